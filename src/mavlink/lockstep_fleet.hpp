// The companion's side of a team flown through MAVLink vehicles in lock step: one UDP link per
// vehicle (`ridgeline vehicle-sim --lockstep` processes, see SimulatedVehicle's lock step), all
// stepped together, one control period at a time.
//
// start(): for every vehicle, until it answers, a HEARTBEAT (a vehicle learns its companion from
// it; a spawned vehicle announces itself to the companion's port instead); once its state is
// known, keep-alive hold setpoints (stamped kKeepAliveStamp: they never step it) with
// MAV_CMD_COMPONENT_ARM_DISARM, then MAV_CMD_DO_SET_MODE (PX4 offboard), one datagram per round
// and a round per answer or per resend_after_s, until its HEARTBEAT shows it armed in offboard.
//
// step(k): every vehicle gets its SET_POSITION_TARGET_LOCAL_NED stamped ms(k) (velocity + yaw
// rate along its last reported heading, or a hold at its last reported position); the fleet then
// waits for each one's LOCAL_POSITION_NED and ATTITUDE stamped ms(k + 1). A vehicle that has not
// answered within resend_after_s gets the same setpoint again (the vehicle answers a resent one
// without stepping twice), so a lost datagram in either direction costs a resend, never a
// deadlock; after step_timeout_s the step fails with an error naming the UAV.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "mavlink/frame.hpp"
#include "mavlink/stream_parser.hpp"
#include "mavlink/udp_link.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::mavlink {

struct LockstepFleetOptions {
  double period_s = 0.02;         ///< one step: the MPC's control period
  double start_timeout_s = 10.0;  ///< for each vehicle to answer and be armed in offboard
  double resend_after_s = 0.2;    ///< resend a datagram not answered within this
  double step_timeout_s = 10.0;   ///< give up on a step after this (wall time)
  double home_altitude_m = 0.0;   ///< ned_frame.hpp: the z of PX4's local origin
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 191;  ///< MAV_COMP_ID_ONBOARD_COMPUTER
};

/// A vehicle's report in the scenario's ENU frame.
struct FleetReport {
  Vec3 position_m = Vec3::Zero();
  Vec3 ground_velocity_m_s = Vec3::Zero();
  double heading_rad = 0.0;
  double turn_rate_rad_s = 0.0;
};

struct FleetCommand {
  vehicle::Input command = vehicle::Input::Zero();
  bool hold = false;
};

struct FleetVehicleStats {
  ParserStats parser;  ///< what came back, by outcome (checksum errors, ...)
  std::uint64_t datagrams_sent = 0;
  std::uint64_t frames_sent = 0;
  std::uint64_t steps = 0;
  std::uint64_t resends = 0;          ///< step datagrams sent again (a datagram was lost)
  std::uint64_t stale_reports = 0;    ///< state reports with another step's stamp
  std::vector<double> round_trip_us;  ///< per step: first send to the complete answer
  double start_s = 0.0;               ///< wall time from start() to armed in offboard
};

class LockstepFleet {
 public:
  /// One link per vehicle (listen() links for spawned vehicles that announce themselves,
  /// connect() links for vehicles at a known address); names label errors ("uav1 (UAV 0)").
  /// Throws ridgeline::InputError naming the option for non-positive periods.
  LockstepFleet(const LockstepFleetOptions& options, std::vector<std::string> names,
                std::vector<UdpLink> links);

  /// Arms every vehicle and starts offboard; `out` gets their states at time 0. Throws
  /// std::runtime_error naming the UAV, its address and the phase it was stuck in.
  void start(std::vector<FleetReport>& out);
  /// Step k for every vehicle (commands[i] for vehicle i); `out` gets the states at step k + 1.
  /// Throws std::runtime_error naming the UAV when it does not answer or left offboard.
  void step(std::uint64_t k, const std::vector<FleetCommand>& commands,
            std::vector<FleetReport>& out);

  int size() const { return static_cast<int>(vehicles_.size()); }
  FleetVehicleStats stats(int i) const;
  std::string address(int i) const {
    return vehicles_[static_cast<std::size_t>(i)].link.peer_text();
  }

 private:
  struct Vehicle {
    Vehicle(std::string n, UdpLink l) : name(std::move(n)), link(std::move(l)) {}
    std::string name;
    UdpLink link;
    StreamParser parser;
    FleetVehicleStats stats;
    bool have_position = false, have_attitude = false, have_heartbeat = false;
    std::uint32_t position_ms = 0, attitude_ms = 0;
    FleetReport report;
    bool armed = false, offboard = false;
    std::uint8_t sequence = 0;
  };

  void send(Vehicle& v, const std::vector<EncodedFrame>& frames);
  /// Waits up to timeout_s for datagrams on any link and decodes them.
  void receive(double timeout_s);

  LockstepFleetOptions o_;
  std::vector<Vehicle> vehicles_;
};

}  // namespace ridgeline::mavlink
