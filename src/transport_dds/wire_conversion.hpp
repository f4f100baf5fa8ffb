// Conversions between a message (a RIDGELINE_WIRE_FIELDS type) and the struct Cyclone's IDL
// compiler generates for it from the IDL this project generates from the same field list
// (idl_writer.hpp). Written once for every message, field by field through the list: the
// C++ and the C struct have the same field names, so a field the list names but the IDL lacks
// (or the reverse) does not compile. For this folder's .cpp files.
//
// Mapping (idl_writer.hpp writes the same): bool, (u)int8 … (u)int64, float, double as
// themselves; std::array<T, N> as T[N];
// an enum as its underlying int32; Vec3 (any 3-vector of doubles) as Vector3_; another fixed
// vector of N doubles as double[N]; std::string as string; std::vector<T> as sequence<T>; a
// WireStruct as its own struct.
#pragma once

#include <fmt/format.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "core/types.hpp"
#include "messages/wire_fields.hpp"

namespace ridgeline::transport_dds {

/// A fixed-size column vector of doubles (Vec3, vehicle::State, vehicle::Input).
template <class T>
struct FixedVector : std::false_type {
  static constexpr int size = 0;
};
template <int N, int Options, int MaxRows, int MaxCols>
struct FixedVector<Eigen::Matrix<double, N, 1, Options, MaxRows, MaxCols>> : std::true_type {
  static_assert(N > 0, "only fixed-size vectors go on the wire");
  static constexpr int size = N;
};

/// std::array<T, N>: an IDL array T name[N] (px4_msgs' float32[3], ...).
template <class T>
struct StdArray : std::false_type {};
template <class T, std::size_t N>
struct StdArray<std::array<T, N>> : std::true_type {
  static constexpr std::size_t size = N;
};

template <class T>
struct StdVector : std::false_type {};
template <class T, class A>
struct StdVector<std::vector<T, A>> : std::true_type {};

/// Storage an outgoing sample's sequences point into while it is written. Each sequence of a
/// sample gets its own block, and a block is kept for the next sample, so a steady stream of
/// samples of one type allocates nothing after its first.
class WireArena {
 public:
  void reset() { used_ = 0; }

  template <class T>
  T* allocate(std::size_t count) {
    static_assert(std::is_trivially_copyable_v<T> && alignof(T) <= alignof(std::max_align_t));
    if (used_ == blocks_.size()) blocks_.emplace_back();
    std::vector<std::max_align_t>& block = blocks_[used_++];
    const std::size_t words =
        (count * sizeof(T) + sizeof(std::max_align_t) - 1) / sizeof(std::max_align_t);
    if (block.size() < words) block.resize(words);
    return reinterpret_cast<T*>(block.data());
  }

 private:
  std::vector<std::vector<std::max_align_t>> blocks_;
  std::size_t used_ = 0;
};

/// Fills the wire struct `w` from `c`. Sequences point into `arena` (valid until its next
/// reset) and strings into `c` itself: `w` is for writing at once, while both live.
template <class C, class W>
void to_wire(const C& c, W& w, WireArena& arena) {
  if constexpr (messages::WireStruct<C>) {
    messages::WireFields<C>::pair(
        c, w, [&](const char*, const auto& cf, auto& wf) { to_wire(cf, wf, arena); });
  } else if constexpr (StdVector<C>::value) {
    using Element = std::remove_pointer_t<decltype(w._buffer)>;
    Element* buffer = arena.allocate<Element>(c.size());
    for (std::size_t k = 0; k < c.size(); ++k) {
      buffer[k] = Element{};
      to_wire(c[k], buffer[k], arena);
    }
    w._maximum = w._length = static_cast<std::uint32_t>(c.size());
    w._buffer = buffer;
    w._release = false;
  } else if constexpr (StdArray<C>::value) {
    static_assert(std::extent_v<W> == StdArray<C>::size, "IDL array of another length");
    for (std::size_t k = 0; k < StdArray<C>::size; ++k) to_wire(c[k], w[k], arena);
  } else if constexpr (FixedVector<C>::value) {
    if constexpr (std::is_array_v<W>) {
      static_assert(std::extent_v<W> == FixedVector<C>::size, "IDL array of another length");
      for (int k = 0; k < FixedVector<C>::size; ++k) w[k] = c[k];
    } else {
      static_assert(FixedVector<C>::size == 3, "a vector that is not 3-D is an IDL array");
      w.x = c.x();
      w.y = c.y();
      w.z = c.z();
    }
  } else if constexpr (std::is_same_v<C, std::string>) {
    w = const_cast<char*>(c.c_str());  // DDS only reads it, during the write
  } else if constexpr (std::is_enum_v<C>) {
    w = static_cast<W>(static_cast<std::underlying_type_t<C>>(c));
  } else {
    static_assert(std::is_arithmetic_v<C> && std::is_arithmetic_v<W> && sizeof(C) == sizeof(W) &&
                      std::is_signed_v<C> == std::is_signed_v<W> &&
                      std::is_floating_point_v<C> == std::is_floating_point_v<W>,
                  "a field's C++ and IDL types differ");
    w = c;
  }
}

/// Fills `c` from the received wire struct `w`. Refuses (returns the reason naming the field) a
/// sequence longer than `max_length` before allocating for it, and a sequence whose length
/// claims elements it has no buffer for; the message's own check comes after.
template <class C, class W>
std::optional<std::string> from_wire(const W& w, C& c, std::uint32_t max_length,
                                     const char* field = "sample") {
  if constexpr (messages::WireStruct<C>) {
    std::optional<std::string> error;
    messages::WireFields<C>::pair(c, w, [&](const char* name, auto& cf, const auto& wf) {
      if (!error) error = from_wire(wf, cf, max_length, name);
    });
    return error;
  } else if constexpr (StdVector<C>::value) {
    if (w._length > max_length)
      return fmt::format("{}: {} elements, at most {}", field, w._length, max_length);
    if (w._length > 0 && w._buffer == nullptr)
      return fmt::format("{}: {} elements without data", field, w._length);
    c.resize(w._length);
    for (std::uint32_t k = 0; k < w._length; ++k)
      if (auto error = from_wire(w._buffer[k], c[k], max_length, field)) return error;
  } else if constexpr (StdArray<C>::value) {
    static_assert(std::extent_v<W> == StdArray<C>::size, "IDL array of another length");
    for (std::size_t k = 0; k < StdArray<C>::size; ++k) c[k] = w[k];
  } else if constexpr (FixedVector<C>::value) {
    if constexpr (std::is_array_v<W>) {
      static_assert(std::extent_v<W> == FixedVector<C>::size, "IDL array of another length");
      for (int k = 0; k < FixedVector<C>::size; ++k) c[k] = w[k];
    } else {
      c = C(w.x, w.y, w.z);
    }
  } else if constexpr (std::is_same_v<C, std::string>) {
    c = w != nullptr ? w : "";
  } else if constexpr (std::is_enum_v<C>) {
    // A scoped enum has a fixed underlying type, so every int32 is one of its values (the
    // message's check says whether it is a named one).
    static_assert(!std::is_convertible_v<C, int>, "only scoped enums go on the wire");
    c = static_cast<C>(w);
  } else {
    c = w;
  }
  return std::nullopt;
}

}  // namespace ridgeline::transport_dds
