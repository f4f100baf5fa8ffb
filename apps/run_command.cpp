// `ridgeline run [--scenario FILE] [--out DIR]`: the main job. It loads and validates the
// scenario (the embedded default without --scenario), plans every UAV's reference with the
// global planner, flies the mission in closed loop (truth world, one agent per UAV talking
// only through the transport, sudden threats, wind) and writes DIR/summary.json,
// DIR/plan.json, DIR/metrics.json, DIR/trajectories.csv, DIR/flight.geojson (when the scenario
// has a geodetic origin) and DIR/report.html (the figures, with plotly.js inlined; skipped with
// a warning when plotly.js is not installed). Progress goes to stderr, a short table to
// stdout. Exit 0 when the flight was safe, 4 when a safety metric failed (the outputs are
// still written: they are the evidence). --variation SEED flies a
// Monte Carlo variation (the same plan; threats, wind, noise and starts varied) to replay a
// failed run.
//
// --mavlink flies the whole team through MAVLink vehicles over UDP on loopback: one
// `ridgeline vehicle-sim --lockstep` process per UAV (or the lock-step vehicles listed by
// --mavlink-vehicles), stepped one control period at a time (apps/mavlink_team.hpp). The same
// outputs, with metrics.json's "mavlink" block (frames, rejected frames, resends, latency).
//
// --px4-dds flies the team the same way through PX4's own DDS topics (px4_msgs over uXRCE-DDS,
// rt/uav_N/fmu/...): one `ridgeline vehicle-sim --px4-dds --lockstep` process per UAV (or, with
// --px4-external, the PX4s already on the domain), apps/px4_team.hpp; metrics.json gets
// "px4_dds".
#include <fmt/format.h>

#include <unistd.h>

#include <cmath>
#include <iostream>
#include <memory>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/mavlink_team.hpp"
#include "apps/px4_team.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/geo_export.hpp"
#include "io/plan_file.hpp"
#include "io/report_html.hpp"
#include "io/scenario_summary.hpp"
#include "sim/mission.hpp"
#include "sim/variation.hpp"

namespace ridgeline::apps {
namespace {

std::string metrics_table(const mission::MissionMetrics& m) {
  std::string out = fmt::format("{:<8} {:>9} {:>10} {:>12} {:>8} {:>8}\n", "uav", "path_m",
                                "track_rmse", "min_clear_m", "targets", "replans");
  for (const mission::UavMetrics& u : m.uavs) {
    out += fmt::format("{:<8} {:>9.0f} {:>10.2f} {:>12.1f} {:>5}/{:<2} {:>8}\n", u.name,
                       u.path_length_m, u.tracking_rmse_m, u.min_terrain_clearance_m,
                       u.targets_inspected, u.targets_assigned, u.replans);
  }
  out += fmt::format(
      "min separation {:.1f} m, min threat distance {:.1f} m, threats {} encountered / {} "
      "intruded, terrain collisions {}, constraint violations {}\n",
      m.min_separation_m, m.min_threat_distance_m, m.threat_encounters, m.threat_intrusions,
      m.terrain_collisions, m.total_constraint_violations());
  out += fmt::format(
      "mission {} in {:.1f} s simulated, {:.1f} s wall ({:.0f}x real time), {:.1f} s CPU "
      "({:.0f}x); MPC step median {:.0f} us, p99 {:.0f} us (CPU: {:.0f} us, {:.0f} us)\n",
      m.mission_complete ? "complete" : "NOT complete", m.sim_time_s, m.wall_time_s,
      m.wall_time_s > 0 ? m.sim_time_s / m.wall_time_s : 0.0, m.cpu_time_s,
      m.cpu_time_s > 0 ? m.sim_time_s / m.cpu_time_s : 0.0, m.mpc_solve_us.median,
      m.mpc_solve_us.p99, m.mpc_solve_cpu_us.median, m.mpc_solve_cpu_us.p99);
  return out;
}

}  // namespace

void register_run_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out";
    bool quiet = false;
    std::optional<std::uint64_t> variation;
    std::string method = "proposed";
    std::string ddpg_model;
    bool mavlink = false;
    std::vector<std::string> mavlink_vehicles;
    double mavlink_timeout_s = 10.0;
    bool px4_dds = false;
    std::vector<std::string> px4_namespaces;
    bool px4_external = false;
    double px4_timeout_s = 10.0;
    std::optional<int> domain_id;
    std::optional<std::string> partition;
  };
  auto args = std::make_shared<Args>();
  CLI::App* run =
      app.add_subcommand("run", "Plan and fly the mission (default: embedded scenario)");
  run->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  run->add_option("--out", args->out, "Output folder")->capture_default_str();
  run->add_flag("--quiet", args->quiet, "No progress on stderr");
  run->add_option("--method", args->method,
                  "Who plans and flies: proposed, astar_dwa ([7] improved A* + dynamic window), "
                  "wind_aware ([6] wind-aware offline path + pure pursuit) or ddpg ([8] a DDPG "
                  "policy, --ddpg-model)")
      ->capture_default_str();
  add_ddpg_model_option(run, args->ddpg_model);
  run->add_option("--variation", args->variation,
                  "Fly the Monte Carlo variation with this seed (as listed by montecarlo)");
  run->add_flag("--mavlink", args->mavlink,
                "Fly every UAV through a MAVLink vehicle over UDP on loopback (one `vehicle-sim "
                "--lockstep` process each), in lock step");
  run->add_option("--mavlink-vehicles", args->mavlink_vehicles,
                  "With --mavlink: HOST:PORT of each UAV's lock-step vehicle, in the scenario's "
                  "order (comma-separated), instead of spawning them")
      ->delimiter(',');
  run->add_option("--mavlink-timeout", args->mavlink_timeout_s,
                  "With --mavlink: seconds a vehicle may take to answer a step (its start: 3x)")
      ->capture_default_str();
  run->add_flag("--px4-dds", args->px4_dds,
                "Fly every UAV through PX4's own DDS topics (px4_msgs, PX4 v1.14; one `vehicle-sim "
                "--px4-dds --lockstep` process each), in lock step");
  run->add_option("--px4-namespaces", args->px4_namespaces,
                  "With --px4-dds: each UAV's PX4 namespace in the scenario's order "
                  "(comma-separated; default uav_1,uav_2,...)")
      ->delimiter(',');
  run->add_flag("--px4-external", args->px4_external,
                "With --px4-dds: fly lock-step vehicles already on the DDS domain instead of "
                "spawning them");
  run->add_option("--px4-timeout", args->px4_timeout_s,
                  "With --px4-dds: seconds a vehicle may take to answer a step (its start: 3x)")
      ->capture_default_str();
  run->add_option("--domain-id", args->domain_id,
                  "With --px4-dds: DDS domain id (default: 100 + pid mod 100; PX4's is 0)");
  run->add_option("--partition", args->partition,
                  "With --px4-dds: DDS partition (default: one of this run; \"\" is PX4's)");
  run->callback([args] {
    const sim::Method method = sim::parse_method(args->method);
    if (!args->px4_dds) {
      const std::pair<const char*, bool> needs_px4[] = {
          {"--px4-namespaces", !args->px4_namespaces.empty()},
          {"--px4-external", args->px4_external},
          {"--domain-id", args->domain_id.has_value()},
          {"--partition", args->partition.has_value()}};
      for (const auto& [option, given] : needs_px4)
        if (given) throw InputError(option, "needs --px4-dds");
    }
    if (args->px4_dds && args->mavlink)
      throw InputError("--px4-dds", "cannot be combined with --mavlink (one wire at a time)");
    if (args->px4_dds && args->variation)
      throw InputError("--variation",
                       "cannot be combined with --px4-dds yet (the vehicles fly the scenario as "
                       "written)");
    if (!args->mavlink && !args->mavlink_vehicles.empty())
      throw InputError("--mavlink-vehicles", "needs --mavlink");
    if (args->mavlink && args->variation)
      throw InputError("--variation",
                       "cannot be combined with --mavlink yet (the vehicles fly the scenario "
                       "as written)");
    if (!(args->mavlink_timeout_s > 0.0) || !std::isfinite(args->mavlink_timeout_s))
      throw InputError("--mavlink-timeout",
                       fmt::format("{} s is not a positive number of seconds",
                                   args->mavlink_timeout_s));
    const std::shared_ptr<const learning::DdpgPolicy> ddpg_policy =
        load_ddpg_policy_if(method == sim::Method::kDdpg, args->ddpg_model);
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    nlohmann::json summary = io::summarize(loaded);
    summary["method"] = sim::to_string(method);
    std::cout << io::summary_text(summary);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded, method);
    if (!plan) return;
    std::cout << io::plan_summary_text(*plan, loaded.scenario);

    sim::MissionOptions options;
    options.method = method;
    options.ddpg_policy = ddpg_policy;
    if (!args->quiet) {
      options.progress = [](double t, double duration) {
        if (static_cast<int>(t) % 10 == 0)
          std::cerr << fmt::format("\rflying: t = {:5.0f} s of at most {:.0f} s", t, duration)
                    << std::flush;
      };
    }
    const mission::Scenario flown_scenario =
        args->variation ? sim::vary_scenario(loaded.scenario, *loaded.terrain, *args->variation)
                        : loaded.scenario;
    const std::filesystem::path dir(args->out);
    std::unique_ptr<MavlinkTeam> team;
    if (args->mavlink) {
      MavlinkTeamOptions mo;
      mo.scenario_path = args->scenario;
      mo.vehicle_addresses = args->mavlink_vehicles;
      mo.timeout_s = args->mavlink_timeout_s;
      // Created by the first vehicle spawned: a refused option leaves nothing behind.
      if (mo.vehicle_addresses.empty()) mo.log_dir = dir / "logs";
      team = std::make_unique<MavlinkTeam>(flown_scenario, mo);
      options.vehicles = team.get();
      std::cerr << fmt::format("run: {} UAVs through MAVLink vehicles ({}), lock step\n",
                               flown_scenario.uavs.size(),
                               mo.vehicle_addresses.empty() ? "vehicle-sim processes"
                                                            : "at the given addresses");
    }
    std::unique_ptr<Px4Team> px4_team;
    if (args->px4_dds) {
      Px4TeamOptions po;
      po.scenario_path = args->scenario;
      po.namespaces = args->px4_namespaces;
      po.external = args->px4_external;
      po.timeout_s = args->px4_timeout_s;
      const int pid = static_cast<int>(::getpid());
      po.dds.domain_id = args->domain_id.value_or(100 + pid % 100);
      po.dds.partition = args->partition.value_or(fmt::format("ridgeline-px4-{}", pid));
      if (!po.external) po.log_dir = dir / "logs";  // created by the first vehicle spawned
      px4_team = std::make_unique<Px4Team>(flown_scenario, po);
      options.vehicles = px4_team.get();
      std::cerr << fmt::format(
          "run: {} UAVs through PX4's DDS topics (domain {}, partition '{}'; {}), lock step\n",
          flown_scenario.uavs.size(), po.dds.domain_id, po.dds.partition,
          po.external ? "vehicles already running" : "vehicle-sim processes");
    }
    const mission::MissionResult flown =
        sim::fly_mission(flown_scenario, loaded.terrain, *plan, options);
    if (!args->quiet) std::cerr << '\n';
    const mission::MissionMetrics& m = flown.metrics;
    std::cout << metrics_table(m);

    const nlohmann::json plan_json = io::plan_to_json(*plan, loaded.scenario);
    summary["plan"] = {{"status", plan_json["status"]},
                       {"solve_time_s", plan_json["solve_time_s"]},
                       {"cost", plan_json["cost"]},
                       {"validation", plan_json["validation"]}};
    nlohmann::json metrics = mission::to_json(m);
    if (team) {
      team->stop_vehicles();
      metrics["mavlink"] = team->to_json();
      const nlohmann::json& t = metrics["mavlink"];
      std::cout << fmt::format(
          "mavlink: {} frames sent, {} received, {} rejected ({} checksum errors), {} resends\n",
          t["frames_sent"].get<std::uint64_t>(), t["frames_received"].get<std::uint64_t>(),
          t["frames_rejected"].get<std::uint64_t>(), t["checksum_errors"].get<std::uint64_t>(),
          t["resends"].get<std::uint64_t>());
    }
    if (px4_team) {
      px4_team->stop_vehicles();
      metrics["px4_dds"] = px4_team->to_json();
      const nlohmann::json& t = metrics["px4_dds"];
      std::cout << fmt::format(
          "px4_dds: {} samples sent, {} received, {} odometry rejected, {} resends\n",
          t["samples_sent"].get<std::uint64_t>(), t["samples_received"].get<std::uint64_t>(),
          t["odometry_rejected"].get<std::uint64_t>(), t["resends"].get<std::uint64_t>());
    }
    summary["flight"] = {{"mission_complete", m.mission_complete},
                         {"safe", m.safe()},
                         {"sim_time_s", m.sim_time_s},
                         {"wall_time_s", m.wall_time_s}};
    io::write_file_atomically(dir / "plan.json", plan_json.dump() + "\n");
    io::write_file_atomically(dir / "metrics.json", metrics.dump(2) + "\n");
    io::write_file_atomically(dir / "trajectories.csv",
                              mission::trajectories_csv(flown.trajectories, loaded.scenario));
    io::write_file_atomically(dir / "summary.json", summary.dump(2) + "\n");
    std::cout << "wrote summary.json, plan.json, metrics.json and trajectories.csv to "
              << dir.string() << '\n';
    // The flown tracks, targets and threat tracks over a map (GeoJSON in WGS 84), when the
    // scenario is placed on the Earth; a stale one from an earlier run would mislead.
    const std::filesystem::path flight = dir / "flight.geojson";
    if (flown_scenario.origin) {
      io::write_file_atomically(
          flight, io::to_geojson(io::mission_from_flight(flown_scenario, flown.trajectories)));
      std::cout << "wrote flight.geojson to " << dir.string() << '\n';
    } else {
      std::error_code not_removed;
      std::filesystem::remove(flight, not_removed);
      std::cout << "no flight.geojson: the scenario names no geodetic origin ('origin: {lat_deg, "
                   "lon_deg, alt_amsl_m}'), so the flight has no latitude/longitude\n";
    }
    write_report(dir, [&](std::string_view plotly_js) {
      return io::mission_report_html({flown_scenario, *loaded.terrain, m, flown.trajectories},
                                     plotly_js);
    });
    if (!m.safe()) {
      std::cerr << "error: the flight broke a safety constraint (see metrics.json)\n";
      set_exit_code(4);
    }
  });
}

}  // namespace ridgeline::apps
