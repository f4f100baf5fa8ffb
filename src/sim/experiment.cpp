#include "sim/experiment.hpp"

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

constexpr double kErrorSampleSpacingM = 10.0;  // as the metrics (DESIGN §6)

struct RunResult {
  bool ok = false;
  std::string error;
  std::uint64_t seed = 0;
  mission::MissionMetrics metrics;
  std::vector<double> bin_sum;  ///< Σ squared error per distance bin
  std::vector<long long> bin_count;
};

nlohmann::json mean_std(const std::vector<double>& v) {
  if (v.empty()) return {{"mean", nullptr}, {"std", nullptr}, {"count", 0}};
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double ss = 0.0;
  for (const double x : v) ss += (x - mean) * (x - mean);
  // Sample standard deviation (n − 1); 0 for one value.
  const double sd = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0.0;
  return {{"mean", mean}, {"std", sd}, {"count", v.size()}};
}

void bin_errors(const std::vector<mission::TrajectoryRow>& rows, int uavs, double bin_m,
                RunResult& out) {
  std::vector<double> travelled(static_cast<std::size_t>(uavs), 0.0),
      next(static_cast<std::size_t>(uavs), 0.0);
  std::vector<Vec3> last(static_cast<std::size_t>(uavs));
  std::vector<char> seen(static_cast<std::size_t>(uavs), 0);
  for (const mission::TrajectoryRow& r : rows) {
    const std::size_t i = static_cast<std::size_t>(r.uav);
    if (seen[i]) travelled[i] += (r.position_m - last[i]).norm();
    seen[i] = 1;
    last[i] = r.position_m;
    if (travelled[i] < next[i]) continue;
    next[i] += kErrorSampleSpacingM;
    const std::size_t bin = static_cast<std::size_t>(travelled[i] / bin_m);
    if (bin >= out.bin_sum.size()) {
      out.bin_sum.resize(bin + 1, 0.0);
      out.bin_count.resize(bin + 1, 0);
    }
    out.bin_sum[bin] += (r.position_m - r.reference_m).squaredNorm();
    ++out.bin_count[bin];
  }
}

}  // namespace

std::vector<ExperimentTask> default_experiment_tasks() {
  return {
      {"northeast", "the scenario's own targets", {}},
      {"east", "three targets up the eastern side", {{0.90, 0.35}, {0.75, 0.65}, {0.55, 0.95}}},
      {"crossing", "three targets across the middle", {{0.15, 0.90}, {0.50, 0.55}, {0.95, 0.60}}},
      {"far_corner", "one far target for the whole team", {{0.92, 0.92}}},
  };
}

mission::Scenario task_scenario(const mission::Scenario& base, const world::Terrain& terrain,
                                const ExperimentTask& task, double target_height_m) {
  mission::Scenario s = base;
  s.name = base.name + "/" + task.name;
  if (!task.target_fractions.empty()) {
    s.targets.clear();
    int k = 0;
    for (const Vec2& f : task.target_fractions) {
      if (!(f.x() >= 0.0 && f.x() <= 1.0 && f.y() >= 0.0 && f.y() <= 1.0))
        throw InputError(fmt::format("tasks.{}.targets[{}]", task.name, k),
                         "fractions of the area must be in [0, 1]");
      const double x = s.area.x_min_m + f.x() * (s.area.x_max_m - s.area.x_min_m);
      const double y = s.area.y_min_m + f.y() * (s.area.y_max_m - s.area.y_min_m);
      const double z = std::clamp(terrain.height(x, y) + target_height_m, s.safety.altitude.min_m,
                                  s.safety.altitude.max_m);
      s.targets.push_back({fmt::format("{}{}", task.name, k + 1), Vec3(x, y, z), 1, 30.0});
      ++k;
    }
  }
  const std::vector<InputError> errors = validate(s, terrain);
  if (!errors.empty()) throw InputError(fmt::format("tasks.{}", task.name), errors.front().what());
  return s;
}

nlohmann::json run_experiment(const mission::Scenario& base,
                              std::shared_ptr<const world::Terrain> terrain,
                              const ExperimentOptions& options) {
  if (options.runs < 1) throw InputError("runs", "must be at least 1");
  if (options.threads < 1) throw InputError("threads", "must be at least 1");
  if (options.tasks.empty()) throw InputError("tasks", "none given");
  if (options.methods.empty()) throw InputError("methods", "none given");
  if (!options.ddpg_policy &&
      std::find(options.methods.begin(), options.methods.end(), Method::kDdpg) !=
          options.methods.end())
    throw InputError("--ddpg-model", "method ddpg needs a DDPG model (none loaded)");
  if (!(options.error_bin_m > 0.0)) throw InputError("error_bin_m", "must be positive");
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n_tasks = options.tasks.size(), n_methods = options.methods.size();
  const std::size_t runs = static_cast<std::size_t>(options.runs);

  std::vector<mission::Scenario> scenarios;
  for (const ExperimentTask& t : options.tasks)
    scenarios.push_back(task_scenario(base, *terrain, t, options.target_height_m));
  // One plan per task and method, before any flight (the ground station's step).
  std::vector<planning::GlobalPlan> plans(n_tasks * n_methods);
  for (std::size_t t = 0; t < n_tasks; ++t)
    for (std::size_t m = 0; m < n_methods; ++m)
      plans[t * n_methods + m] = plan_for_method(scenarios[t], terrain, options.methods[m]);

  std::vector<RunResult> results(n_tasks * n_methods * runs);
  const int total = static_cast<int>(results.size());
  std::atomic<int> next{0};
  std::mutex progress_mutex;
  int done = 0;
  auto worker = [&] {
    for (int job = next++; job < total; job = next++) {
      const std::size_t r = static_cast<std::size_t>(job) % runs;
      const std::size_t m = (static_cast<std::size_t>(job) / runs) % n_methods;
      const std::size_t t = static_cast<std::size_t>(job) / (runs * n_methods);
      RunResult& out = results[static_cast<std::size_t>(job)];
      // The same seed for every method: run r of task t meets the same world.
      out.seed = variation_seed(scenarios[t], static_cast<int>(r));
      const planning::GlobalPlan& plan = plans[t * n_methods + m];
      if (plan.status != planning::GlobalPlanStatus::kPlanned) {
        out.error = "not planned: " + plan.message;
      } else {
        try {
          const mission::Scenario varied =
              vary_scenario(scenarios[t], *terrain, out.seed, options.variation);
          MissionOptions mission;
          mission.method = options.methods[m];
          mission.ddpg_policy = options.ddpg_policy;
          mission::MissionResult flown = fly_mission(varied, terrain, plan, mission);
          bin_errors(flown.trajectories, static_cast<int>(varied.uavs.size()), options.error_bin_m,
                     out);
          out.metrics = std::move(flown.metrics);
          out.ok = true;
        } catch (const std::exception& e) {
          out.error = e.what();
        }
      }
      std::lock_guard lock(progress_mutex);
      ++done;
      if (options.progress)
        options.progress(
            done, total,
            fmt::format("{}/{}/run {}", options.tasks[t].name, to_string(options.methods[m]), r));
    }
  };
  const int threads = std::min(options.threads, total);
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (std::thread& th : pool) th.join();

  nlohmann::json out;
  out["runs"] = options.runs;
  out["threads"] = threads;
  nlohmann::json method_names = nlohmann::json::array();
  for (const Method m : options.methods) method_names.push_back(to_string(m));
  out["methods"] = method_names;
  out["tasks"] = nlohmann::json::array();
  for (std::size_t t = 0; t < n_tasks; ++t) {
    nlohmann::json task;
    task["task"] = options.tasks[t].name;
    task["description"] = options.tasks[t].description;
    task["targets"] = nlohmann::json::array();
    for (const mission::InspectionTarget& target : scenarios[t].targets)
      task["targets"].push_back(
          {{"name", target.name},
           {"position_m", {target.position_m.x(), target.position_m.y(), target.position_m.z()}}});
    task["seeds"] = nlohmann::json::array();
    for (std::size_t r = 0; r < runs; ++r)
      task["seeds"].push_back(variation_seed(scenarios[t], static_cast<int>(r)));
    nlohmann::json methods = nlohmann::json::object();
    for (std::size_t m = 0; m < n_methods; ++m) {
      const planning::GlobalPlan& plan = plans[t * n_methods + m];
      std::vector<double> team_path, uav_path, mse, medians, p99s, walls;
      double step_max = 0.0;
      long long encounters = 0, intrusions = 0, terrain_hits = 0, separation = 0, violations = 0,
                complete = 0;
      std::vector<double> bin_sum;
      std::vector<long long> bin_count;
      nlohmann::json run_rows = nlohmann::json::array();
      for (std::size_t r = 0; r < runs; ++r) {
        const RunResult& rr = results[(t * n_methods + m) * runs + r];
        nlohmann::json row = {{"run", r}, {"seed", rr.seed}};
        if (!rr.ok) {
          row["error"] = rr.error;
          run_rows.push_back(std::move(row));
          continue;
        }
        const mission::MissionMetrics& mm = rr.metrics;
        double path = 0.0, run_mse = 0.0;
        for (const mission::UavMetrics& u : mm.uavs) {
          path += u.path_length_m;
          uav_path.push_back(u.path_length_m);
          mse.push_back(u.tracking_mse_m2);
          run_mse += u.tracking_mse_m2 / static_cast<double>(mm.uavs.size());
        }
        team_path.push_back(path);
        encounters += mm.threat_encounters;
        intrusions += mm.threat_intrusions;
        terrain_hits += mm.terrain_collisions;
        separation += mm.separation_violations;
        violations += mm.total_constraint_violations();
        complete += mm.mission_complete ? 1 : 0;
        medians.push_back(mm.mpc_solve_us.median);
        p99s.push_back(mm.mpc_solve_us.p99);
        step_max = std::max(step_max, mm.mpc_solve_us.max);
        walls.push_back(mm.wall_time_s);
        if (rr.bin_sum.size() > bin_sum.size()) {
          bin_sum.resize(rr.bin_sum.size(), 0.0);
          bin_count.resize(rr.bin_sum.size(), 0);
        }
        for (std::size_t b = 0; b < rr.bin_sum.size(); ++b) {
          bin_sum[b] += rr.bin_sum[b];
          bin_count[b] += rr.bin_count[b];
        }
        row["path_length_m"] = path;
        row["tracking_mse_m2"] = run_mse;
        row["threat_encounters"] = mm.threat_encounters;
        row["threat_intrusions"] = mm.threat_intrusions;
        row["terrain_collisions"] = mm.terrain_collisions;
        row["separation_violations"] = mm.separation_violations;
        row["min_threat_distance_m"] = std::isfinite(mm.min_threat_distance_m)
                                           ? nlohmann::json(mm.min_threat_distance_m)
                                           : nlohmann::json(nullptr);
        row["mission_complete"] = mm.mission_complete;
        row["sim_time_s"] = mm.sim_time_s;
        run_rows.push_back(std::move(row));
      }
      nlohmann::json by_distance = {{"bin_m", options.error_bin_m},
                                    {"distance_m", nlohmann::json::array()},
                                    {"mse_m2", nlohmann::json::array()},
                                    {"samples", nlohmann::json::array()}};
      for (std::size_t b = 0; b < bin_sum.size(); ++b) {
        if (bin_count[b] == 0) continue;
        by_distance["distance_m"].push_back((static_cast<double>(b) + 0.5) * options.error_bin_m);
        by_distance["mse_m2"].push_back(bin_sum[b] / static_cast<double>(bin_count[b]));
        by_distance["samples"].push_back(bin_count[b]);
      }
      const auto mean_of = [](const std::vector<double>& v) {
        return v.empty() ? 0.0
                         : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
      };
      nlohmann::json M;
      M["plan_status"] = std::string(planning::to_string(plan.status));
      M["plan_message"] = plan.message;
      M["plan_time_s"] = plan.total_time_s;
      M["flown_runs"] = team_path.size();
      M["path_length_m"] = mean_std(team_path);
      M["path_length_per_uav_m"] = mean_std(uav_path);
      M["avoidance_success_rate"] = encounters > 0 ? static_cast<double>(encounters - intrusions) /
                                                         static_cast<double>(encounters)
                                                   : 1.0;
      M["threat_encounters"] = encounters;
      M["threat_intrusions"] = intrusions;
      M["tracking_mse_m2"] = mean_std(mse);
      M["tracking_mse_by_distance"] = std::move(by_distance);
      M["collisions"] = {
          {"terrain", terrain_hits}, {"threat", intrusions}, {"separation", separation}};
      M["constraint_violations"] = violations;
      M["missions_complete"] = complete;
      M["control_step_us"] = {
          {"median", mean_of(medians)}, {"p99", mean_of(p99s)}, {"max", step_max}};
      M["wall_time_s"] = mean_std(walls);
      M["runs"] = std::move(run_rows);
      methods[std::string(to_string(options.methods[m]))] = std::move(M);
    }
    task["methods"] = std::move(methods);
    out["tasks"].push_back(std::move(task));
  }
  out["wall_time_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace ridgeline::sim
