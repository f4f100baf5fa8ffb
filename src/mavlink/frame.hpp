// MAVLink v2 frames (mavlink.io, "Packet Serialization"), written from the protocol's
// documentation; no MAVLink library is involved.
//
//   byte   0      start marker 0xFD
//          1      payload length n (after truncation)
//          2      incompatibility flags: a receiver must drop a frame with a flag it does not
//                 know; 0x01 = signed (a 13-byte signature follows the checksum)
//          3      compatibility flags (may be ignored)
//          4      sequence number, 5 system id, 6 component id (of the sender)
//          7..9   message id, 24 bits, little-endian
//          10..   payload, n bytes: the message's fields little-endian, sorted by type size
//                 (largest first, stable), extension fields last in their own order
//          10+n   checksum, little-endian: X.25 over bytes 1..9+n, then the CRC_EXTRA byte
//
// Payload truncation: the sender drops the payload's trailing zero bytes (keeping at least
// one); the receiver zero-extends what arrives to the message's full length. Signing is not
// supported: a signed frame is recognized, counted and dropped.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace ridgeline::mavlink {

constexpr std::uint8_t kStartByteV2 = 0xFD;
constexpr std::size_t kHeaderSize = 10;  ///< start marker through message id
constexpr std::size_t kChecksumSize = 2;
constexpr std::size_t kSignatureSize = 13;
constexpr std::size_t kMaxPayloadSize = 255;
constexpr std::size_t kMinFrameSize = kHeaderSize + kChecksumSize;  ///< empty payload
constexpr std::size_t kMaxFrameSize = kHeaderSize + kMaxPayloadSize + kChecksumSize + kSignatureSize;
constexpr std::uint8_t kIncompatFlagSigned = 0x01;

/// What a receiver must know of a message id to check and decode its frames.
struct MessageSpec {
  std::uint32_t id = 0;
  std::string_view name;
  std::uint8_t crc_extra = 0;
  std::uint8_t payload_size = 0;  ///< untruncated, extensions included
};

/// The messages this implementation knows (messages.hpp), or nullptr.
const MessageSpec* find_message_spec(std::uint32_t message_id);

/// One frame's header and its payload, zero-extended to the message's full length.
struct Frame {
  std::uint8_t incompat_flags = 0;
  std::uint8_t compat_flags = 0;
  std::uint8_t sequence = 0;
  std::uint8_t system_id = 0;
  std::uint8_t component_id = 0;
  std::uint32_t message_id = 0;
  std::uint8_t wire_payload_size = 0;  ///< as received (after the sender's truncation)
  std::uint16_t checksum = 0;          ///< as received (verified)
  std::array<std::uint8_t, kMaxPayloadSize> payload{};
};

/// The sender's part of a header.
struct FrameHeader {
  std::uint8_t sequence = 0;
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 1;
  std::uint8_t compat_flags = 0;
};

struct EncodedFrame {
  std::array<std::uint8_t, kMaxFrameSize> bytes{};
  std::size_t size = 0;
  std::span<const std::uint8_t> view() const { return {bytes.data(), size}; }
};

/// Frames `payload` (the message's untruncated payload, exactly spec.payload_size bytes) with
/// truncation and the checksum. Throws ridgeline::InputError (field `message_id` or
/// `payload`) for an unknown id or a payload of the wrong size.
EncodedFrame encode_frame(const FrameHeader& header, std::uint32_t message_id,
                          std::span<const std::uint8_t> payload);

/// Why a candidate frame was accepted or not. Every rejection is counted by the parser.
enum class FrameStatus : int {
  kOk = 0,
  kIncomplete,              ///< fewer bytes than the header's length announces (wait for more)
  kBadStartByte,            ///< byte 0 is not 0xFD
  kUnsupportedIncompatFlags,///< an incompatibility flag other than "signed"
  kUnknownMessage,          ///< no CRC_EXTRA known for the id, so nothing can be checked
  kBadLength,               ///< payload longer than the message's full length
  kBadChecksum,
  kSignedUnsupported,       ///< a well-formed signed frame; signatures are not verified here
};
constexpr int kFrameStatusCount = 8;
std::string_view to_string(FrameStatus status);

struct DecodeResult {
  FrameStatus status = FrameStatus::kIncomplete;
  std::size_t frame_size = 0;  ///< bytes the frame occupies (known once the header is complete)
};

/// Checks and decodes the frame at the start of `bytes` (which may hold more after it).
/// `frame` is written only when the status is kOk. Never throws; reads no byte beyond `bytes`.
DecodeResult decode_frame(std::span<const std::uint8_t> bytes, Frame& frame);

}  // namespace ridgeline::mavlink
