#include "benchmarks/mission_benchmark.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "sim/mission.hpp"

namespace ridgeline::benchmarks {
namespace {

double median(std::vector<double> v) { return mission::percentiles(std::move(v)).median; }

nlohmann::json run_to_json(const MissionBenchmarkRun& r) {
  return {{"sim_time_s", r.sim_time_s},
          {"wall_time_s", r.wall_time_s},
          {"cpu_time_s", r.cpu_time_s},
          {"safe", r.safe},
          {"mission_complete", r.mission_complete},
          {"mpc_step_us", to_json(r.mpc_step_us)},
          {"mpc_step_cpu_us", to_json(r.mpc_step_cpu_us)}};
}

}  // namespace

nlohmann::json MissionBenchmarkReport::to_json() const {
  nlohmann::json runs_json = nlohmann::json::array();
  for (const MissionBenchmarkRun& r : runs) runs_json.push_back(run_to_json(r));
  return {{"uavs", uavs},
          {"flights", static_cast<int>(runs.size())},
          {"sim_time_s", runs.empty() ? 0.0 : runs.front().sim_time_s},
          {"wall_time_s_median", wall_time_s_median},
          {"cpu_time_s_median", cpu_time_s_median},
          {"real_time_factor_wall", real_time_factor_wall},
          {"real_time_factor_cpu", real_time_factor_cpu},
          {"deterministic", deterministic},
          {"all_safe", std::all_of(runs.begin(), runs.end(),
                                   [](const MissionBenchmarkRun& r) { return r.safe; })},
          {"host_speed", host_speed.to_json()},
          {"host_interruptions", host_interruptions.to_json()},
          {"runs", runs_json}};
}

MissionBenchmarkReport run_mission_benchmark(const mission::Scenario& scenario,
                                             std::shared_ptr<const world::Terrain> terrain,
                                             const planning::GlobalPlan& plan,
                                             const MissionBenchmarkOptions& options) {
  if (options.repeats < 1) throw InputError("repeats", "must be at least 1");
  MissionBenchmarkReport report;
  report.uavs = static_cast<int>(scenario.uavs.size());
  sim::MissionOptions mission_options;  // records trajectories, as `ridgeline run` does
  std::vector<double> wall, cpu, rtf_wall, rtf_cpu;
  std::vector<double> first_path_lengths;
  report.host_speed.read_before();
  report.host_interruptions = probe_interruptions();
  for (int k = 0; k < options.repeats; ++k) {
    const mission::MissionResult flown = sim::fly_mission(scenario, terrain, plan, mission_options);
    const mission::MissionMetrics& m = flown.metrics;
    MissionBenchmarkRun r;
    r.sim_time_s = m.sim_time_s;
    r.wall_time_s = m.wall_time_s;
    r.cpu_time_s = m.cpu_time_s;
    r.safe = m.safe();
    r.mission_complete = m.mission_complete;
    r.mpc_step_us = m.mpc_solve_us;
    r.mpc_step_cpu_us = m.mpc_solve_cpu_us;
    std::vector<double> lengths;
    for (const mission::UavMetrics& u : m.uavs) lengths.push_back(u.path_length_m);
    if (k == 0) {
      first_path_lengths = lengths;
    } else {
      report.deterministic = report.deterministic &&
                             r.sim_time_s == report.runs.front().sim_time_s &&
                             lengths == first_path_lengths;
    }
    wall.push_back(r.wall_time_s);
    cpu.push_back(r.cpu_time_s);
    rtf_wall.push_back(r.wall_time_s > 0.0 ? r.sim_time_s / r.wall_time_s : 0.0);
    rtf_cpu.push_back(r.cpu_time_s > 0.0 ? r.sim_time_s / r.cpu_time_s : 0.0);
    report.runs.push_back(r);
  }
  report.host_speed.read_after();
  report.wall_time_s_median = median(wall);
  report.cpu_time_s_median = median(cpu);
  report.real_time_factor_wall = median(rtf_wall);
  report.real_time_factor_cpu = median(rtf_cpu);
  return report;
}

}  // namespace ridgeline::benchmarks
