#include "sim/monte_carlo.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <thread>

#include "core/error.hpp"
#include "mission/statistics.hpp"
#include "sim/mission.hpp"

namespace ridgeline::sim {
namespace {

std::vector<std::string> failures_of(const mission::MissionMetrics& m) {
  std::vector<std::string> out;
  if (m.terrain_collisions > 0) out.push_back("terrain collision");
  if (m.threat_intrusions > 0) out.push_back("threat intrusion");
  if (m.separation_violations > 0) out.push_back("separation below d_safe");
  for (const auto& [kind, count] : m.constraint_violations)
    if (count > 0) out.push_back(kind + " limit violated");
  if (!m.mission_complete) out.push_back("mission not complete");
  return out;
}

nlohmann::json distribution(std::vector<double> v) {
  std::erase_if(v, [](double x) { return !std::isfinite(x); });
  if (v.empty()) return nullptr;
  const mission::Percentiles p = mission::percentiles(v);
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  return {{"min", *std::min_element(v.begin(), v.end())},
          {"median", p.median},
          {"p90", p.p90},
          {"max", p.max},
          {"mean", mean},
          {"count", v.size()}};
}

nlohmann::json rate(long long successes, long long trials) {
  const mission::Interval w = mission::wilson_interval(successes, trials);
  return {
      {"successes", successes},
      {"trials", trials},
      {"value", trials > 0 ? static_cast<double>(successes) / static_cast<double>(trials) : 1.0},
      {"wilson95", {w.low, w.high}}};
}

}  // namespace

MonteCarloReport run_monte_carlo(const mission::Scenario& scenario,
                                 std::shared_ptr<const world::Terrain> terrain,
                                 const planning::GlobalPlan& plan,
                                 const MonteCarloOptions& options) {
  if (options.runs < 1) throw InputError("runs", "must be at least 1");
  if (options.threads < 1) throw InputError("threads", "must be at least 1");
  if (plan.status != planning::GlobalPlanStatus::kPlanned)
    throw InputError("plan", "is not planned: " + plan.message);
  const auto start = std::chrono::steady_clock::now();
  MonteCarloReport report;
  report.threads = std::min(options.threads, options.runs);
  report.runs.resize(static_cast<std::size_t>(options.runs));
  std::atomic<int> next{0};
  std::mutex progress_mutex;
  int done = 0, failed = 0;
  auto worker = [&] {
    for (int i = next++; i < options.runs; i = next++) {
      MonteCarloRun& run = report.runs[static_cast<std::size_t>(i)];
      run.index = i;
      run.seed = variation_seed(scenario, i);
      try {
        const mission::Scenario varied =
            vary_scenario(scenario, *terrain, run.seed, options.variation);
        MissionOptions mission;
        mission.record_trajectories = false;
        mission.method = options.method;
        mission.ddpg_policy = options.ddpg_policy;
        run.metrics = fly_mission(varied, terrain, plan, mission).metrics;
        run.failures = failures_of(run.metrics);
      } catch (const std::exception& e) {
        run.failures = {std::string("error: ") + e.what()};
      }
      std::lock_guard lock(progress_mutex);
      ++done;
      failed += run.failures.empty() ? 0 : 1;
      if (options.progress) options.progress(done, options.runs, failed);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < report.threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  report.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

nlohmann::json MonteCarloReport::summary() const {
  const long long n = static_cast<long long>(runs.size());
  long long safe = 0, complete = 0, encounters = 0, intrusions = 0, unavoidable = 0, collisions = 0,
            separation = 0, violations = 0, targets = 0, inspected = 0;
  std::vector<double> min_sep, min_threat, min_clear, rmse, path, step_median, step_p99, sim_time,
      wall_time, cpu_time, replans;
  nlohmann::json failed = nlohmann::json::array();
  for (const MonteCarloRun& r : runs) {
    const mission::MissionMetrics& m = r.metrics;
    safe += m.safe() && !m.uavs.empty() ? 1 : 0;  // no metrics: the run threw
    complete += m.mission_complete ? 1 : 0;
    encounters += m.threat_encounters;
    intrusions += m.threat_intrusions;
    unavoidable += m.unavoidable_intrusions;
    collisions += m.terrain_collisions;
    separation += m.separation_violations;
    violations += m.total_constraint_violations();
    min_sep.push_back(m.min_separation_m);
    min_threat.push_back(m.min_threat_distance_m);
    double clear = INFINITY, rmse_sum = 0.0, path_sum = 0.0, replan_sum = 0.0;
    for (const mission::UavMetrics& u : m.uavs) {
      clear = std::min(clear, u.min_terrain_clearance_m);
      rmse_sum += u.tracking_rmse_m;
      path_sum += u.path_length_m;
      replan_sum += static_cast<double>(u.replans);
      targets += u.targets_assigned;
      inspected += u.targets_inspected;
    }
    if (!m.uavs.empty()) {
      min_clear.push_back(clear);
      rmse.push_back(rmse_sum / static_cast<double>(m.uavs.size()));
      path.push_back(path_sum);
      replans.push_back(replan_sum);
      step_median.push_back(m.mpc_solve_us.median);
      step_p99.push_back(m.mpc_solve_us.p99);
      sim_time.push_back(m.sim_time_s);
      wall_time.push_back(m.wall_time_s);
      cpu_time.push_back(m.cpu_time_s);
    }
    if (!r.failures.empty())
      failed.push_back({{"run", r.index},
                        {"seed", r.seed},
                        {"reasons", r.failures},
                        {"replay", fmt::format("ridgeline run --variation {}", r.seed)}});
  }
  const double sim_total = std::accumulate(sim_time.begin(), sim_time.end(), 0.0);
  // The flights' own CPU time: what the runs cost a core, whatever else shared the machine.
  const double cpu_total = std::accumulate(cpu_time.begin(), cpu_time.end(), 0.0);
  return {{"runs", n},
          {"threads", threads},
          {"wall_time_s", wall_time_s},
          {"runs_per_second", wall_time_s > 0 ? static_cast<double>(n) / wall_time_s : 0.0},
          {"simulated_s_per_wall_s", wall_time_s > 0 ? sim_total / wall_time_s : 0.0},
          {"flight_cpu_time_s", cpu_total},
          {"runs_per_cpu_second", cpu_total > 0 ? static_cast<double>(n) / cpu_total : 0.0},
          {"simulated_s_per_cpu_s", cpu_total > 0 ? sim_total / cpu_total : 0.0},
          {"counts",
           {{"safe_runs", safe},
            {"complete_missions", complete},
            {"terrain_collisions", collisions},
            {"threat_encounters", encounters},
            {"threat_intrusions", intrusions},
            {"threat_intrusions_unavoidable", unavoidable},
            {"threat_intrusions_avoidable", intrusions - unavoidable},
            {"separation_violations", separation},
            {"constraint_violations", violations},
            {"targets_assigned", targets},
            {"targets_inspected", inspected}}},
          {"rates",
           {{"safe", rate(safe, n)},
            {"mission_complete", rate(complete, n)},
            {"avoidance_success", rate(encounters - intrusions, encounters)},
            {"targets_inspected", rate(inspected, targets)}}},
          {"metrics",
           {{"min_separation_m", distribution(min_sep)},
            {"min_threat_distance_m", distribution(min_threat)},
            {"min_terrain_clearance_m", distribution(min_clear)},
            {"tracking_rmse_m", distribution(rmse)},
            {"path_length_m", distribution(path)},
            {"replans", distribution(replans)},
            {"mpc_step_us_median", distribution(step_median)},
            {"mpc_step_us_p99", distribution(step_p99)},
            {"sim_time_s", distribution(sim_time)},
            {"wall_time_s", distribution(wall_time)},
            {"cpu_time_s", distribution(cpu_time)}}},
          {"failed_runs", failed}};
}

}  // namespace ridgeline::sim
