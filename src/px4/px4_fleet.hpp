// The companion's side of a team flown through PX4's DDS topics in lock step (issue 22): the
// uXRCE-DDS counterpart of mavlink::LockstepFleet, with one vehicle namespace per UAV on one
// transport_dds::Px4Link (`ridgeline vehicle-sim --px4-dds --lockstep` processes, or PX4s).
//
// start(): every round, for every vehicle not yet flying, an OffboardControlMode (the offboard
// stream PX4 requires before and during offboard); once its odometry is known, a hold
// TrajectorySetpoint at its position stamped with the keep-alive stamp (never a step) and a
// VehicleCommand: arm, then offboard (DO_SET_MODE, PX4 main mode 6), until its vehicle_status
// shows it armed in offboard and its odometry is stamped 0.
//
// step(k): every vehicle gets OffboardControlMode + TrajectorySetpoint (velocity + yawspeed
// along its last reported heading, or a hold) stamped with µs(k); the fleet waits for each one's
// VehicleOdometry stamped µs(k + 1). A vehicle not answering within resend_after_s gets the same
// samples again (the vehicle answers a resent step without stepping twice: DDS here is best
// effort, so a sample can be lost like a UDP datagram); after step_timeout_s the step fails.
//
// Received odometry that cannot be used (NaN, a frame that is not NED) is rejected and
// counted per vehicle, never flown on. Errors name the UAV, the DDS topic and what was waited
// for, as ridgeline::InputError (exit 2 at the command line).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mavlink/lockstep_fleet.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::px4 {

struct Px4FleetOptions {
  double period_s = 0.02;         ///< one step: the MPC's control period
  double start_timeout_s = 10.0;  ///< for each vehicle to report and be armed in offboard
  double resend_after_s = 0.2;    ///< resend a step not answered within this
  double step_timeout_s = 10.0;   ///< give up on a step after this (wall time)
  double home_altitude_m = 0.0;   ///< mavlink/ned_frame.hpp: the z of PX4's local origin
  std::uint8_t target_system = 1;
};

struct Px4FleetVehicleStats {
  std::uint64_t odometry_received = 0;
  std::uint64_t status_received = 0;
  std::uint64_t rejected = 0;  ///< odometry that could not be used (NaN, frame, ...)
  std::string last_rejection;  ///< "topic: reason" of the latest
  std::uint64_t samples_sent = 0;
  std::uint64_t steps = 0;
  std::uint64_t resends = 0;
  std::uint64_t stale_reports = 0;  ///< odometry with another step's stamp
  std::vector<double> round_trip_us;
  double start_s = 0.0;
};

class Px4Fleet {
 public:
  /// names[i] labels vehicle i of `link` in errors ("uav1 (UAV 0)"). Throws InputError naming
  /// the option for non-positive periods, or when names and the link's vehicles differ.
  Px4Fleet(const Px4FleetOptions& options, std::vector<std::string> names,
           std::unique_ptr<transport_dds::Px4Link> link);

  void start(std::vector<mavlink::FleetReport>& out);
  void step(std::uint64_t k, const std::vector<mavlink::FleetCommand>& commands,
            std::vector<mavlink::FleetReport>& out);

  int size() const { return static_cast<int>(vehicles_.size()); }
  const Px4FleetVehicleStats& stats(int i) const {
    return vehicles_[static_cast<std::size_t>(i)].stats;
  }
  const std::string& vehicle_namespace(int i) const { return link_->vehicle_namespace(i); }

 private:
  struct Vehicle {
    std::string name;
    Px4FleetVehicleStats stats;
    bool have_odometry = false, have_status = false;
    /// Odometry received while the latest status showed armed + offboard: the two are separate
    /// topics, so a status can overtake the odometry of the same answer, and the state before
    /// offboard (hovering) must not start the flight.
    bool odometry_in_offboard = false;
    std::uint64_t odometry_stamp = 0;
    mavlink::FleetReport report;
    bool armed = false, offboard = false;
  };

  /// Waits up to timeout_s for samples and applies them.
  void receive(double timeout_s);
  std::string topic(int i, const char* name) const;

  Px4FleetOptions o_;
  std::unique_ptr<transport_dds::Px4Link> link_;
  std::vector<Vehicle> vehicles_;
};

}  // namespace ridgeline::px4
