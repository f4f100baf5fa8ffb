// The offboard companion (DESIGN §8): flies one UAV's reference through MAVLink.
//
// Every control period (tick, 50 Hz) it
//  - sends a HEARTBEAT each heartbeat_period_s (MAV_TYPE_ONBOARD_CONTROLLER);
//  - once the vehicle's state is known (LOCAL_POSITION_NED + ATTITUDE), streams
//    SET_POSITION_TARGET_LOCAL_NED (velocity + yaw rate, kTypeMaskVelocityYawRate): before
//    the flight a hold at the reference's speed, so the vehicle sees a setpoint stream as PX4
//    requires before offboard;
//  - arms (MAV_CMD_COMPONENT_ARM_DISARM) and then asks for offboard (MAV_CMD_DO_SET_MODE,
//    PX4 main mode 6), repeating each command every command_retry_s until the vehicle's
//    heartbeat shows it done;
//  - then flies: mission time t = 0 when the heartbeat first shows armed + offboard; the
//    UAV tracker (uav_tracker.hpp) steps on the reported state and its command is sent. After
//    flight_duration_s the pilot is finished (the vehicle, no longer fed, holds by itself).
// The flight log holds |p − r(t)| per step. Time is the caller's (lock step in tests, the
// wall clock in `ridgeline fly`).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mavlink/frame.hpp"
#include "mavlink/messages.hpp"
#include "mpc/reference.hpp"
#include "mpc/uav_tracker.hpp"
#include "world/terrain.hpp"

namespace ridgeline::mavlink {

struct OffboardPilotOptions {
  mpc::UavTrackerOptions tracker;  ///< its control_period_s is the tick period
  double flight_duration_s = 20.0;
  double heartbeat_period_s = 1.0;
  double command_retry_s = 0.5;
  double state_timeout_s = 0.5;  ///< a step on a state older than this is counted as stale
  double home_altitude_m = 0.0;  ///< z of the vehicle's local NED origin (ned_frame.hpp)
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 191;  ///< MAV_COMP_ID_ONBOARD_COMPUTER
  std::uint8_t target_system = 1;
  std::uint8_t target_component = 1;
};

enum class PilotPhase : int {
  kWaitingForState = 0,  ///< no LOCAL_POSITION_NED + ATTITUDE yet
  kArming,
  kStartingOffboard,
  kFlying,
  kFinished,
  kVehicleLeftOffboard,  ///< disarmed or out of offboard during the flight: aborted
};
std::string_view to_string(PilotPhase phase);

struct FlightSample {
  double t_s = 0.0;  ///< mission time
  Vec3 position_m = Vec3::Zero();
  Vec3 reference_m = Vec3::Zero();
  vehicle::Input command = vehicle::Input::Zero();
};

struct FlightSummary {
  PilotPhase phase = PilotPhase::kWaitingForState;
  int steps = 0;
  int stale_steps = 0;
  int qp_fallbacks = 0;
  double flown_time_s = 0.0;
  double tracking_rmse_m = 0.0;
  double tracking_max_m = 0.0;
  double path_length_m = 0.0;
  double time_to_offboard_s = 0.0;  ///< from the first tick to the start of the flight
};

class OffboardPilot {
 public:
  /// Throws ridgeline::InputError for invalid tracker options or a missing reference.
  OffboardPilot(const OffboardPilotOptions& options, const world::SafetyLimits& limits,
                std::shared_ptr<const mpc::ReferenceTrajectory> reference,
                std::shared_ptr<const world::Terrain> terrain);

  void handle(const Message& message, double t_s);
  /// One control period at time t_s: appends the frames to send to `out`.
  void tick(double t_s, std::vector<EncodedFrame>& out);
  /// The same as messages, for a wire other than MAVLink's (PX4's DDS topics, px4/px4_pilot.hpp).
  void tick(double t_s, std::vector<Message>& out);

  PilotPhase phase() const { return phase_; }
  bool done() const {
    return phase_ == PilotPhase::kFinished || phase_ == PilotPhase::kVehicleLeftOffboard;
  }
  const std::vector<FlightSample>& log() const { return log_; }
  FlightSummary summary() const;

 private:
  FrameHeader next_header();
  CommandLong command(std::uint16_t id, float param1, float param2) const;

  OffboardPilotOptions o_;
  std::shared_ptr<const mpc::ReferenceTrajectory> reference_;
  std::shared_ptr<const world::Terrain> terrain_;
  mpc::UavTracker tracker_;
  PilotPhase phase_ = PilotPhase::kWaitingForState;
  std::uint8_t sequence_ = 0;

  bool have_position_ = false, have_attitude_ = false, have_heartbeat_ = false;
  LocalPositionNed position_;
  Attitude attitude_;
  double state_time_s_ = 0.0;
  bool vehicle_armed_ = false, vehicle_offboard_ = false;

  double first_tick_s_ = -1.0;
  double next_heartbeat_s_ = -1.0;
  double next_command_s_ = -1.0;
  double flight_start_s_ = 0.0;
  vehicle::Input last_command_ = vehicle::Input::Zero();
  std::vector<FlightSample> log_;
  int stale_steps_ = 0, qp_fallbacks_ = 0;
};

}  // namespace ridgeline::mavlink
