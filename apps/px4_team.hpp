// `ridgeline run --px4-dds`: the whole team flown through PX4's own DDS topics (px4_msgs over
// uXRCE-DDS, issue 22), one vehicle namespace per UAV (rt/uav_N/fmu/...), stepped in lock step by
// px4::Px4Fleet behind the mission's sim::ExternalVehicles interface. The vehicles are one
// `ridgeline vehicle-sim --px4-dds --lockstep` process per UAV, or (--px4-external) vehicles
// already on the DDS domain. As with `run --mavlink`, the mission loop, agents, threats, wind,
// sensors and metrics are `run`'s own; only the UAVs' dynamics live in the vehicles.
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "apps/vehicle_processes.hpp"
#include "mission/scenario.hpp"
#include "px4/px4_fleet.hpp"
#include "sim/external_vehicles.hpp"
#include "transport_dds/dds_participant.hpp"

namespace ridgeline::apps {

struct Px4TeamOptions {
  std::string scenario_path;  ///< the scenario file spawned vehicles load ("" = embedded default)
  /// Each UAV's PX4 namespace, in the scenario's order; empty: uav_1, uav_2, ... (PX4's
  /// multi-vehicle convention, instance N + 1 for UAV N).
  std::vector<std::string> namespaces;
  bool external = false;  ///< fly vehicles already running instead of spawning them
  transport_dds::DdsOptions dds;
  std::filesystem::path log_dir;  ///< spawned vehicles' output (vehicle-sim-<uav>.log)
  double timeout_s = 10.0;        ///< per step; the start gets 3x
};

class Px4Team : public sim::ExternalVehicles {
 public:
  /// Throws InputError naming --px4-namespaces (wrong count, not uav_N, repeated) or
  /// --px4-timeout, std::runtime_error when a process cannot start.
  Px4Team(const mission::Scenario& scenario, const Px4TeamOptions& options);
  ~Px4Team() override { stop_vehicles(); }

  void start(std::vector<sim::VehicleReport>& out) override;
  void step(long long step, double t_s, const std::vector<sim::VehicleCommand>& commands,
            std::vector<sim::VehicleReport>& out) override;

  void stop_vehicles() { processes_.stop(); }
  /// metrics.json's "px4_dds" block: domain, partition, per vehicle its namespace, samples
  /// sent and received, rejected odometry, resends, round trip, how its process ended.
  nlohmann::json to_json() const;

 private:
  double period_s_;
  double home_altitude_m_;
  transport_dds::DdsOptions dds_;
  std::vector<std::string> names_;
  VehicleProcesses processes_;
  std::unique_ptr<px4::Px4Fleet> fleet_;
  std::vector<mavlink::FleetCommand> commands_;
  std::vector<mavlink::FleetReport> reports_;
};

}  // namespace ridgeline::apps
