// The IDL generated from the messages' field lists, and the field-by-field conversions to and
// from a wire struct (here a hand-made struct shaped as idlc makes them, so these run without
// DDS; the DDS round trips are in dds_transport_test.cpp).
#include "transport_dds/idl_writer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <regex>
#include <string>
#include <vector>

namespace ridgeline::transport_dds {
namespace {

std::string struct_body(const std::string& idl, const std::string& name) {
  const std::size_t start = idl.find("@final struct " + name + " {");
  if (start == std::string::npos) return "";
  return idl.substr(start, idl.find("};", start) - start);
}

TEST(IdlWriter, EveryTopicsTypeWithItsKeyAndEveryFieldOfItsList) {
  const std::string idl = ridgeline_idl();
  for (const char* topic :
       {"rt/ridgeline/predicted_trajectory", "rt/ridgeline/threat_report", "rt/ridgeline/state",
        "rt/ridgeline/reference_plan", "rt/ridgeline/clock", "rt/ridgeline/measurement",
        "rt/ridgeline/command"})
    EXPECT_NE(idl.find(std::string("// Topic ") + topic + ","), std::string::npos) << topic;

  const std::string prediction = struct_body(idl, "PredictedTrajectory_");
  EXPECT_NE(prediction.find("@key int32 uav;"), std::string::npos) << prediction;
  EXPECT_NE(prediction.find("sequence<Vector3_> positions_m;"), std::string::npos);
  // A topic without a key has none.
  EXPECT_EQ(struct_body(idl, "ThreatReport_").find("@key"), std::string::npos);
  EXPECT_EQ(struct_body(idl, "Clock_").find("@key"), std::string::npos);
  // A 7-vector is an array, a 3-vector a Vector3_, an enum its int32, counters their struct.
  EXPECT_NE(struct_body(idl, "State_").find("double state[7];"), std::string::npos);
  const std::string command = struct_body(idl, "Command_");
  EXPECT_NE(command.find("Vector3_ command;"), std::string::npos) << command;
  EXPECT_NE(command.find("int32 mode;"), std::string::npos);
  EXPECT_NE(command.find("sequence<string> missed_targets;"), std::string::npos);
  EXPECT_NE(command.find("AgentCounters_ counters;"), std::string::npos);
  EXPECT_NE(struct_body(idl, "AgentCounters_").find("uint64 threat_reports_sent;"),
            std::string::npos);
  EXPECT_NE(struct_body(idl, "ReferencePlan_").find("sequence<ReferencePoint_> points;"),
            std::string::npos);
  EXPECT_NE(struct_body(idl, "Clock_").find("sequence<int64> reports_sent;"), std::string::npos);

  // Each field of a list appears once in its struct, in the list's order.
  std::vector<std::string> names;
  CommandReport report;
  messages::WireFields<CommandReport>::each(
      report, [&](const char* name, const auto&) { names.push_back(name); });
  std::size_t at = 0;
  for (const std::string& name : names) {
    const std::regex field("[ <>\\w]+ " + name + "(\\[\\d+\\])?;");
    std::smatch m;
    const std::string rest = command.substr(at);
    ASSERT_TRUE(std::regex_search(rest, m, field)) << name << " after " << at;
    at += static_cast<std::size_t>(m.position(0) + m.length(0));
  }

  // A struct is declared before the first struct that uses it (IDL needs it).
  for (const char* used : {"Vector3_", "ReferencePoint_", "SensedThreat_", "AgentCounters_"}) {
    const std::size_t declared = idl.find(std::string("@final struct ") + used + " {");
    ASSERT_NE(declared, std::string::npos) << used;
    EXPECT_EQ(idl.find(std::string(used)), idl.find(std::string("@final struct ") + used) + 14)
        << used << " is used before it is declared";
  }
}

// A wire struct shaped as idlc's C output: sequences as {_maximum, _length, _buffer, _release}.
struct WireVector3 {
  double x, y, z;
};
struct WireSensed {
  std::int32_t threat_id;
  WireVector3 centre_m, velocity_m_s;
  double radius_m;
};
struct WireSensedSequence {
  std::uint32_t _maximum, _length;
  WireSensed* _buffer;
  bool _release;
};
struct WireMeasurement {
  std::int32_t uav;
  std::uint64_t tick;
  double t_s;
  double state[7];
  WireVector3 wind_m_s;
  WireSensedSequence threats;
};

TEST(WireConversion, AMeasurementRoundTripsFieldByField) {
  Measurement m;
  m.uav = 2;
  m.tick = 99;
  m.t_s = 1.98;
  m.state << 1, 2, 3, 0.4, 10, -0.1, 0.5;
  m.wind_m_s = Vec3(3, -1, 0.25);
  m.threats = {{4, Vec3(1, 2, 3), Vec3(-1, 0, 0), 40.0}, {7, Vec3(5, 6, 7), Vec3(0, 1, 0), 25.0}};
  WireArena arena;
  WireMeasurement w{};
  to_wire(m, w, arena);
  EXPECT_EQ(w.uav, 2);
  EXPECT_EQ(w.state[3], 0.4);
  EXPECT_EQ(w.wind_m_s.z, 0.25);
  ASSERT_EQ(w.threats._length, 2u);
  EXPECT_FALSE(w.threats._release);  // DDS must not free the arena's storage
  EXPECT_EQ(w.threats._buffer[1].centre_m.y, 6.0);

  Measurement back;
  ASSERT_FALSE(from_wire(w, back, 10).has_value());
  EXPECT_EQ(back.uav, m.uav);
  EXPECT_EQ(back.tick, m.tick);
  EXPECT_EQ(back.state, m.state);
  EXPECT_EQ(back.wind_m_s, m.wind_m_s);
  ASSERT_EQ(back.threats.size(), 2u);
  EXPECT_EQ(back.threats[1].threat_id, 7);
  EXPECT_EQ(back.threats[1].velocity_m_s, Vec3(0, 1, 0));
  EXPECT_EQ(back.threats[0].radius_m, 40.0);

  // The arena's storage is reused: a second sample of the same shape gets the same buffer.
  const WireSensed* first = w.threats._buffer;
  WireMeasurement again{};
  arena.reset();
  to_wire(m, again, arena);
  EXPECT_EQ(again.threats._buffer, first);
}

TEST(WireConversion, ASequenceLongerThanTheBoundOrWithoutDataIsRefusedNamingTheField) {
  WireMeasurement w{};
  w.threats._length = 4000000000u;  // a forged length: refused before any allocation
  Measurement m;
  const auto reason = from_wire(w, m, 1000);
  ASSERT_TRUE(reason.has_value());
  EXPECT_EQ(*reason, "threats: 4000000000 elements, at most 1000");
  w.threats._length = 3;  // and no buffer
  EXPECT_EQ(from_wire(w, m, 1000).value_or(""), "threats: 3 elements without data");
}

// PX4's px4_msgs (PX4 v1.14) in their own module, with PX4's field types (float32[3] as
// float[3], uint8, int8, uint16, uint32, uint64), every field in its message's order, and the
// QoS of PX4's publishers and subscribers.
TEST(IdlWriter, Px4MessagesAreInPx4MsgsModuleWithPx4sFieldTypesAndQos) {
  const std::string idl = px4_msgs_idl();
  EXPECT_NE(idl.find("module px4_msgs {\nmodule msg {\nmodule dds_ {"), std::string::npos);
  EXPECT_EQ(idl.find("module ridgeline"), std::string::npos);
  EXPECT_NE(idl.find("// Topic rt/fmu/in/trajectory_setpoint, best effort, volatile, keep last 1 "
                     "(PX4's subscribers)."),
            std::string::npos);
  EXPECT_NE(idl.find("// Topic rt/fmu/out/vehicle_odometry, best effort, transient local, keep "
                     "last 1 (PX4's publishers)."),
            std::string::npos);
  for (const char* topic : {"rt/fmu/in/offboard_control_mode", "rt/fmu/in/vehicle_command",
                            "rt/fmu/out/vehicle_status"})
    EXPECT_NE(idl.find(std::string("// Topic ") + topic + ","), std::string::npos) << topic;
  const std::string setpoint = struct_body(idl, "TrajectorySetpoint_");
  EXPECT_NE(setpoint.find("  uint64 timestamp;\n  float position[3];\n  float velocity[3];\n  "
                          "float acceleration[3];\n  float jerk[3];\n  float yaw;\n  float "
                          "yawspeed;\n"),
            std::string::npos)
      << setpoint;
  const std::string odometry = struct_body(idl, "VehicleOdometry_");
  EXPECT_NE(odometry.find("uint8 pose_frame;\n  float position[3];\n  float q[4];"),
            std::string::npos)
      << odometry;
  EXPECT_NE(odometry.find("uint8 reset_counter;\n  int8 quality;\n"), std::string::npos);
  const std::string command = struct_body(idl, "VehicleCommand_");
  EXPECT_NE(command.find("double param5;\n  double param6;\n  float param7;\n  uint32 command;"),
            std::string::npos)
      << command;
  const std::string status = struct_body(idl, "VehicleStatus_");
  EXPECT_NE(status.find("uint16 failure_detector_status;"), std::string::npos);
  EXPECT_NE(status.find("boolean pre_flight_checks_pass;\n"), std::string::npos);
  // PX4's topics have no key.
  EXPECT_EQ(idl.find("@key"), std::string::npos);
  // VehicleStatus has 37 fields in v1.14: one declaration a line.
  EXPECT_EQ(std::count(status.begin(), status.end(), ';'), 37);
}

}  // namespace
}  // namespace ridgeline::transport_dds
