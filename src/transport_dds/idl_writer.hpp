// Writes Ridgeline's DDS IDL from the messages' RIDGELINE_WIRE_FIELDS lists and the topics'
// table (topics.hpp), so the IDL is never a second definition of a message: the build runs
// ridgeline-idl-writer (idl/write_idl.cpp) and feeds its output to Cyclone's idlc. The mapping
// of field types is wire_conversion.hpp's. No DDS type here.
#pragma once

#include <fmt/format.h>

#include <set>
#include <string>
#include <type_traits>
#include <utility>

#include "messages/wire_fields.hpp"
#include "transport_dds/topics.hpp"
#include "transport_dds/wire_conversion.hpp"

namespace ridgeline::transport_dds {

class IdlWriter {
 public:
  /// The IDL of module `package`::msg::dds_ (ROS 2's mapping of package/msg/Name), its file
  /// starting with `heading` (// lines: what the types are and where they are defined).
  IdlWriter(std::string package, std::string heading)
      : package_(std::move(package)), heading_(std::move(heading)) {}

  /// Adds the struct of message type M and of every struct it uses, with M's topic.
  template <class M>
  void add_topic() {
    static_assert(messages::WireStruct<M>);
    add_struct<M>(&Topic<M>::spec);
  }

  /// The whole IDL file.
  std::string text() const {
    return heading_ +
           "// Every struct is @final (XCDR1, what ROS 2's rmw implementations use). Sequences "
           "are\n"
           "// unbounded on the wire: their lengths are checked by the receiver.\n" +
           fmt::format("module {} {{\nmodule msg {{\nmodule dds_ {{\n\n", package_) + body_ +
           fmt::format("}};  // module dds_\n}};  // module msg\n}};  // module {}\n", package_);
  }

 private:
  template <class T>
  void add_struct(const TopicSpec* topic) {
    const std::string name = std::string(messages::WireFields<T>::name) + "_";
    if (!emitted_.insert(name).second) return;
    std::string fields;
    T sample{};
    messages::WireFields<T>::each(sample, [&](const char* field, const auto& value) {
      const bool key = topic != nullptr && std::string(topic->key) == field;
      fields += fmt::format("  {}{};\n", key ? "@key " : "",
                            declaration<std::remove_cvref_t<decltype(value)>>(field));
    });
    if (topic != nullptr)
      body_ += fmt::format("// Topic {}, {}.\n{}\n", topic->name, qos_text(*topic),
                           comment(topic->about));
    body_ += fmt::format("@final struct {} {{\n{}}};\n\n", name, fields);
  }

  void add_vector3() {
    if (emitted_.insert("Vector3_").second)
      body_ += "@final struct Vector3_ {\n  double x;\n  double y;\n  double z;\n};\n\n";
  }

  /// "type name" (or "double name[N]") of a field, after adding the structs it uses.
  template <class T>
  std::string declaration(const char* field) {
    if constexpr (StdArray<T>::value)
      return fmt::format("{} {}[{}]", type_name<typename T::value_type>(), field,
                         StdArray<T>::size);
    else if constexpr (FixedVector<T>::value && FixedVector<T>::size != 3)
      return fmt::format("double {}[{}]", field, FixedVector<T>::size);
    else
      return fmt::format("{} {}", type_name<T>(), field);
  }

  template <class T>
  std::string type_name() {
    if constexpr (messages::WireStruct<T>) {
      add_struct<T>(nullptr);
      return std::string(messages::WireFields<T>::name) + "_";
    } else if constexpr (StdVector<T>::value) {
      return "sequence<" + type_name<typename T::value_type>() + ">";
    } else if constexpr (FixedVector<T>::value) {
      static_assert(FixedVector<T>::size == 3, "an IDL array cannot be a sequence's element");
      add_vector3();
      return "Vector3_";
    } else if constexpr (std::is_same_v<T, std::string>) {
      return "string";
    } else if constexpr (std::is_enum_v<T>) {
      return type_name<std::underlying_type_t<T>>();
    } else if constexpr (std::is_same_v<T, bool>) {
      return "boolean";
    } else if constexpr (std::is_floating_point_v<T>) {
      static_assert(sizeof(T) == 8 || sizeof(T) == 4, "float32 or float64 on the wire");
      return sizeof(T) == 8 ? "double" : "float";
    } else {
      // IDL 4's int8 … uint64 (idlc and fastddsgen both read them; ROS 2 writes them too).
      static_assert(std::is_integral_v<T> && !std::is_same_v<T, char>);
      return fmt::format("{}int{}", std::is_signed_v<T> ? "" : "u", 8 * sizeof(T));
    }
  }

  static std::string qos_text(const TopicSpec& topic) {
    const std::string per_key = topic.key[0] != '\0' ? std::string(" per ") + topic.key : "";
    switch (topic.qos) {
      case TopicQos::kLatestBestEffort:
        return fmt::format("best effort, keep last 1{}", per_key);
      case TopicQos::kReliable:
        return fmt::format("reliable, keep last {}{}", topic.depth, per_key);
      case TopicQos::kReliableLatched:
        return fmt::format("reliable, transient local, keep last 1{}", per_key);
      case TopicQos::kPx4Publisher:
        return "best effort, transient local, keep last 1 (PX4's publishers)";
      case TopicQos::kPx4Subscriber:
        return "best effort, volatile, keep last 1 (PX4's subscribers)";
    }
    return "";
  }

  /// `text` as // lines of at most about 96 characters.
  static std::string comment(const std::string& text) {
    std::string out, line;
    std::size_t start = 0;
    while (start < text.size()) {
      std::size_t end = text.find(' ', start);
      if (end == std::string::npos) end = text.size();
      const std::string word = text.substr(start, end - start);
      if (!line.empty() && line.size() + 1 + word.size() > 93) {
        out += "// " + line + "\n";
        line.clear();
      }
      line += (line.empty() ? "" : " ") + word;
      start = end + 1;
    }
    if (!line.empty()) out += "// " + line;
    return out;
  }

  std::string package_;
  std::string heading_;
  std::set<std::string> emitted_;
  std::string body_;
};

/// The IDL of every topic Ridgeline publishes.
inline std::string ridgeline_idl() {
  IdlWriter writer(
      "ridgeline",
      "// Ridgeline's DDS message types. GENERATED by ridgeline-idl-writer from the\n"
      "// RIDGELINE_WIRE_FIELDS lists of the messages (src/messages/messages.hpp,\n"
      "// src/swarm/uav_agent.hpp, src/transport_dds/sim_messages.hpp) and the topics "
      "of\n// src/transport_dds/topics.hpp: edit those, not this file.\n"
      "// Module path and the trailing underscore follow ROS 2's mapping of a message\n"
      "// ridgeline/msg/Name to the DDS type ridgeline::msg::dds_::Name_. Units: SI "
      "(m, s, rad),\n// positions ENU.\n");
  writer.add_topic<messages::PredictedTrajectory>();
  writer.add_topic<messages::ThreatReport>();
  writer.add_topic<messages::StateReport>();
  writer.add_topic<messages::ReferencePlan>();
  writer.add_topic<ClockTick>();
  writer.add_topic<Measurement>();
  writer.add_topic<CommandReport>();
  return writer.text();
}

/// The IDL of PX4's topics Ridgeline uses (px4_messages.hpp): px4_msgs::msg::dds_, PX4 v1.14.
inline std::string px4_msgs_idl() {
  IdlWriter writer(
      "px4_msgs",
      "// PX4's px4_msgs types (PX4 v1.14), as its uXRCE-DDS bridge puts them on the\n"
      "// wire. GENERATED by ridgeline-idl-writer from the RIDGELINE_WIRE_FIELDS lists\n"
      "// of src/transport_dds/px4_messages.hpp and the topics of\n"
      "// src/transport_dds/topics.hpp: edit those, not this file. Units and frames\n"
      "// are PX4's: NED metres about home, radians, microseconds since boot; a\n"
      "// vehicle in namespace uav_N has its topics under rt/uav_N/fmu/.\n");
  writer.add_topic<px4::OffboardControlMode>();
  writer.add_topic<px4::TrajectorySetpoint>();
  writer.add_topic<px4::VehicleCommand>();
  writer.add_topic<px4::VehicleOdometry>();
  writer.add_topic<px4::VehicleStatus>();
  return writer.text();
}

}  // namespace ridgeline::transport_dds
