#include "benchmarks/replan_benchmark.hpp"

#include <fmt/format.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"

namespace ridgeline::benchmarks {
namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

planning::TimedPath reference_path(const planning::UavPlan& u) {
  planning::TimedPath p;
  p.name = u.name;
  for (std::size_t k = 0; k < u.timing.samples.size(); ++k) {
    p.waypoints_m.push_back(u.timing.samples[k].position_m);
    p.times_s.push_back(u.timing.sample_times_s[k]);
  }
  return p;
}

}  // namespace

nlohmann::json ReplanBenchmarkReport::to_json() const {
  nlohmann::json counts = nlohmann::json::object();
  for (const auto& [status, n] : status_counts) counts[status] = n;
  return {{"case", fmt::format("default scenario, {} random threats, {}", cases, window)},
          {"cases", cases},
          {"optimized", optimized},
          {"status_counts", counts},
          {"first_messages", first_messages},
          {"replan_ms", mission::to_json(replan_ms)},
          {"replan_cpu_ms", mission::to_json(replan_cpu_ms)},
          {"ipopt_iterations", mission::to_json(ipopt_iterations)},
          {"solves", mission::to_json(solves)},
          {"min_threat_distance_m", min_threat_distance_m},
          {"min_separation_m", min_separation_m},
          {"min_terrain_clearance_m", min_terrain_clearance_m},
          {"mean_detour_ratio", mean_detour_ratio},
          {"plan_s", plan_s}};
}

ReplanBenchmarkReport run_replan_benchmark(const planning::GlobalPlanningProblem& problem,
                                           const planning::GlobalPlannerOptions& planner,
                                           const ReplanBenchmarkOptions& options) {
  if (options.cases < 1)
    throw InputError("cases", fmt::format("must be >= 1, got {}", options.cases));
  ReplanBenchmarkReport report;
  const auto plan_start = std::chrono::steady_clock::now();
  const planning::GlobalPlan plan = planning::plan_mission(problem, planner);
  report.plan_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - plan_start).count();
  if (plan.status != planning::GlobalPlanStatus::kPlanned)
    throw InputError("scenario", "the global plan failed (" + std::string(to_string(plan.status)) +
                                     "): " + plan.message);

  planning::LocalReplanOptions o = options.replan;
  o.timing.control_period_s = planner.timing.control_period_s;
  report.window = fmt::format("window {:.0f} s, grid {:.1f} s, r_safe {:.0f} m, sweep {}",
                              o.window_s, o.time_step_s, problem.limits.threat_margin_m,
                              std::isinf(o.threat_time_margin_s)
                                  ? std::string("over the window")
                                  : fmt::format("+-{:.1f} s", o.threat_time_margin_s));

  std::vector<planning::TimedPath> paths;
  for (const planning::UavPlan& u : plan.uavs) paths.push_back(reference_path(u));

  Rng rng(options.seed);
  std::vector<double> wall_ms, cpu_ms, iterations, solves;
  double detour_sum = 0.0;
  int replanned = 0;
  report.min_threat_distance_m = std::numeric_limits<double>::infinity();
  report.min_separation_m = std::numeric_limits<double>::infinity();
  report.min_terrain_clearance_m = std::numeric_limits<double>::infinity();
  for (int c = 0; c < options.cases; ++c) {
    const int i = std::min(static_cast<int>(rng.uniform() * static_cast<double>(plan.uavs.size())),
                           static_cast<int>(plan.uavs.size()) - 1);
    const planning::UavPlan& u = plan.uavs[static_cast<std::size_t>(i)];
    const mpc::SampledReference& ref = *u.timing.reference;
    const double t_begin = ref.start_time_s();
    const double t_end = ref.end_time_s();
    const double t0 = rng.uniform(t_begin, std::max(t_begin, t_end - 10.0));
    const double t_cross = std::min(t0 + rng.uniform(8.0, 25.0), t_end);
    const double radius = rng.uniform(30.0, 60.0);
    const double speed = rng.uniform(2.0, 8.0);
    const mpc::ReferencePoint at_cross = ref.at(t_cross);
    const double psi = at_cross.heading_rad + rng.uniform(-kPi, kPi);
    world::Threat threat;
    threat.name = fmt::format("case{}", c);
    threat.radius_m = radius;
    threat.velocity_m_s = Vec3(speed * std::cos(psi), speed * std::sin(psi), 0.0);
    threat.appear_s = t0;
    threat.centre_m = at_cross.position_m - threat.velocity_m_s * (t_cross - t0);

    planning::LocalReplanProblem p;
    p.terrain = problem.terrain.get();
    p.reference = &ref;
    p.reference_end_time_s = t_end;
    p.start_time_s = t0;
    p.vehicle = problem.uavs[static_cast<std::size_t>(i)].vehicle;
    p.threats = {threat};
    p.limits = problem.limits;
    for (int j = 0; j < static_cast<int>(paths.size()); ++j)
      if (j != i) p.others.push_back(paths[static_cast<std::size_t>(j)]);

    const double cpu0 = thread_cpu_s();
    const auto wall0 = std::chrono::steady_clock::now();
    const planning::LocalReplanResult r = planning::replan_locally(p, o);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    const double cpu = thread_cpu_s() - cpu0;
    ++report.status_counts[std::string(to_string(r.status))];
    if (!r.message.empty())
      report.first_messages.try_emplace(std::string(to_string(r.status)),
                                        fmt::format("case {}: {}", c, r.message));
    if (r.status == planning::LocalReplanStatus::kInvalidInput)
      throw InputError("replan", fmt::format("case {}: {}", c, r.message));
    if (r.solves > 0) {
      ++report.optimized;
      wall_ms.push_back(1e3 * wall);
      cpu_ms.push_back(1e3 * cpu);
      iterations.push_back(r.ipopt_iterations);
      solves.push_back(r.solves);
    }
    if (r.ok()) {
      ++replanned;
      report.min_threat_distance_m =
          std::min(report.min_threat_distance_m, r.min_threat_distance_m);
      report.min_separation_m = std::min(report.min_separation_m, r.min_separation_m);
      report.min_terrain_clearance_m =
          std::min(report.min_terrain_clearance_m, r.min_terrain_clearance_m);
      detour_sum += r.length_m / std::max(r.old_length_m, 1e-9);
    }
  }
  report.cases = options.cases;
  report.replan_ms = mission::percentiles(wall_ms);
  report.replan_cpu_ms = mission::percentiles(cpu_ms);
  report.ipopt_iterations = mission::percentiles(iterations);
  report.solves = mission::percentiles(solves);
  report.mean_detour_ratio = replanned > 0 ? detour_sum / replanned : 0.0;
  return report;
}

}  // namespace ridgeline::benchmarks
