// `ridgeline run --mavlink`: the whole team flown through MAVLink vehicles over UDP on
// loopback, one `ridgeline vehicle-sim --lockstep` process per UAV (or vehicles the user runs,
// at given addresses), stepped in lock step by mavlink::LockstepFleet behind the mission's
// sim::ExternalVehicles interface. The mission loop, the agents, the world's threats, wind,
// sensors and metrics are `run`'s own; only the UAVs' dynamics live in the vehicles.
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "apps/vehicle_processes.hpp"
#include "mavlink/lockstep_fleet.hpp"
#include "mission/scenario.hpp"
#include "sim/external_vehicles.hpp"

namespace ridgeline::apps {

/// The altitude of PX4's local NED origin (the home position) in the scenario's z: the geodetic
/// origin's altitude above mean sea level when the scenario has one (z is then AMSL), else 0
/// (z is the height above the terrain datum, where home is). The one place `vehicle-sim`,
/// `fly` and `run --mavlink` take it from (ned_frame.hpp applies it).
double home_altitude_m(const mission::Scenario& scenario);

struct MavlinkTeamOptions {
  /// The scenario file the vehicles load ("" = the embedded default), the one `run` flies.
  std::string scenario_path;
  /// HOST:PORT of each UAV's lock-step vehicle, in the scenario's order; empty: spawn one
  /// `vehicle-sim --lockstep` process per UAV on a free loopback port.
  std::vector<std::string> vehicle_addresses;
  /// Where the spawned vehicles' output goes (vehicle-sim-<uav>.log); empty: discarded.
  std::filesystem::path log_dir;
  double timeout_s = 10.0;  ///< per step; the start (scenario loading included) gets 3x
};

class MavlinkTeam : public sim::ExternalVehicles {
 public:
  /// Opens the links and spawns the vehicles. Throws InputError naming --mavlink-vehicles for a
  /// bad address list, std::runtime_error when a process cannot start.
  MavlinkTeam(const mission::Scenario& scenario, const MavlinkTeamOptions& options);
  /// Stops the spawned vehicles (SIGTERM, then SIGKILL after 3 s).
  ~MavlinkTeam() override;
  MavlinkTeam(const MavlinkTeam&) = delete;
  MavlinkTeam& operator=(const MavlinkTeam&) = delete;

  void start(std::vector<sim::VehicleReport>& out) override;
  void step(long long step, double t_s, const std::vector<sim::VehicleCommand>& commands,
            std::vector<sim::VehicleReport>& out) override;

  /// Stops the spawned vehicles now and records how they ended.
  void stop_vehicles();
  /// metrics.json's "mavlink" block: per vehicle frames sent and received, rejected frames by
  /// reason (checksum, ...), resends, round-trip latency, the process's end.
  nlohmann::json to_json() const;

 private:
  double period_s_;
  double home_altitude_m_;
  std::vector<std::string> names_;
  VehicleProcesses processes_;
  std::unique_ptr<mavlink::LockstepFleet> fleet_;
  std::vector<mavlink::FleetCommand> commands_;
  std::vector<mavlink::FleetReport> reports_;
};

}  // namespace ridgeline::apps
