// Helpers the MAVLink tests share: hex, random messages, and an independent reference for
// the checksum (bit by bit, from the polynomial, unlike src/mavlink's byte-wise form) with the
// CRC_EXTRA values and lengths published in the MAVLink definitions.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <span>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

#include "mavlink/frame.hpp"
#include "mavlink/messages.hpp"

namespace ridgeline::mavlink::testing {

inline std::string to_hex(std::span<const std::uint8_t> bytes) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (const std::uint8_t b : bytes) {
    s += digits[b >> 4];
    s += digits[b & 15];
  }
  return s;
}

inline std::vector<std::uint8_t> from_hex(const std::string& hex) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

/// CRC-16/MCRF4XX bit by bit: reflected polynomial 0x8408, init 0xFFFF, no final XOR.
inline std::uint16_t reference_crc(std::span<const std::uint8_t> bytes, std::uint16_t crc = 0xFFFF) {
  for (const std::uint8_t b : bytes) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0x8408) : static_cast<std::uint16_t>(crc >> 1);
  }
  return crc;
}

struct PublishedSpec {
  std::uint8_t crc_extra;
  std::uint8_t length;
};
/// common.xml / minimal.xml as published (message id → CRC_EXTRA, payload length).
inline const std::map<std::uint32_t, PublishedSpec>& published_specs() {
  static const std::map<std::uint32_t, PublishedSpec> specs = {
      {0, {50, 9}}, {30, {39, 28}}, {32, {185, 28}}, {76, {152, 33}}, {84, {143, 53}}};
  return specs;
}

/// A random value of a field's type; floats are random bit patterns when `any_bits` (NaN and
/// infinities included), else finite values of mixed magnitude, with zeros now and then so
/// truncation is exercised.
template <class T>
T random_value(std::mt19937_64& rng, bool any_bits) {
  std::uniform_int_distribution<int> pick(0, 9);
  if (pick(rng) == 0) return T{0};
  if constexpr (std::is_same_v<T, float>) {
    if (any_bits) return std::bit_cast<float>(static_cast<std::uint32_t>(rng()));
    std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
    std::uniform_int_distribution<int> exponent(-10, 12);
    return std::ldexp(mantissa(rng), exponent(rng));
  } else {
    return static_cast<T>(rng());
  }
}

template <class M>
M random_message(std::mt19937_64& rng, bool any_bits) {
  M m{};
  std::apply(
      [&](const auto&... f) {
        ((m.*(f.member) = random_value<std::remove_cvref_t<decltype(m.*(f.member))>>(rng, any_bits)),
         ...);
      },
      M::fields);
  // Trailing fields zero in a quarter of the messages: truncation removes them on the wire.
  if (std::uniform_int_distribution<int>(0, 3)(rng) == 0) {
    bool zero = true;
    std::apply(
        [&](const auto&... f) {
          std::size_t i = 0, n = sizeof...(f), keep = static_cast<std::size_t>(rng() % n);
          ((zero = (i++ >= keep), zero ? void(m.*(f.member) = {}) : void()), ...);
        },
        M::fields);
  }
  return m;
}

inline Message random_any_message(std::mt19937_64& rng, bool any_bits) {
  switch (rng() % 5) {
    case 0: return random_message<Heartbeat>(rng, any_bits);
    case 1: return random_message<Attitude>(rng, any_bits);
    case 2: return random_message<LocalPositionNed>(rng, any_bits);
    case 3: return random_message<CommandLong>(rng, any_bits);
    default: return random_message<SetPositionTargetLocalNed>(rng, any_bits);
  }
}

inline FrameHeader random_header(std::mt19937_64& rng) {
  return {static_cast<std::uint8_t>(rng()), static_cast<std::uint8_t>(rng() % 255 + 1),
          static_cast<std::uint8_t>(rng() % 255 + 1), 0};
}

}  // namespace ridgeline::mavlink::testing
