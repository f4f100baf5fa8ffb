// The field list of a message type, written once beside its definition, from which everything
// on the wire is generated: the DDS IDL (transport_dds/idl/, at build time) and the conversions
// to and from the IDL compiler's types (transport_dds/wire_conversion.hpp). A field added to a
// message and to its list reaches the IDL, DDS and every process without another edit; a field
// missing from the list is a compile error in the conversion (the IDL type would lack it).
//
//   struct ThreatReport { int reporter = -1; ... };
//   RIDGELINE_WIRE_FIELDS(ThreatReport, "ThreatReport", reporter, threat_id, ...)
//
// declares, in the type's namespace, a description found by argument-dependent lookup:
//   WireFields<T>::name             the wire name (the IDL struct is `name` + "_", ROS 2's rule)
//   WireFields<T>::each(m, f)       f("field", m.field) for each field, in order
//   WireFields<T>::pair(m, w, f)    f("field", m.field, w.field): the same field of another type
//                                   with the same field names (the IDL compiler's struct)
#pragma once

#include <type_traits>
#include <utility>

// Applies `macro` to each of up to 256 arguments (C++20 __VA_OPT__ recursion).
#define RIDGELINE_WIRE_PARENS ()
#define RIDGELINE_WIRE_EXPAND(...) \
  RIDGELINE_WIRE_EXPAND4(RIDGELINE_WIRE_EXPAND4(RIDGELINE_WIRE_EXPAND4(__VA_ARGS__)))
#define RIDGELINE_WIRE_EXPAND4(...) \
  RIDGELINE_WIRE_EXPAND3(RIDGELINE_WIRE_EXPAND3(RIDGELINE_WIRE_EXPAND3(__VA_ARGS__)))
#define RIDGELINE_WIRE_EXPAND3(...) \
  RIDGELINE_WIRE_EXPAND2(RIDGELINE_WIRE_EXPAND2(RIDGELINE_WIRE_EXPAND2(__VA_ARGS__)))
#define RIDGELINE_WIRE_EXPAND2(...) __VA_ARGS__
#define RIDGELINE_WIRE_FOR_EACH(macro, ...) \
  __VA_OPT__(RIDGELINE_WIRE_EXPAND(RIDGELINE_WIRE_FOR_EACH_STEP(macro, __VA_ARGS__)))
#define RIDGELINE_WIRE_FOR_EACH_STEP(macro, first, ...) \
  macro(first) __VA_OPT__(RIDGELINE_WIRE_FOR_EACH_AGAIN RIDGELINE_WIRE_PARENS(macro, __VA_ARGS__))
#define RIDGELINE_WIRE_FOR_EACH_AGAIN() RIDGELINE_WIRE_FOR_EACH_STEP

#define RIDGELINE_WIRE_VISIT_ONE(field) f(#field, m.field);
#define RIDGELINE_WIRE_PAIR_ONE(field) f(#field, m.field, w.field);

/// Declares the wire description of `Type` (see above); use in Type's namespace.
#define RIDGELINE_WIRE_FIELDS(Type, wire_name, ...)                  \
  struct Type##WireFields {                                          \
    using Message = Type;                                            \
    static constexpr const char* name = wire_name;                   \
    template <class M, class F>                                      \
    static void each(M& m, F&& f) {                                  \
      RIDGELINE_WIRE_FOR_EACH(RIDGELINE_WIRE_VISIT_ONE, __VA_ARGS__) \
    }                                                                \
    template <class M, class W, class F>                             \
    static void pair(M& m, W& w, F&& f) {                            \
      RIDGELINE_WIRE_FOR_EACH(RIDGELINE_WIRE_PAIR_ONE, __VA_ARGS__)  \
    }                                                                \
  };                                                                 \
  inline Type##WireFields ridgeline_wire_fields(const Type*) { return {}; }

namespace ridgeline::messages {

/// A type with a RIDGELINE_WIRE_FIELDS list.
template <class T>
concept WireStruct = requires {
  ridgeline_wire_fields(static_cast<const T*>(nullptr));
};

/// The field list of a WireStruct.
template <WireStruct T>
using WireFields = decltype(ridgeline_wire_fields(static_cast<const T*>(nullptr)));

}  // namespace ridgeline::messages
