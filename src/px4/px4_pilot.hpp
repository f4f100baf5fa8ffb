// `ridgeline fly --px4-dds`: the offboard companion (mavlink::OffboardPilot, the MAVLink path's
// own) flown over PX4's DDS topics in real time (issue 22). The pilot decides what to send; this
// loop carries it on px4_msgs instead of MAVLink frames:
//
//   every control period (50 Hz)  OffboardControlMode (velocity): the offboard stream PX4
//                                 requires before and during offboard, sent from the first tick
//   the pilot's setpoint          TrajectorySetpoint: NED velocity + yawspeed, NaN position
//   arm, DO_SET_MODE offboard     VehicleCommand (400 param1 1; 176 param1 1 param2 6)
//   the pilot's HEARTBEAT         nothing: on DDS the offboard stream is the companion's liveness
//   VehicleOdometry               LOCAL_POSITION_NED + ATTITUDE (px4_frame.hpp); odometry that
//                                 cannot be used (NaN, not NED) is rejected and counted, never
//                                 flown on
//   VehicleStatus                 HEARTBEAT (armed, offboard)
//
// Samples are stamped with the system clock in µs since the Unix epoch, as a ROS 2 node stamps
// them (PX4's uXRCE-DDS client shifts incoming stamps by its time sync with the agent).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "mavlink/offboard_pilot.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::px4 {

struct Px4PilotReport {
  std::uint64_t samples_sent = 0;
  std::uint64_t odometry_received = 0;
  std::uint64_t odometry_rejected = 0;
  std::uint64_t status_received = 0;
  std::string last_rejection;  ///< "topic: reason" of the latest rejected odometry
  double wall_time_s = 0.0;
};

/// Flies `pilot` through vehicle 0 of `link` (a kCompanion side) until the pilot is done or
/// `stop` is set. `name` labels the vehicle in errors ("uav1 (UAV 0)"). Throws InputError naming
/// it, the topic and what was waited for when the vehicle is not flying offboard within
/// start_timeout_s, or when in flight no usable odometry arrives for 1 s (PX4's own offboard
/// loss timeout, COM_OF_LOSS_T, the other way round).
Px4PilotReport fly_px4_pilot(mavlink::OffboardPilot& pilot, transport_dds::Px4Link& link,
                             const std::string& name, double control_period_s,
                             double start_timeout_s, const std::atomic<bool>& stop);

}  // namespace ridgeline::px4
