#include "benchmarks/swarm_benchmark.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "mission/stage_inputs.hpp"
#include "sim/mission.hpp"
#include "sim/monte_carlo.hpp"
#include "sim/variation.hpp"

namespace ridgeline::benchmarks {
namespace {

/// The highest terrain within `radius` of `centre`, on a 10 m grid (the swap's straight lines
/// all lie inside the disc).
double highest_terrain(const world::Terrain& terrain, const Vec2& centre, double radius) {
  constexpr double kStep = 10.0;
  double top = -std::numeric_limits<double>::infinity();
  for (double dx = -radius; dx <= radius; dx += kStep)
    for (double dy = -radius; dy <= radius; dy += kStep)
      if (dx * dx + dy * dy <= radius * radius)
        top = std::max(top, terrain.height(centre.x() + dx, centre.y() + dy));
  return top;
}

}  // namespace

mission::Scenario make_circle_swap(const mission::Scenario& base, const world::Terrain& terrain,
                                   const CircleSwapOptions& options) {
  if (options.uavs < 2) throw InputError("--uavs", "a swap needs at least 2 UAVs");
  if (!(options.radius_m > 0.0) || !std::isfinite(options.radius_m))
    throw InputError("--radius-m", "must be positive and finite");
  mission::Scenario s = base;
  s.name = fmt::format("circle-swap-{}", options.uavs);
  s.targets.clear();
  s.threats.clear();
  const mission::Area& a = s.area;
  const Vec2 centre(0.5 * (a.x_min_m + a.x_max_m), 0.5 * (a.y_min_m + a.y_max_m));
  const double margin = 50.0;  // room for the turns of a UAV avoiding others at the rim
  if (options.radius_m + margin > 0.5 * std::min(a.x_max_m - a.x_min_m, a.y_max_m - a.y_min_m))
    throw InputError("--radius-m",
                     fmt::format("a circle of {:.0f} m (+{:.0f} m) does not fit the area",
                                 options.radius_m, margin));
  const double spacing = 2.0 * options.radius_m * std::sin(kPi / options.uavs);
  if (spacing < s.safety.separation_m + 5.0)
    throw InputError("--uavs", fmt::format("{} UAVs on a {:.0f} m circle start {:.1f} m apart, "
                                           "less than d_safe + 5 m",
                                           options.uavs, options.radius_m, spacing));
  const double z = highest_terrain(terrain, centre, options.radius_m + margin) +
                   s.safety.terrain_clearance_m + options.altitude_above_terrain_m;
  if (z < s.safety.altitude.min_m || z > s.safety.altitude.max_m - 20.0)
    throw InputError("--radius-m", fmt::format("the flight altitude {:.0f} m leaves the altitude "
                                               "band [{:.0f}, {:.0f}] m",
                                               z, s.safety.altitude.min_m,
                                               s.safety.altitude.max_m));
  const mission::UavSpec prototype = base.uavs.empty() ? mission::UavSpec{} : base.uavs.front();
  s.uavs.clear();
  for (int i = 0; i < options.uavs; ++i) {
    const double angle = 2.0 * kPi * i / options.uavs;
    const Vec2 out(std::cos(angle), std::sin(angle));
    mission::UavSpec u = prototype;
    u.name = fmt::format("uav{}", i);
    const Vec2 start = centre + options.radius_m * out;
    const Vec2 end = centre - options.radius_m * out;
    u.start_position_m = Vec3(start.x(), start.y(), z);
    u.start_heading_rad = std::atan2(-out.y(), -out.x());
    u.start_speed_m_s = u.vehicle.cruise_speed_m_s;
    u.assigned_targets.clear();
    u.end_position_m = Vec3(end.x(), end.y(), z);
    s.uavs.push_back(std::move(u));
  }
  const double crossing_s = 2.0 * options.radius_m / prototype.vehicle.min_speed_m_s();
  s.simulation.duration_s = crossing_s + 120.0;
  return s;
}

planning::GlobalPlan straight_line_plan(const mission::Scenario& swap,
                                        std::shared_ptr<const world::Terrain> terrain) {
  const planning::GlobalPlannerOptions planner = mission::make_planner_options(swap);
  planning::GlobalPlan plan;
  plan.status = planning::GlobalPlanStatus::kPlanned;
  plan.path_source = planning::PathSource::kInitialPathsOptimizerOff;
  for (const mission::UavSpec& u : swap.uavs) {
    planning::UavPlan up;
    up.name = u.name;
    up.waypoints_m = {u.start_position_m, u.end_position_m.value_or(u.start_position_m)};
    up.timing = planning::time_parametrize(up.waypoints_m, u.vehicle, planner.timing);
    if (up.timing.status != planning::TimeParametrizationStatus::kOk || !up.timing.reference) {
      plan.status = planning::GlobalPlanStatus::kValidationFailed;
      plan.message = fmt::format("{}: straight line not flyable: {}", u.name, up.timing.message);
      return plan;
    }
    // The terrain, checked densely along the line (the swap flies above its highest point).
    for (const mpc::ReferencePoint& p : up.timing.samples) {
      const double clearance = p.position_m.z() - terrain->height(p.position_m.x(), p.position_m.y());
      if (clearance < swap.safety.terrain_clearance_m) {
        plan.status = planning::GlobalPlanStatus::kValidationFailed;
        plan.message = fmt::format("{}: straight line {:.1f} m above the terrain", u.name, clearance);
        return plan;
      }
    }
    plan.uavs.push_back(std::move(up));
  }
  return plan;
}

namespace {

/// The cell's link: the delay is exactly the latency (no jitter), as RMADER's cells.
void set_link(mission::Scenario& swap, double latency_s, double loss_rate) {
  swap.simulation.link_latency_s = latency_s;
  swap.simulation.link_jitter_s = 0.0;
  swap.simulation.link_drop_rate = loss_rate;
}

}  // namespace

mission::MissionResult replay_swarm_run(const mission::Scenario& base,
                                        std::shared_ptr<const world::Terrain> terrain, int uavs,
                                        double radius_m, double latency_s, double loss_rate,
                                        std::uint64_t seed, mission::Scenario* flown) {
  CircleSwapOptions swap_options;
  swap_options.uavs = uavs;
  swap_options.radius_m = radius_m;
  mission::Scenario swap = make_circle_swap(base, *terrain, swap_options);
  const planning::GlobalPlan plan = straight_line_plan(swap, terrain);
  if (plan.status != planning::GlobalPlanStatus::kPlanned) throw InputError("--radius-m", plan.message);
  set_link(swap, latency_s, loss_rate);
  const mission::Scenario varied = sim::vary_scenario(swap, *terrain, seed, {});
  if (flown != nullptr) *flown = varied;
  return sim::fly_mission(varied, terrain, plan, {});
}

SwarmBenchmarkReport run_swarm_benchmark(const mission::Scenario& base,
                                         std::shared_ptr<const world::Terrain> terrain,
                                         const SwarmBenchmarkOptions& options) {
  if (options.runs < 1) throw InputError("--runs", "must be at least 1");
  if (options.threads < 1) throw InputError("--threads", "must be at least 1");
  if (options.team_sizes.empty()) throw InputError("--uavs", "needs at least one team size");
  for (int n : options.team_sizes)
    if (n < 2) throw InputError("--uavs", "every team size must be at least 2");
  if (options.latencies_s.empty()) throw InputError("--latency-ms", "needs at least one latency");
  for (double l : options.latencies_s)
    if (!(l >= 0.0) || !std::isfinite(l))
      throw InputError("--latency-ms", "every latency must be finite and >= 0");
  if (!(options.loss_rate >= 0.0 && options.loss_rate < 1.0))
    throw InputError("--loss", "must be in [0, 1)");

  SwarmBenchmarkReport report;
  report.d_safe_m = base.safety.separation_m;
  report.radius_m = options.radius_m;
  for (int n : options.team_sizes) {
    CircleSwapOptions swap_options;
    swap_options.uavs = n;
    swap_options.radius_m = options.radius_m;
    mission::Scenario swap = make_circle_swap(base, *terrain, swap_options);
    const planning::GlobalPlan plan = straight_line_plan(swap, terrain);
    if (plan.status != planning::GlobalPlanStatus::kPlanned)
      throw InputError("--radius-m", plan.message);
    double v_max = std::numeric_limits<double>::infinity();
    for (const mission::UavSpec& u : swap.uavs) v_max = std::min(v_max, u.vehicle.max_speed_m_s());
    for (double latency : options.latencies_s) {
      set_link(swap, latency, options.loss_rate);
      const std::string label = fmt::format("{} UAVs, {:.0f} ms", n, latency * 1e3);
      sim::MonteCarloOptions mc;
      mc.runs = options.runs;
      mc.threads = options.threads;
      if (options.progress)
        mc.progress = [&](int done, int total, int failed) {
          options.progress(label, done, total, failed);
        };
      const sim::MonteCarloReport runs = sim::run_monte_carlo(swap, terrain, plan, mc);

      SwarmCell cell;
      cell.uavs = n;
      cell.latency_s = latency;
      cell.loss_rate = options.loss_rate;
      cell.runs = options.runs;
      cell.straight_line_bound_s = 2.0 * options.radius_m / v_max;
      cell.min_separation_m = std::numeric_limits<double>::infinity();
      cell.wall_time_s = runs.wall_time_s;
      double completion_sum = 0.0;
      for (const sim::MonteCarloRun& r : runs.runs) {
        const mission::MissionMetrics& m = r.metrics;
        const bool flown = !m.uavs.empty();  // no metrics: the run threw
        const bool collision_free = flown && m.separation_violations == 0;
        cell.collision_free += collision_free ? 1 : 0;
        cell.completed += m.mission_complete ? 1 : 0;
        cell.constraint_violations += m.total_constraint_violations();
        cell.terrain_collisions += m.terrain_collisions;
        cell.cpu_time_s += m.cpu_time_s;
        if (flown) cell.min_separation_m = std::min(cell.min_separation_m, m.min_separation_m);
        if (m.mission_complete) {
          double finish = 0.0;
          for (const mission::UavMetrics& u : m.uavs) finish = std::max(finish, u.finish_time_s);
          completion_sum += finish;
        }
        if (!collision_free || !m.mission_complete || !r.failures.empty()) {
          SwarmFailedRun f;
          f.index = r.index;
          f.seed = r.seed;
          f.min_separation_m = flown ? m.min_separation_m : std::nan("");
          f.closest_pair = m.min_separation_pair;
          f.closest_time_s = m.min_separation_time_s;
          f.reasons = r.failures;
          cell.failed.push_back(std::move(f));
        }
      }
      cell.mean_completion_time_s =
          cell.completed > 0 ? completion_sum / cell.completed : std::nan("");
      report.cells.push_back(std::move(cell));
    }
  }
  return report;
}

nlohmann::json SwarmBenchmarkReport::to_json() const {
  nlohmann::json cells_json = nlohmann::json::array();
  for (const SwarmCell& c : cells) {
    nlohmann::json failed = nlohmann::json::array();
    for (const SwarmFailedRun& f : c.failed)
      failed.push_back({{"run", f.index},
                        {"seed", f.seed},
                        {"min_separation_m", std::isfinite(f.min_separation_m)
                                                 ? nlohmann::json(f.min_separation_m)
                                                 : nlohmann::json(nullptr)},
                        {"closest_pair", {f.closest_pair.first, f.closest_pair.second}},
                        {"closest_time_s", f.closest_time_s},
                        {"reasons", f.reasons}});
    const auto finite_or_null = [](double x) {
      return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
    };
    cells_json.push_back(
        {{"uavs", c.uavs},
         {"latency_ms", c.latency_s * 1e3},
         {"loss_rate", c.loss_rate},
         {"runs", c.runs},
         {"collision_free", c.collision_free},
         {"collision_free_rate", static_cast<double>(c.collision_free) / c.runs},
         {"completed", c.completed},
         {"completion_rate", static_cast<double>(c.completed) / c.runs},
         {"mean_completion_time_s", finite_or_null(c.mean_completion_time_s)},
         {"straight_line_bound_s", c.straight_line_bound_s},
         {"completion_time_ratio", finite_or_null(c.mean_completion_time_s / c.straight_line_bound_s)},
         {"constraint_violations", c.constraint_violations},
         {"terrain_collisions", c.terrain_collisions},
         {"min_separation_m", finite_or_null(c.min_separation_m)},
         {"cpu_time_s", c.cpu_time_s},
         {"wall_time_s", c.wall_time_s},
         {"failed_runs", failed}});
  }
  return {{"benchmark", "circle swap"},
          {"d_safe_m", d_safe_m},
          {"radius_m", radius_m},
          {"cells", cells_json}};
}

std::string SwarmBenchmarkReport::to_markdown() const {
  std::string out =
      "| UAVs | latency | loss | runs | collision-free | completed | completion time / bound | "
      "closest (m) | constraint violations | failing seeds |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SwarmCell& c : cells) {
    std::string seeds;
    for (std::size_t k = 0; k < c.failed.size() && k < 5; ++k)
      seeds += fmt::format("{}{}", k ? ", " : "", c.failed[k].seed);
    if (c.failed.size() > 5) seeds += fmt::format(" (+{})", c.failed.size() - 5);
    out += fmt::format(
        "| {} | {:.0f} ms | {:.0f} % | {} | {:.1f} % | {:.1f} % | {} | {:.2f} | {} | {} |\n",
        c.uavs, c.latency_s * 1e3, c.loss_rate * 100.0, c.runs,
        100.0 * c.collision_free / c.runs, 100.0 * c.completed / c.runs,
        std::isfinite(c.mean_completion_time_s)
            ? fmt::format("{:.1f} s / {:.1f} s = {:.2f}", c.mean_completion_time_s,
                          c.straight_line_bound_s,
                          c.mean_completion_time_s / c.straight_line_bound_s)
            : std::string("-"),
        c.min_separation_m, c.constraint_violations, seeds.empty() ? "-" : seeds);
  }
  return out;
}

}  // namespace ridgeline::benchmarks
