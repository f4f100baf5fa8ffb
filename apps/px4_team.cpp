#include "apps/px4_team.hpp"

#include <fmt/format.h>

#include <cmath>

#include "apps/mavlink_team.hpp"
#include "core/error.hpp"
#include "mission/statistics.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::apps {

Px4Team::Px4Team(const mission::Scenario& scenario, const Px4TeamOptions& options)
    : period_s_(scenario.mpc.control_period_s),
      home_altitude_m_(home_altitude_m(scenario)),
      dds_(options.dds),
      processes_("run --px4-dds") {
  const std::size_t n = scenario.uavs.size();
  if (!(options.timeout_s > 0.0) || !std::isfinite(options.timeout_s))
    throw InputError("--px4-timeout",
                     fmt::format("{} s is not a positive number of seconds", options.timeout_s));
  std::vector<std::string> namespaces = options.namespaces;
  if (namespaces.empty()) {
    for (std::size_t i = 0; i < n; ++i) namespaces.push_back(fmt::format("uav_{}", i + 1));
  } else if (namespaces.size() != n) {
    throw InputError("--px4-namespaces",
                     fmt::format("{} namespaces for the scenario's {} UAVs (one uav_N each, in "
                                 "the scenario's order)",
                                 namespaces.size(), n));
  }
  for (std::size_t i = 0; i < n; ++i)
    names_.push_back(fmt::format("{} (UAV {})", scenario.uavs[i].name, i));
  auto participant = std::make_shared<transport_dds::DdsParticipant>(dds_);
  std::unique_ptr<transport_dds::Px4Link> link;
  try {
    link = std::make_unique<transport_dds::Px4Link>(participant, transport_dds::Px4Side::kCompanion,
                                                    namespaces);
  } catch (const InputError& e) {
    throw InputError("--px4-namespaces", e.reason());
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (options.external) {
      processes_.add_external();
      continue;
    }
    processes_.spawn_vehicle_sim(static_cast<int>(i), scenario.uavs[i].name,
                                 {"--px4-dds", "--px4-namespace", namespaces[i], "--domain-id",
                                  std::to_string(dds_.domain_id), "--partition", dds_.partition},
                                 options.scenario_path, options.log_dir);
  }
  px4::Px4FleetOptions fo;
  fo.period_s = period_s_;
  fo.home_altitude_m = home_altitude_m_;
  // A spawned vehicle loads the scenario (a DEM can take seconds) before it answers.
  fo.start_timeout_s = 3.0 * options.timeout_s;
  fo.step_timeout_s = options.timeout_s;
  fleet_ = std::make_unique<px4::Px4Fleet>(fo, names_, std::move(link));
  commands_.resize(n);
}

namespace {
void to_reports(const std::vector<mavlink::FleetReport>& in, std::vector<sim::VehicleReport>& out) {
  out.clear();
  for (const mavlink::FleetReport& r : in)
    out.push_back({r.position_m, r.ground_velocity_m_s, r.heading_rad, r.turn_rate_rad_s});
}
}  // namespace

void Px4Team::start(std::vector<sim::VehicleReport>& out) {
  fleet_->start(reports_);
  to_reports(reports_, out);
}

void Px4Team::step(long long step, double /*t_s*/, const std::vector<sim::VehicleCommand>& commands,
                   std::vector<sim::VehicleReport>& out) {
  for (std::size_t i = 0; i < commands.size() && i < commands_.size(); ++i)
    commands_[i] = {commands[i].command, commands[i].hold};
  fleet_->step(static_cast<std::uint64_t>(step), commands_, reports_);
  to_reports(reports_, out);
}

nlohmann::json Px4Team::to_json() const {
  nlohmann::json vehicles = nlohmann::json::array();
  std::uint64_t sent = 0, received = 0, rejected = 0, resends = 0;
  for (int i = 0; i < fleet_->size(); ++i) {
    const px4::Px4FleetVehicleStats& s = fleet_->stats(i);
    vehicles.push_back(
        {{"uav", names_[static_cast<std::size_t>(i)]},
         {"namespace", fleet_->vehicle_namespace(i)},
         {"process", processes_.status(i)},
         {"steps", s.steps},
         {"samples_sent", s.samples_sent},
         {"odometry_received", s.odometry_received},
         {"status_received", s.status_received},
         {"odometry_rejected", s.rejected},
         {"last_rejection", s.last_rejection},
         {"resends", s.resends},
         {"stale_reports", s.stale_reports},
         {"start_s", s.start_s},
         {"round_trip_us", mission::to_json(mission::percentiles(s.round_trip_us))}});
    sent += s.samples_sent;
    received += s.odometry_received + s.status_received;
    rejected += s.rejected;
    resends += s.resends;
  }
  return {{"mode", "lock-step"},           {"px4_release", "v1.14"},
          {"domain_id", dds_.domain_id},   {"partition", dds_.partition},
          {"period_s", period_s_},         {"home_altitude_m", home_altitude_m_},
          {"samples_sent", sent},          {"samples_received", received},
          {"odometry_rejected", rejected}, {"resends", resends},
          {"vehicles", vehicles}};
}

}  // namespace ridgeline::apps
