// Ridgeline's DDS topics: for each message type, its topic name, its QoS and why, and the field
// that keys its instances. The one place these are written: the DDS code creates its topics,
// readers and writers from here, and the IDL writer (idl_writer.hpp) puts the key and the
// description into the generated IDL. No DDS type here.
//
// Topic names follow ROS 2's mapping of a topic /ridgeline/name to the DDS topic
// rt/ridgeline/name, and the types ROS 2's `ridgeline::msg::dds_::Name_`, so a ROS 2 tool on the
// same domain sees the swarm.
#pragma once

#include "messages/messages.hpp"
#include "transport_dds/px4_messages.hpp"
#include "transport_dds/sim_messages.hpp"

namespace ridgeline::transport_dds {

enum class TopicQos {
  kLatestBestEffort,  ///< best effort, keep last 1 (per key)
  kReliable,          ///< reliable, keep last `depth` (per key)
  kReliableLatched,   ///< reliable, transient local, keep last 1 per key
  /// PX4's uXRCE-DDS bridge: its publishers (fmu/out) are best effort + transient local and its
  /// subscribers (fmu/in) best effort + volatile, keep last 1. Both ends of a PX4 topic use
  /// its class, as a ROS 2 node talking to PX4 does.
  kPx4Publisher,
  kPx4Subscriber,
};

struct TopicSpec {
  const char* name = "";  ///< the DDS topic
  TopicQos qos = TopicQos::kReliable;
  int depth = 1;           ///< history depth of writers and readers
  const char* key = "";    ///< the field whose value keys an instance ("": one instance)
  const char* about = "";  ///< what a sample is and why this QoS (into the IDL)
};

/// Topic<M>::spec: the topic of message type M.
template <class M>
struct Topic;

template <>
struct Topic<messages::PredictedTrajectory> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/predicted_trajectory", TopicQos::kLatestBestEffort, 1, "uav",
      "One UAV's MPC prediction: positions at stamp_s + k*step_s, k = 1..Np. Best effort, keep "
      "last 1 per UAV: a newer prediction supersedes an old one, a lost one is replaced 10-20 ms "
      "later, and retransmitting an old one would only add latency."};
};

template <>
struct Topic<messages::ThreatReport> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/threat_report", TopicQos::kReliable, 16, "",
      "A sensed sudden threat (eq. 13): a sphere whose centre is centre_m at stamp_s and moves at "
      "velocity_m_s. Reliable, keep last 16: a threat reported once must reach everyone (reports "
      "are repeated every second, but the first one matters most)."};
};

template <>
struct Topic<messages::StateReport> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/state", TopicQos::kLatestBestEffort, 1, "uav",
      "A UAV's measured state s = [x, y, z, psi, v, omega, w] (eq. 1). Best effort, keep last 1 "
      "per UAV: superseded at the next control period."};
};

template <>
struct Topic<messages::ReferencePlan> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/reference_plan", TopicQos::kReliableLatched, 1, "uav",
      "The ground station's reference for one UAV: the time-parametrized reference r_i(t) "
      "(points[k] at times_s[k]) and the indices of its targets in visiting order; version grows "
      "with every re-plan. Reliable, transient local, keep last 1 per UAV: the plan must arrive, "
      "also at an agent that starts after it was published."};
};

template <>
struct Topic<ClockTick> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/clock", TopicQos::kReliable, 8, "",
      "The world's clock: tick k is mission time t_s. answered lists the UAVs that answered the "
      "previous tick; reports_sent and prediction_stamps (same order) say how many threat reports "
      "each had sent by then and the stamp of the prediction it published: in lock-step an agent "
      "waits for those before it computes, so a run does not depend on DDS's delivery timing. "
      "Reliable, keep last 8: the lock-step protocol waits for every tick."};
};

template <>
struct Topic<Measurement> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/measurement", TopicQos::kReliable, 4, "uav",
      "What the world's sensors give one UAV at one control tick: the measured state, the "
      "anemometer and the threats its sensor sees (centres at t_s). Reliable, keep last 4 per "
      "UAV: the lock-step protocol waits for it."};
};

template <>
struct Topic<CommandReport> {
  static constexpr TopicSpec spec{
      "rt/ridgeline/command", TopicQos::kReliable, 4, "uav",
      "An agent's answer to a Measurement: the command u = (v_c, omega_c, w_c) held until the "
      "next tick (commanded speed, turn rate, vertical speed in command.x, .y, .z), and what the "
      "world records of the agent (mode 0 "
      "tracking, 1 fallback, 2 finished; reference, MPC step, counters). hello marks an agent's "
      "announcement before its first tick. Reliable, keep last 4 per UAV."};
};

// PX4's topics (px4_messages.hpp). The names are those of a vehicle without a namespace; a
// vehicle in namespace uav_N has them under rt/uav_N/fmu/ (px4_link.hpp: px4_topic_name).
template <>
struct Topic<px4::OffboardControlMode> {
  static constexpr TopicSpec spec{
      "rt/fmu/in/offboard_control_mode", TopicQos::kPx4Subscriber, 1, "",
      "The companion's offboard heartbeat: which setpoint kind it streams (here velocity). PX4 "
      "enters and stays in offboard only while it arrives."};
};

template <>
struct Topic<px4::TrajectorySetpoint> {
  static constexpr TopicSpec spec{
      "rt/fmu/in/trajectory_setpoint", TopicQos::kPx4Subscriber, 1, "",
      "The companion's setpoint, NED: velocity + yawspeed with NaN positions (the command u), "
      "or a position with NaN velocity (hold). In lock step its timestamp is the vehicle's time."};
};

template <>
struct Topic<px4::VehicleCommand> {
  static constexpr TopicSpec spec{
      "rt/fmu/in/vehicle_command", TopicQos::kPx4Subscriber, 1, "",
      "Arm (VEHICLE_CMD_COMPONENT_ARM_DISARM, param1 1) and offboard (VEHICLE_CMD_DO_SET_MODE, "
      "param1 1, param2 6), repeated until vehicle_status shows them done."};
};

template <>
struct Topic<px4::VehicleOdometry> {
  static constexpr TopicSpec spec{
      "rt/fmu/out/vehicle_odometry", TopicQos::kPx4Publisher, 1, "",
      "The vehicle's position and velocity (NED about home), attitude quaternion and body rates; "
      "in lock step its timestamp is the vehicle's time after the step."};
};

template <>
struct Topic<px4::VehicleStatus> {
  static constexpr TopicSpec spec{
      "rt/fmu/out/vehicle_status", TopicQos::kPx4Publisher, 1, "",
      "The vehicle's arming state and navigation mode (offboard = 14)."};
};

}  // namespace ridgeline::transport_dds
