// A simulated vehicle on PX4's DDS topics (issue 22): mavlink::SimulatedVehicle — the stand-in
// for PX4 the MAVLink path already has, with its offboard rules, hold and lock step — served on
// the vehicle's side of a transport_dds::Px4Link instead of a UDP port (`ridgeline vehicle-sim
// --px4-dds`). What arrives on fmu/in is converted (px4_frame.hpp) and handed to the vehicle as
// the MAVLink messages it stands for.
//
// Lock step (serve_px4_vehicle_lockstep, `--lockstep`, as `ridgeline run --px4-dds` drives it):
// every batch received is answered on fmu/out with vehicle_status and vehicle_odometry stamped
// with the vehicle's lock-step time.
// Real time (serve_px4_vehicle, as `ridgeline fly --px4-dds` flies it): the vehicle runs on the
// wall clock; every report period (50 Hz) it publishes vehicle_odometry, and vehicle_status at
// 2 Hz and at once on a change of arming or mode (PX4's commander does the same), stamped with
// the system clock in µs since the Unix epoch: what PX4's uXRCE-DDS client puts on the wire
// after its time sync with the agent (it converts stamps between its boot time and the agent's
// clock both ways).
//
// As PX4 does, it enters offboard only while the companion's offboard_control_mode stream
// arrives: a DO_SET_MODE with no offboard_control_mode received within the vehicle's
// setpoint timeout is refused (and counted). A trajectory setpoint that cannot be flown (NaN
// velocity or yawspeed in a velocity setpoint, NaN position in a hold, both or neither) is
// rejected and counted with its reason, never flown.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "mavlink/simulated_vehicle.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::px4 {

struct Px4VehicleStats {
  std::uint64_t offboard_control_modes = 0;
  std::uint64_t setpoints = 0;
  std::uint64_t setpoints_rejected = 0;
  std::uint64_t commands = 0;
  std::uint64_t commands_refused = 0;  ///< offboard asked for without the offboard stream
  std::uint64_t replies = 0;           ///< lock step: answers; real time: odometry samples
  std::uint64_t status_sent = 0;       ///< vehicle_status samples
  std::string last_rejection;          ///< "topic: reason"
  double wall_time_s = 0.0;
};

/// Serves `vehicle` as vehicle 0 of `link` (a kVehicle side) in lock step (period_s a step)
/// until `stop` is set or duration_s (> 0) of wall time has passed.
Px4VehicleStats serve_px4_vehicle_lockstep(mavlink::SimulatedVehicle& vehicle,
                                           transport_dds::Px4Link& link, double period_s,
                                           double duration_s, const std::atomic<bool>& stop);

/// Serves `vehicle` as vehicle 0 of `link` in real time (its time = seconds of wall time since
/// the call) until `stop` is set or duration_s (> 0) has passed.
Px4VehicleStats serve_px4_vehicle(mavlink::SimulatedVehicle& vehicle, transport_dds::Px4Link& link,
                                  double duration_s, const std::atomic<bool>& stop);

/// Microseconds since the Unix epoch on the system clock: the time base of PX4's DDS samples as
/// a ROS 2 node sees them (and stamps its own).
std::uint64_t system_clock_us();

}  // namespace ridgeline::px4
