// The checksum of a MAVLink frame: CRC-16/MCRF4XX, which MAVLink's documentation calls "X.25"
// (polynomial x¹⁶ + x¹² + x⁵ + 1, reflected, initial value 0xFFFF, no final inversion).
//
// A frame's checksum runs over every byte after the start marker up to the end of the payload,
// then over the message's CRC_EXTRA byte, which is not sent: a receiver whose definition of the
// message differs from the sender's (field order, types, names) computes another checksum and
// drops the frame instead of misreading it.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace ridgeline::mavlink {

constexpr std::uint16_t kX25InitialValue = 0xFFFF;

/// Folds one byte into a running checksum (the byte-wise form of the reflected polynomial
/// 0x8408: the byte is XORed into the low half, then its 8 bits are shifted out at once).
constexpr std::uint16_t x25_accumulate(std::uint8_t byte, std::uint16_t crc) {
  std::uint8_t t = static_cast<std::uint8_t>(byte ^ (crc & 0xFF));
  t = static_cast<std::uint8_t>(t ^ (t << 4));
  return static_cast<std::uint16_t>((crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4));
}

constexpr std::uint16_t x25_accumulate(std::span<const std::uint8_t> bytes, std::uint16_t crc) {
  for (const std::uint8_t b : bytes) crc = x25_accumulate(b, crc);
  return crc;
}

constexpr std::uint16_t x25_accumulate(std::string_view text, std::uint16_t crc) {
  for (const char c : text) crc = x25_accumulate(static_cast<std::uint8_t>(c), crc);
  return crc;
}

}  // namespace ridgeline::mavlink
