// `ridgeline bench mpc [--steps N] [--np NP] [--nc NC] [--ipopt-every K] [--dump-qps FILE]`:
// measures the tracker's full 50 Hz step, with the medians of its parts, and compares its QP solver
// with Ipopt on the same QPs, printing JSON; --dump-qps writes the QPs it built as an RLQP file.
// `ridgeline bench mission [--scenario FILE] [--repeats N]`: plans once, flies the mission N
// times and reports the real-time factor (median, in wall-clock and thread CPU time).
// `ridgeline bench qp --instances FILE [--json] [--method M] [--reference R]`: times the QP
// solver on the instances of an RLQP file in order, hot-started as the MPC does, against the
// unconstrained Cholesky floor and a tight reference. Figures are medians and ratios from one
// run: absolute times vary on shared machines.
// `ridgeline bench host [--seconds S] [--threshold-us T]`: this core's speed and the
// interruptions of the calling thread over S seconds (benchmarks/host_speed.hpp): what a timed
// step's tail meets on this machine, before any of our code runs.
// `ridgeline bench swarm [--uavs 8,16,32] [--latency-ms 0,100,300] [--loss 0.2] [--runs 100]
// [--threads 2] [--radius-m 250] [--scenario FILE] [--out DIR]`: circle swaps over the
// scenario's terrain (benchmarks/swarm_benchmark.hpp), a table like RMADER's; DIR gets
// swarm.json and swarm.md.
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "benchmarks/host_speed.hpp"
#include "benchmarks/mission_benchmark.hpp"
#include "benchmarks/mpc_benchmark.hpp"
#include "benchmarks/plan_benchmark.hpp"
#include "benchmarks/qp_benchmark.hpp"
#include "benchmarks/replan_benchmark.hpp"
#include "benchmarks/swarm_benchmark.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "mission/stage_inputs.hpp"
#include "qp/qp_instance_file.hpp"

namespace ridgeline::apps {

void register_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Speed measurements, printed as JSON");
  bench->require_subcommand(1);

  // `ridgeline bench plan [--scenario FILE] [--repeats N] [--scaling-repeats N] [--max-uavs N]
  // [--max-waypoints N] [--budget-s S]`: the global planner (plan_mission, all stages) on the
  // default scenario, then a scaling table of team scenarios (`scenario team`) of 3, 10, 30, 100
  // UAVs x 100, 200 waypoints
  // (sim/plan_benchmark.hpp). Large rows take long: --max-uavs / --max-waypoints drop them.
  struct PlanCommandOptions {
    std::string scenario;
    benchmarks::PlanBenchmarkOptions benchmark;
    int max_uavs = 100;
    int max_waypoints = 200;
  };
  auto plan_options = std::make_shared<PlanCommandOptions>();
  CLI::App* plan = bench->add_subcommand(
      "plan", "The global planner's wall time on the default scenario and a scaling table");
  plan->add_option("--scenario", plan_options->scenario, "Scenario YAML (default: embedded)");
  plan->add_option("--repeats", plan_options->benchmark.repeats, "timed plans of the scenario")
      ->capture_default_str();
  plan->add_option("--scaling-repeats", plan_options->benchmark.scaling_repeats,
                   "timed plans per scaling row (0: no scaling table)")
      ->capture_default_str();
  plan->add_option("--max-uavs", plan_options->max_uavs, "leave out scaling rows with more UAVs")
      ->capture_default_str();
  plan->add_option("--max-waypoints", plan_options->max_waypoints,
                   "leave out scaling rows with more waypoints")
      ->capture_default_str();
  plan->add_option("--budget-s", plan_options->benchmark.scaling_time_budget_s,
                   "optimizer time budget per plan in the scaling rows")
      ->capture_default_str();
  plan->callback([plan_options] {
    benchmarks::PlanBenchmarkOptions o = plan_options->benchmark;
    if (o.repeats < 1) throw InputError("--repeats", "must be at least 1");
    if (o.scaling_repeats < 0) throw InputError("--scaling-repeats", "must not be negative");
    if (!(o.scaling_time_budget_s > 0.0)) throw InputError("--budget-s", "must be positive");
    std::erase_if(o.uav_counts, [&](int n) { return n > plan_options->max_uavs; });
    std::erase_if(o.waypoint_counts, [&](int n) { return n > plan_options->max_waypoints; });
    const io::LoadedScenario loaded = load_scenario_argument(plan_options->scenario);
    const benchmarks::PlanBenchmarkReport report =
        benchmarks::run_plan_benchmark(loaded.scenario, loaded.terrain, o);
    std::cout << report.to_json().dump(2) << '\n';
  });

  // `ridgeline bench replan [--scenario FILE] [--cases N] [--seed S] [--window-s W]
  // [--time-margin-s D]`: the local re-plan (planning/local_replan) against N random sudden
  // threats thrown at the scenario's plan: median/p99 wall and CPU time, status counts
  // (sim/replan_benchmark.hpp).
  struct ReplanCommandOptions {
    std::string scenario;
    benchmarks::ReplanBenchmarkOptions benchmark;
  };
  auto replan_options = std::make_shared<ReplanCommandOptions>();
  CLI::App* replan = bench->add_subcommand(
      "replan", "The local re-plan's time over random sudden threats on the scenario's plan");
  replan->add_option("--scenario", replan_options->scenario, "Scenario YAML (default: embedded)");
  replan->add_option("--cases", replan_options->benchmark.cases, "random threats")
      ->capture_default_str();
  replan->add_option("--seed", replan_options->benchmark.seed, "seed of the cases")
      ->capture_default_str();
  replan
      ->add_option("--window-s", replan_options->benchmark.replan.window_s, "re-planned window (s)")
      ->capture_default_str();
  replan->add_option("--time-margin-s", replan_options->benchmark.replan.threat_time_margin_s,
                     "avoid each threat over [t - D, t + D] (default: its sweep over the window)");
  replan
      ->add_option("--budget-s", replan_options->benchmark.replan.time_budget_s,
                   "time budget of one re-plan's solves (an early exit is a failure status)")
      ->capture_default_str();
  replan->callback([replan_options] {
    const benchmarks::ReplanBenchmarkOptions& o = replan_options->benchmark;
    if (o.cases < 1) throw InputError("--cases", "must be at least 1");
    if (!(o.replan.window_s > 0.0 && std::isfinite(o.replan.window_s)))
      throw InputError("--window-s", "must be positive");
    if (!(o.replan.threat_time_margin_s >= 0.0))
      throw InputError("--time-margin-s", "must not be negative");
    if (!(o.replan.time_budget_s > 0.0 && std::isfinite(o.replan.time_budget_s)))
      throw InputError("--budget-s", "must be positive");
    const io::LoadedScenario loaded = load_scenario_argument(replan_options->scenario);
    const benchmarks::ReplanBenchmarkReport report = benchmarks::run_replan_benchmark(
        mission::make_planning_problem(loaded.scenario, loaded.terrain),
        mission::make_planner_options(loaded.scenario), o);
    std::cout << report.to_json().dump(2) << '\n';
  });

  struct MissionCommandOptions {
    std::string scenario;
    benchmarks::MissionBenchmarkOptions benchmark;
  };
  auto mission_options = std::make_shared<MissionCommandOptions>();
  CLI::App* mission = bench->add_subcommand(
      "mission", "The closed loop's real-time factor: one plan flown N times, medians");
  mission->add_option("--scenario", mission_options->scenario, "Scenario YAML (default: embedded)");
  mission->add_option("--repeats", mission_options->benchmark.repeats, "identical flights")
      ->capture_default_str();
  mission->callback([mission_options] {
    if (mission_options->benchmark.repeats < 1) throw InputError("--repeats", "must be at least 1");
    const io::LoadedScenario loaded = load_scenario_argument(mission_options->scenario);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded);
    if (!plan) return;
    const benchmarks::MissionBenchmarkReport report = benchmarks::run_mission_benchmark(
        loaded.scenario, loaded.terrain, *plan, mission_options->benchmark);
    std::cout << report.to_json().dump(2) << '\n';
  });

  struct HostCommandOptions {
    double seconds = 5.0;
    double threshold_us = benchmarks::kInterruptionThresholdUs;
  };
  auto host_options = std::make_shared<HostCommandOptions>();
  CLI::App* host = bench->add_subcommand(
      "host", "This core's speed and the pauses of this thread (run it pinned: taskset -c N)");
  host->add_option("--seconds", host_options->seconds, "how long to read the clock")
      ->capture_default_str();
  host->add_option("--threshold-us", host_options->threshold_us,
                   "a gap between two clock readings longer than this is a pause")
      ->capture_default_str();
  host->callback([host_options] {
    // Bounded so that a typo cannot hold a core for hours; a day covers any soak test.
    if (!(std::isfinite(host_options->seconds) && host_options->seconds > 0.0 &&
          host_options->seconds <= 86400.0)) {
      throw InputError("--seconds", "must be above 0 and at most 86400");
    }
    if (!(std::isfinite(host_options->threshold_us) && host_options->threshold_us > 0.0)) {
      throw InputError("--threshold-us", "must be finite and above 0");
    }
    const int cpu = sched_getcpu();
    const double speed = benchmarks::dependent_adds_per_ns();
    const benchmarks::HostInterruptions pauses =
        benchmarks::probe_interruptions(host_options->seconds * 1000.0, host_options->threshold_us);
    const nlohmann::json report = {{"cpu", cpu},
                                   {"processor", benchmarks::this_processor()},
                                   {"dependent_adds_per_ns", speed},
                                   {"threshold_us", host_options->threshold_us},
                                   {"host_interruptions", pauses.to_json()}};
    std::cout << report.dump(2) << '\n';
  });

  auto options = std::make_shared<benchmarks::MpcBenchmarkOptions>();
  CLI::App* mpc = bench->add_subcommand(
      "mpc", "The MPC step (Np 40, Nc 10, 3 threats, 2 neighbours, terrain) and our QP vs Ipopt");
  mpc->add_option("--steps", options->steps, "closed-loop control steps")->capture_default_str();
  mpc->add_option("--np", options->prediction_horizon, "prediction horizon Np (steps of 0.1 s)")
      ->capture_default_str();
  mpc->add_option("--nc", options->control_horizon, "control horizon Nc (moves)")
      ->capture_default_str();
  mpc->add_option("--ipopt-every", options->ipopt_every, "solve every n-th QP with Ipopt too")
      ->capture_default_str();
  mpc->add_option("--dump-qps", options->dump_qps_path,
                  "write every step's QP to this RLQP file (for bench qp --instances)");
  mpc->callback([options] {
    if (options->steps < 1) throw InputError("--steps", "must be at least 1");
    if (options->ipopt_every < 0) throw InputError("--ipopt-every", "must not be negative");
    if (options->prediction_horizon < 1) throw InputError("--np", "must be at least 1");
    if (options->control_horizon < 1 || options->control_horizon > options->prediction_horizon)
      throw InputError("--nc", "must be between 1 and --np");
    std::cout << benchmarks::run_mpc_benchmark(*options).to_json().dump(2) << '\n';
  });

  struct QpCommandOptions {
    std::string instances;
    bool json = false;
    std::string method = "active-set";
    std::string reference = "ipopt";
    int repeats = 3;
  };
  auto qp_options = std::make_shared<QpCommandOptions>();
  CLI::App* qp = bench->add_subcommand(
      "qp", "Our QP solver on an RLQP instance file, in order and hot-started, vs the LLT floor");
  qp->add_option("--instances", qp_options->instances, "RLQP file (gen_mpc_qps.py, --dump-qps)")
      ->required();
  qp->add_flag("--json", qp_options->json, "print the report as JSON");
  qp->add_option("--repeats", qp_options->repeats,
                 "passes over the sequence; an instance's time is its minimum over them")
      ->capture_default_str();
  qp->add_option("--method", qp_options->method, "active-set | interior-point")
      ->capture_default_str();
  qp->add_option("--reference", qp_options->reference,
                 "ipopt | interior-point | none: the tight solve the objective gap is measured "
                 "against")
      ->capture_default_str();
  qp->callback([qp_options] {
    benchmarks::QpBenchmarkOptions o;
    if (qp_options->repeats < 1) throw InputError("--repeats", "must be at least 1");
    o.repeats = qp_options->repeats;
    if (qp_options->method == "active-set") {
      o.settings.method = qp::QpMethod::kActiveSet;
    } else if (qp_options->method == "interior-point") {
      o.settings.method = qp::QpMethod::kInteriorPoint;
    } else {
      throw InputError("--method",
                       "'" + qp_options->method + "' is not one of active-set, interior-point");
    }
    if (qp_options->reference == "ipopt") {
      o.reference = benchmarks::QpReference::kIpopt;
    } else if (qp_options->reference == "interior-point") {
      o.reference = benchmarks::QpReference::kInteriorPoint;
    } else if (qp_options->reference == "none") {
      o.reference = benchmarks::QpReference::kNone;
    } else {
      throw InputError("--reference",
                       "'" + qp_options->reference + "' is not one of ipopt, interior-point, none");
    }
    const std::vector<qp::QpProblem> instances = qp::read_qp_instance_file(qp_options->instances);
    if (instances.empty()) throw InputError(qp_options->instances, "holds no instances");
    const benchmarks::QpBenchmarkReport report = benchmarks::run_qp_benchmark(instances, o);
    if (qp_options->json) {
      std::cout << report.to_json().dump(2) << '\n';
      return;
    }
    std::cout << report.count << " instances, " << report.method << ": solve median "
              << report.solve_us.median << " us (p99 " << report.solve_us.p99 << ", max "
              << report.solve_us.max << "), LLT floor median " << report.floor_llt_us_median
              << " us, failures " << report.failures.size() << ", fallbacks " << report.fallbacks
              << ", max violation " << report.max_violation << ", max rel. objective gap "
              << report.max_rel_objective_gap << '\n';
  });
  struct SwarmCommandOptions {
    std::string scenario;
    std::vector<int> uavs = {8, 16, 32};
    std::vector<double> latencies_ms = {0.0, 100.0, 300.0};
    benchmarks::SwarmBenchmarkOptions benchmark;
    std::string out;
    std::uint64_t replay = 0;
  };
  auto swarm_options = std::make_shared<SwarmCommandOptions>();
  CLI::App* swarm = bench->add_subcommand(
      "swarm", "Circle swaps over terrain under link latency and loss: collision-free and "
               "completion rates");
  swarm->add_option("--scenario", swarm_options->scenario,
                    "Scenario YAML whose terrain, wind, limits and layers are used (default: "
                    "embedded)");
  swarm->add_option("--uavs", swarm_options->uavs, "team sizes")->delimiter(',')
      ->capture_default_str();
  swarm->add_option("--latency-ms", swarm_options->latencies_ms, "link latencies (ms)")
      ->delimiter(',')->capture_default_str();
  swarm->add_option("--loss", swarm_options->benchmark.loss_rate, "message loss rate")
      ->capture_default_str();
  swarm->add_option("--runs", swarm_options->benchmark.runs, "seeded runs a cell")
      ->capture_default_str();
  swarm->add_option("--threads", swarm_options->benchmark.threads, "worker threads")
      ->capture_default_str();
  swarm->add_option("--radius-m", swarm_options->benchmark.radius_m, "circle radius")
      ->capture_default_str();
  swarm->add_option("--out", swarm_options->out, "folder for swarm.json and swarm.md");
  swarm->add_option("--replay", swarm_options->replay,
                    "fly one run again by its seed (one --uavs, one --latency-ms): DIR gets its "
                    "metrics.json and trajectories.csv");
  swarm->callback([swarm_options] {
    benchmarks::SwarmBenchmarkOptions o = swarm_options->benchmark;
    o.team_sizes = swarm_options->uavs;
    o.latencies_s.clear();
    for (double ms : swarm_options->latencies_ms) o.latencies_s.push_back(ms * 1e-3);
    if (!std::isfinite(o.radius_m)) throw InputError("--radius-m", "must be finite");
    const io::LoadedScenario loaded = load_scenario_argument(swarm_options->scenario);
    if (swarm_options->replay != 0) {
      if (o.team_sizes.size() != 1 || o.latencies_s.size() != 1)
        throw InputError("--replay", "needs exactly one --uavs and one --latency-ms");
      if (swarm_options->out.empty()) throw InputError("--replay", "needs --out DIR");
      mission::Scenario flown;
      const mission::MissionResult r = benchmarks::replay_swarm_run(
          loaded.scenario, loaded.terrain, o.team_sizes.front(), o.radius_m,
          o.latencies_s.front(), o.loss_rate, swarm_options->replay, &flown);
      const std::filesystem::path dir(swarm_options->out);
      std::filesystem::create_directories(dir);
      io::write_file_atomically(dir / "metrics.json", mission::to_json(r.metrics).dump(2) + "\n");
      io::write_file_atomically(dir / "trajectories.csv",
                                mission::trajectories_csv(r.trajectories, flown));
      std::cout << "min separation " << r.metrics.min_separation_m << " m; wrote metrics.json and "
                << "trajectories.csv to " << dir.string() << '\n';
      return;
    }
    o.progress = [](const std::string& cell, int done, int total, int failed) {
      if (done == total || done % 10 == 0)
        std::cerr << cell << ": " << done << "/" << total << " runs, " << failed << " failed\n";
    };
    const benchmarks::SwarmBenchmarkReport report =
        benchmarks::run_swarm_benchmark(loaded.scenario, loaded.terrain, o);
    const std::string table = report.to_markdown();
    std::cout << table;
    if (!swarm_options->out.empty()) {
      const std::filesystem::path dir(swarm_options->out);
      std::filesystem::create_directories(dir);
      io::write_file_atomically(dir / "swarm.json", report.to_json().dump(2) + "\n");
      io::write_file_atomically(dir / "swarm.md", table);
    }
  });
}

}  // namespace ridgeline::apps
