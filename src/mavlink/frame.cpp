#include "mavlink/frame.hpp"

#include <algorithm>
#include <string>

#include "core/error.hpp"
#include "mavlink/x25_crc.hpp"

namespace ridgeline::mavlink {

std::string_view to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::kOk: return "ok";
    case FrameStatus::kIncomplete: return "incomplete";
    case FrameStatus::kBadStartByte: return "bad start byte";
    case FrameStatus::kUnsupportedIncompatFlags: return "unsupported incompatibility flags";
    case FrameStatus::kUnknownMessage: return "unknown message id";
    case FrameStatus::kBadLength: return "payload longer than the message";
    case FrameStatus::kBadChecksum: return "bad checksum";
    case FrameStatus::kSignedUnsupported: return "signed frame (signing not supported)";
  }
  return "invalid status";
}

EncodedFrame encode_frame(const FrameHeader& header, std::uint32_t message_id,
                          std::span<const std::uint8_t> payload) {
  const MessageSpec* spec = find_message_spec(message_id);
  if (spec == nullptr)
    throw InputError("message_id", std::to_string(message_id) + " is not a known message");
  if (payload.size() != spec->payload_size)
    throw InputError("payload", std::string(spec->name) + " needs " +
                                    std::to_string(spec->payload_size) + " bytes, got " +
                                    std::to_string(payload.size()));
  // Truncation keeps the first byte even when everything is zero (MAVLink's own rule).
  std::size_t n = payload.size();
  while (n > 1 && payload[n - 1] == 0) --n;

  EncodedFrame out;
  std::uint8_t* b = out.bytes.data();
  b[0] = kStartByteV2;
  b[1] = static_cast<std::uint8_t>(n);
  b[2] = 0;  // incompatibility flags: not signed
  b[3] = header.compat_flags;
  b[4] = header.sequence;
  b[5] = header.system_id;
  b[6] = header.component_id;
  b[7] = static_cast<std::uint8_t>(message_id & 0xFF);
  b[8] = static_cast<std::uint8_t>((message_id >> 8) & 0xFF);
  b[9] = static_cast<std::uint8_t>((message_id >> 16) & 0xFF);
  std::copy_n(payload.begin(), n, b + kHeaderSize);
  std::uint16_t crc = x25_accumulate(std::span<const std::uint8_t>(b + 1, kHeaderSize - 1 + n),
                                     kX25InitialValue);
  crc = x25_accumulate(spec->crc_extra, crc);
  b[kHeaderSize + n] = static_cast<std::uint8_t>(crc & 0xFF);
  b[kHeaderSize + n + 1] = static_cast<std::uint8_t>(crc >> 8);
  out.size = kHeaderSize + n + kChecksumSize;
  return out;
}

DecodeResult decode_frame(std::span<const std::uint8_t> bytes, Frame& frame) {
  if (bytes.empty()) return {FrameStatus::kIncomplete, 0};
  if (bytes[0] != kStartByteV2) return {FrameStatus::kBadStartByte, 0};
  if (bytes.size() < kHeaderSize) return {FrameStatus::kIncomplete, 0};
  const std::size_t n = bytes[1];
  const std::uint8_t incompat = bytes[2];
  const bool is_signed = (incompat & kIncompatFlagSigned) != 0;
  const std::size_t frame_size =
      kHeaderSize + n + kChecksumSize + (is_signed ? kSignatureSize : 0);
  // Flags are judged before waiting for the rest: a receiver that cannot interpret a frame
  // must not hold up the stream for up to 280 bytes it will drop anyway.
  if ((incompat & ~kIncompatFlagSigned) != 0)
    return {FrameStatus::kUnsupportedIncompatFlags, frame_size};
  const std::uint32_t id = static_cast<std::uint32_t>(bytes[7]) |
                           (static_cast<std::uint32_t>(bytes[8]) << 8) |
                           (static_cast<std::uint32_t>(bytes[9]) << 16);
  const MessageSpec* spec = find_message_spec(id);
  if (spec == nullptr) return {FrameStatus::kUnknownMessage, frame_size};
  if (n > spec->payload_size) return {FrameStatus::kBadLength, frame_size};
  if (bytes.size() < frame_size) return {FrameStatus::kIncomplete, frame_size};

  std::uint16_t crc =
      x25_accumulate(bytes.subspan(1, kHeaderSize - 1 + n), kX25InitialValue);
  crc = x25_accumulate(spec->crc_extra, crc);
  const std::uint16_t sent = static_cast<std::uint16_t>(
      bytes[kHeaderSize + n] | (static_cast<std::uint16_t>(bytes[kHeaderSize + n + 1]) << 8));
  if (crc != sent) return {FrameStatus::kBadChecksum, frame_size};
  if (is_signed) return {FrameStatus::kSignedUnsupported, frame_size};

  frame.incompat_flags = incompat;
  frame.compat_flags = bytes[3];
  frame.sequence = bytes[4];
  frame.system_id = bytes[5];
  frame.component_id = bytes[6];
  frame.message_id = id;
  frame.wire_payload_size = static_cast<std::uint8_t>(n);
  frame.checksum = sent;
  frame.payload.fill(0);
  std::copy_n(bytes.begin() + kHeaderSize, n, frame.payload.begin());
  return {FrameStatus::kOk, frame_size};
}

}  // namespace ridgeline::mavlink
