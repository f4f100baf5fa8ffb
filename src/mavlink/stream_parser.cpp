#include "mavlink/stream_parser.hpp"

#include <algorithm>

namespace ridgeline::mavlink {

std::uint64_t ParserStats::rejected() const {
  std::uint64_t n = 0;
  for (int s = 0; s < kFrameStatusCount; ++s)
    if (s != static_cast<int>(FrameStatus::kOk) && s != static_cast<int>(FrameStatus::kIncomplete))
      n += frames[static_cast<std::size_t>(s)];
  return n;
}

void StreamParser::push(std::span<const std::uint8_t> bytes, const FrameHandler& on_frame) {
  stats_.bytes_in += bytes.size();
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  std::size_t pos = 0;
  const std::size_t size = buffer_.size();
  while (pos < size) {
    if (buffer_[pos] != kStartByteV2) {
      const auto next = std::find(buffer_.begin() + static_cast<std::ptrdiff_t>(pos),
                                  buffer_.end(), kStartByteV2);
      const std::size_t skip = static_cast<std::size_t>(next - buffer_.begin()) - pos;
      stats_.bytes_skipped += skip;
      pos += skip;
      continue;
    }
    const std::span<const std::uint8_t> candidate(buffer_.data() + pos, size - pos);
    const DecodeResult r = decode_frame(candidate, frame_);
    if (r.status == FrameStatus::kIncomplete) break;
    ++stats_.frames[static_cast<std::size_t>(r.status)];
    if (r.status == FrameStatus::kOk) {
      pos += r.frame_size;
      if (on_frame) on_frame(frame_);
    } else if (r.status == FrameStatus::kSignedUnsupported) {
      // A genuine frame (its checksum holds): skip it whole.
      stats_.bytes_skipped += r.frame_size;
      pos += r.frame_size;
    } else {
      ++stats_.bytes_skipped;
      ++pos;
    }
  }
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(pos));
}

}  // namespace ridgeline::mavlink
