// Splits a byte stream (serial bytes, or UDP datagrams one after another) into MAVLink v2
// frames, resynchronizing on garbage.
//
// The parser looks for the start marker 0xFD, waits until the header's length has arrived,
// and checks the candidate with decode_frame(). A rejected candidate costs one byte: the
// search resumes at the byte after its 0xFD, never after the whole candidate, because a 0xFD
// in noise can announce a length that swallows the start of the next real frame. So a real
// frame is found whatever garbage precedes it; a false candidate is accepted only if noise
// happens to carry a known id, a valid length and the right 16-bit checksum for them.
//
// Memory is bounded: at most one maximal frame (280 bytes) is kept between calls.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "mavlink/frame.hpp"

namespace ridgeline::mavlink {

/// What the parser has seen, by outcome (FrameStatus::kIncomplete is never counted).
struct ParserStats {
  std::array<std::uint64_t, kFrameStatusCount> frames{};  ///< indexed by FrameStatus
  std::uint64_t bytes_in = 0;
  std::uint64_t bytes_skipped = 0;  ///< bytes not part of an accepted frame

  std::uint64_t accepted() const { return frames[static_cast<int>(FrameStatus::kOk)]; }
  std::uint64_t count(FrameStatus s) const { return frames[static_cast<int>(s)]; }
  std::uint64_t rejected() const;
};

class StreamParser {
 public:
  using FrameHandler = std::function<void(const Frame&)>;

  /// Feeds bytes; calls `on_frame` for every frame accepted, in stream order.
  void push(std::span<const std::uint8_t> bytes, const FrameHandler& on_frame);

  const ParserStats& stats() const { return stats_; }
  /// Bytes held back waiting for the rest of a candidate frame.
  std::size_t pending_bytes() const { return buffer_.size(); }

 private:
  std::vector<std::uint8_t> buffer_;
  Frame frame_;
  ParserStats stats_;
};

}  // namespace ridgeline::mavlink
