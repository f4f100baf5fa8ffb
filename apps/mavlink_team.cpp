#include "apps/mavlink_team.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/error.hpp"
#include "mission/statistics.hpp"

namespace ridgeline::apps {

double home_altitude_m(const mission::Scenario& scenario) {
  return scenario.origin ? scenario.origin->alt_amsl_m : 0.0;
}

MavlinkTeam::MavlinkTeam(const mission::Scenario& scenario, const MavlinkTeamOptions& options)
    : period_s_(scenario.mpc.control_period_s),
      home_altitude_m_(home_altitude_m(scenario)),
      processes_("run --mavlink") {
  const std::size_t n = scenario.uavs.size();
  if (!(options.timeout_s > 0.0) || !std::isfinite(options.timeout_s))
    throw InputError("--mavlink-timeout",
                     fmt::format("{} s is not a positive number of seconds", options.timeout_s));
  if (!options.vehicle_addresses.empty() && options.vehicle_addresses.size() != n)
    throw InputError("--mavlink-vehicles",
                     fmt::format("{} addresses for the scenario's {} UAVs (one HOST:PORT each, "
                                 "in the scenario's order)",
                                 options.vehicle_addresses.size(), n));
  std::vector<mavlink::UdpLink> links;
  for (std::size_t i = 0; i < n; ++i) {
    names_.push_back(fmt::format("{} (UAV {})", scenario.uavs[i].name, i));
    if (!options.vehicle_addresses.empty()) {
      std::pair<std::string, std::uint16_t> hp;
      try {
        hp = mavlink::parse_host_port(options.vehicle_addresses[i]);
      } catch (const InputError& e) {
        throw InputError("--mavlink-vehicles", fmt::format("{} (entry {})", e.reason(), i));
      }
      links.push_back(mavlink::UdpLink::connect(hp.first, hp.second));
      processes_.add_external();
    } else {
      // The companion's port first; the vehicle, on a free port of its own, announces itself
      // there (as PX4 SITL sends to its companion's port).
      links.push_back(mavlink::UdpLink::listen("127.0.0.1", 0));
    }
  }
  if (options.vehicle_addresses.empty()) {
    for (std::size_t i = 0; i < n; ++i) {
      processes_.spawn_vehicle_sim(
          static_cast<int>(i), scenario.uavs[i].name,
          {"--udp", "0", "--peer", fmt::format("127.0.0.1:{}", links[i].local_port())},
          options.scenario_path, options.log_dir);
    }
  }
  mavlink::LockstepFleetOptions fo;
  fo.period_s = period_s_;
  fo.home_altitude_m = home_altitude_m_;
  // A spawned vehicle loads the scenario (a DEM can take seconds) before it announces itself.
  fo.start_timeout_s = 3.0 * options.timeout_s;
  fo.step_timeout_s = options.timeout_s;
  fleet_ = std::make_unique<mavlink::LockstepFleet>(fo, names_, std::move(links));
  commands_.resize(n);
}

MavlinkTeam::~MavlinkTeam() { stop_vehicles(); }

void MavlinkTeam::stop_vehicles() { processes_.stop(); }

void MavlinkTeam::start(std::vector<sim::VehicleReport>& out) {
  fleet_->start(reports_);
  out.clear();
  for (const mavlink::FleetReport& r : reports_)
    out.push_back({r.position_m, r.ground_velocity_m_s, r.heading_rad, r.turn_rate_rad_s});
}

void MavlinkTeam::step(long long step, double /*t_s*/,
                       const std::vector<sim::VehicleCommand>& commands,
                       std::vector<sim::VehicleReport>& out) {
  for (std::size_t i = 0; i < commands.size() && i < commands_.size(); ++i)
    commands_[i] = {commands[i].command, commands[i].hold};
  fleet_->step(static_cast<std::uint64_t>(step), commands_, reports_);
  out.clear();
  for (const mavlink::FleetReport& r : reports_)
    out.push_back({r.position_m, r.ground_velocity_m_s, r.heading_rad, r.turn_rate_rad_s});
}

nlohmann::json MavlinkTeam::to_json() const {
  nlohmann::json vehicles = nlohmann::json::array();
  std::uint64_t sent = 0, received = 0, rejected = 0, checksum = 0, resends = 0;
  for (int i = 0; i < fleet_->size(); ++i) {
    const mavlink::FleetVehicleStats s = fleet_->stats(i);
    nlohmann::json by_reason = nlohmann::json::object();
    for (int k = 0; k < mavlink::kFrameStatusCount; ++k) {
      const auto status = static_cast<mavlink::FrameStatus>(k);
      if (status == mavlink::FrameStatus::kOk || status == mavlink::FrameStatus::kIncomplete)
        continue;
      by_reason[std::string(mavlink::to_string(status))] = s.parser.count(status);
    }
    vehicles.push_back(
        {{"uav", names_[static_cast<std::size_t>(i)]},
         {"address", fleet_->address(i)},
         {"process", processes_.status(i)},
         {"steps", s.steps},
         {"datagrams_sent", s.datagrams_sent},
         {"frames_sent", s.frames_sent},
         {"frames_received", s.parser.accepted()},
         {"frames_rejected", s.parser.rejected()},
         {"rejected_by_reason", by_reason},
         {"bytes_skipped", s.parser.bytes_skipped},
         {"resends", s.resends},
         {"stale_reports", s.stale_reports},
         {"start_s", s.start_s},
         {"round_trip_us", mission::to_json(mission::percentiles(s.round_trip_us))}});
    sent += s.frames_sent;
    received += s.parser.accepted();
    rejected += s.parser.rejected();
    checksum += s.parser.count(mavlink::FrameStatus::kBadChecksum);
    resends += s.resends;
  }
  return {{"mode", "lock-step"},
          {"period_s", period_s_},
          {"home_altitude_m", home_altitude_m_},
          {"frames_sent", sent},
          {"frames_received", received},
          {"frames_rejected", rejected},
          {"checksum_errors", checksum},
          {"resends", resends},
          {"vehicles", vehicles}};
}

}  // namespace ridgeline::apps
