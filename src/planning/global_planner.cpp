#include "planning/global_planner.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "world/smooth_terrain.hpp"

namespace ridgeline::planning {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

GlobalPlan fail(GlobalPlan plan, GlobalPlanStatus status, std::string message) {
  plan.status = status;
  plan.message = std::move(message);
  plan.uavs.clear();
  return plan;
}

std::string check_problem(const GlobalPlanningProblem& p) {
  if (!p.terrain) return "terrain: missing";
  if (p.uavs.empty()) return "uavs: at least one UAV is needed";
  if (p.targets.empty()) return "targets: at least one target is needed";
  try {
    world::validate(p.limits);
  } catch (const InputError& e) {
    return e.what();
  }
  std::vector<int> owner(p.targets.size(), -1);
  for (std::size_t i = 0; i < p.uavs.size(); ++i) {
    for (std::size_t k = 0; k < p.uavs[i].required_targets.size(); ++k) {
      const int t = p.uavs[i].required_targets[k];
      if (t < 0 || t >= static_cast<int>(p.targets.size()))
        return fmt::format("uavs[{}].required_targets[{}]: {} is not a target (0..{})", i, k, t,
                           p.targets.size() - 1);
      if (owner[static_cast<std::size_t>(t)] >= 0)
        return fmt::format(
            "uavs[{}].required_targets[{}]: target '{}' is already required of "
            "uavs[{}]",
            i, k, p.targets[static_cast<std::size_t>(t)].name, owner[static_cast<std::size_t>(t)]);
      owner[static_cast<std::size_t>(t)] = static_cast<int>(i);
    }
    if (p.uavs[i].end_m && !p.uavs[i].end_m->allFinite())
      return fmt::format("uavs[{}].end_m: not finite", i);
  }
  return "";
}

// Position of a UAV at time t: its reference while it lasts, then its final point (a UAV that
// has finished its route holds there in the separation check).
Vec3 position_at(const TimeParametrizationResult& timing, double t_s) {
  const std::vector<double>& times = timing.sample_times_s;
  if (t_s >= times.back()) return timing.samples.back().position_m;
  if (t_s <= times.front()) return timing.samples.front().position_m;
  return timing.reference->at(t_s).position_m;
}

// Stage 5: every hard constraint on the final references, densely. Returns "" or where the
// first violation is.
std::string validate_references(const GlobalPlanningProblem& problem,
                                 const GlobalPlannerOptions& options, const GlobalPlan& plan,
                                 PlanValidationSummary& summary) {
  const world::Terrain& terrain = *problem.terrain;
  const double floor_m = problem.limits.clearance_floor_m(terrain);
  summary = PlanValidationSummary{};
  summary.min_terrain_clearance_m = std::numeric_limits<double>::infinity();
  summary.min_altitude_m = std::numeric_limits<double>::infinity();
  summary.max_altitude_m = -std::numeric_limits<double>::infinity();
  summary.min_separation_m = std::numeric_limits<double>::infinity();
  std::string first_violation;
  auto report = [&](std::string text) {
    if (first_violation.empty()) first_violation = std::move(text);
  };

  for (const UavPlan& uav : plan.uavs) {
    const auto& samples = uav.timing.samples;
    const auto& times = uav.timing.sample_times_s;
    for (std::size_t k = 0; k < samples.size(); ++k) {
      // Between samples the reference is linear: subdivide so terrain is sampled at least
      // every validation_step_m.
      const Vec3 a = samples[k].position_m;
      const Vec3 b = k + 1 < samples.size() ? samples[k + 1].position_m : a;
      const int pieces = std::max(1, static_cast<int>(std::ceil((b - a).norm() / options.validation_step_m)));
      for (int q = 0; q < pieces; ++q) {
        const Vec3 p = a + (b - a) * (static_cast<double>(q) / pieces);
        const double clearance = p.z() - terrain.height(p.x(), p.y());
        ++summary.samples_checked;
        summary.min_terrain_clearance_m = std::min(summary.min_terrain_clearance_m, clearance);
        summary.min_altitude_m = std::min(summary.min_altitude_m, p.z());
        summary.max_altitude_m = std::max(summary.max_altitude_m, p.z());
        if (!(clearance >= floor_m - 1e-6)) {  // NaN (a broken terrain query) fails too
          report(fmt::format("terrain clearance: {} at t = {:.2f} s, ({:.1f}, {:.1f}, {:.1f}) is "
                             "{:.2f} m above the terrain, below the required {:.2f} m",
                             uav.name, times[k], p.x(), p.y(), p.z(), clearance, floor_m));
        }
        if (p.z() < problem.limits.altitude.min_m - 1e-6 ||
            p.z() > problem.limits.altitude.max_m + 1e-6) {
          report(
              fmt::format("altitude band: {} at t = {:.2f} s flies at {:.1f} m, outside "
                          "[{}, {}] m",
                          uav.name, times[k], p.z(), problem.limits.altitude.min_m,
                          problem.limits.altitude.max_m));
        }
      }
      const double pitch = std::atan2(std::abs(samples[k].climb_rate_m_s), samples[k].speed_m_s);
      summary.max_pitch_rad = std::max(summary.max_pitch_rad, pitch);
    }
  }

  // Separation at equal times (eq. 21), at every control period over the longest mission.
  double end_s = 0.0;
  double begin_s = std::numeric_limits<double>::infinity();
  for (const UavPlan& uav : plan.uavs) {
    end_s = std::max(end_s, uav.timing.sample_times_s.back());
    begin_s = std::min(begin_s, uav.timing.sample_times_s.front());
  }
  const double dt = options.timing.control_period_s;
  std::vector<Vec3> positions(plan.uavs.size());
  for (double t = begin_s; t <= end_s + 1e-9; t += dt) {
    for (std::size_t i = 0; i < plan.uavs.size(); ++i) positions[i] = position_at(plan.uavs[i].timing, t);
    for (std::size_t i = 0; i < plan.uavs.size(); ++i) {
      for (std::size_t j = i + 1; j < plan.uavs.size(); ++j) {
        const double d = (positions[i] - positions[j]).norm();
        summary.min_separation_m = std::min(summary.min_separation_m, d);
        if (d < problem.limits.separation_m - 1e-6) {
          report(
              fmt::format("separation: {} and {} are {:.2f} m apart at t = {:.2f} s near "
                          "({:.1f}, {:.1f}, {:.1f}), below d_safe {} m",
                          plan.uavs[i].name, plan.uavs[j].name, d, t, positions[i].x(),
                          positions[i].y(), positions[i].z(), problem.limits.separation_m));
        }
      }
    }
  }
  return first_violation;
}

struct StageFailure {
  GlobalPlanStatus status = GlobalPlanStatus::kPlanned;  // kPlanned: no failure
  std::string message;
};

// Stage 4: each UAV's waypoints into its reference, at cruise (timed == nullptr), or the
// optimizer's timed references (time_parametrize_timed with the same options, passing waypoint k
// at its grid time). A limit the reference would break is a failure.
StageFailure time_references(const std::vector<const PlannerUav*>& vehicles,
                             const std::vector<TimeParametrizationResult>* timed,
                             const GlobalPlannerOptions& options, std::vector<UavPlan>& uavs) {
  for (std::size_t i = 0; i < uavs.size(); ++i) {
    UavPlan& uav_plan = uavs[i];
    const vehicle::VehicleParams& vehicle = vehicles[i]->vehicle;
    uav_plan.timing = timed == nullptr
                          ? time_parametrize(uav_plan.waypoints_m, vehicle, options.timing)
                          : (*timed)[i];
    if (uav_plan.timing.status == TimeParametrizationStatus::kInvalidInput ||
        !uav_plan.timing.reference)
      return {GlobalPlanStatus::kInvalidInput, uav_plan.name + ": " + uav_plan.timing.message};
    if (!uav_plan.timing.violations.empty())
      return {GlobalPlanStatus::kValidationFailed,
              fmt::format("{}: {}", uav_plan.name, uav_plan.timing.violations.front().description)};
  }
  return {};
}

}  // namespace

std::string_view to_string(GlobalPlanStatus status) {
  switch (status) {
    case GlobalPlanStatus::kPlanned: return "planned";
    case GlobalPlanStatus::kInvalidInput: return "invalid input";
    case GlobalPlanStatus::kUnreachable: return "unreachable";
    case GlobalPlanStatus::kValidationFailed: return "validation failed";
    case GlobalPlanStatus::kOptimizationFailed: return "optimization failed";
  }
  return "unknown";
}

std::string_view to_string(PathSource source) {
  switch (source) {
    case PathSource::kOptimized: return "optimized";
    case PathSource::kInitialPathsOptimizerOff: return "initial paths (optimizer off)";
    case PathSource::kInitialPathsOptimizerFailed: return "initial paths (optimizer failed)";
  }
  return "unknown";
}

AllocationProblem make_allocation_problem(const GlobalPlanningProblem& problem,
                                          const CostEstimateOptions& options) {
  AllocationProblem a;
  std::vector<std::optional<Vec3>> ends;
  a.required_uav.assign(problem.targets.size(), -1);
  for (std::size_t i = 0; i < problem.uavs.size(); ++i) {
    a.uav_starts_m.push_back(problem.uavs[i].start_m);
    ends.push_back(problem.uavs[i].end_m);
    for (const int t : problem.uavs[i].required_targets)
      if (t >= 0 && t < static_cast<int>(problem.targets.size()))
        a.required_uav[static_cast<std::size_t>(t)] = static_cast<int>(i);
  }
  a.targets = problem.targets;
  AllocationCosts costs = estimate_allocation_costs(*problem.terrain, a.uav_starts_m,
                                                    problem.targets, problem.limits, options, ends);
  a.start_cost = std::move(costs.start_cost);
  a.target_cost = std::move(costs.target_cost);
  a.end_cost = std::move(costs.end_cost);
  a.start_end_cost = std::move(costs.start_end_cost);
  return a;
}

GlobalPlan plan_mission(const GlobalPlanningProblem& problem, const GlobalPlannerOptions& options) {
  const auto start = Clock::now();
  GlobalPlan plan;
  if (std::string problem_error = check_problem(problem); !problem_error.empty())
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, problem_error);

  // 1. Allocation on terrain-aware estimates.
  auto stage = Clock::now();
  AllocationProblem allocation_problem;
  try {
    allocation_problem = make_allocation_problem(problem, options.cost_estimate);
  } catch (const InputError& e) {
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, e.what());
  }
  plan.allocation = allocate_targets(allocation_problem, options.allocation);
  plan.allocation_time_s = seconds_since(stage);
  if (plan.allocation.status == AllocationStatus::kInvalidInput)
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, plan.allocation.message);

  // 2. Initial paths through each UAV's targets.
  stage = Clock::now();
  PathSearchOptions search = options.search;
  // The profile's grade: the team's flyable grade (pitch, and climb at v0 − Δv, eq. 2) times
  // the optimizer's grade_fraction, the room the time parametrization's corner arcs need (each
  // steepens its stretch by the length it cuts), so the initial paths are flyable as a fallback.
  double max_grade = std::numeric_limits<double>::infinity();
  double min_turn_radius_m = 0.0;
  for (const PlannerUav& u : problem.uavs) {
    max_grade = std::min({max_grade, std::tan(u.vehicle.max_pitch_rad),
                          u.vehicle.max_climb_rate_m_s / u.vehicle.min_speed_m_s()});
    min_turn_radius_m = std::max(min_turn_radius_m, u.vehicle.min_turn_radius_m);
  }
  search.max_pitch_rad = std::atan(options.optimizer.grade_fraction * max_grade);
  search.turn_margin_m = std::max(search.turn_margin_m, min_turn_radius_m);
  std::vector<const PlannerUav*> flying;          // per plan.uavs entry
  std::vector<std::vector<int>> target_indices;  // per plan.uavs entry: targets on its path
  try {
    const ClearanceGrid grid(*problem.terrain, problem.area, problem.limits, search);
    for (std::size_t i = 0; i < problem.uavs.size(); ++i) {
      const PlannerUav& u = problem.uavs[i];
      UavPlan uav_plan;
      uav_plan.name = u.name;
      uav_plan.targets = plan.allocation.routes[i];
      if (uav_plan.targets.empty() && !u.end_m) continue;  // spare UAV: no route to fly
      std::vector<NamedPoint> targets;
      for (int t : uav_plan.targets)
        targets.push_back({problem.targets[static_cast<std::size_t>(t)].name,
                           problem.targets[static_cast<std::size_t>(t)].position_m});
      // The end is the path's last fixed point, as a target is (the optimizer keeps it).
      if (u.end_m) targets.push_back({u.name + " end", *u.end_m});
      const PathResult path = plan_initial_path(grid, {u.name, u.start_m}, targets);
      if (path.status == PathStatus::kUnreachable)
        return fail(std::move(plan), GlobalPlanStatus::kUnreachable, path.message);
      if (path.status != PathStatus::kFound)
        return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, path.message);
      uav_plan.waypoints_m = path.waypoints_m;
      plan.uavs.push_back(std::move(uav_plan));
      flying.push_back(&u);
      target_indices.push_back(path.target_waypoint_index);
    }
  } catch (const InputError& e) {
    return fail(std::move(plan), GlobalPlanStatus::kInvalidInput, e.what());
  }
  plan.search_time_s = seconds_since(stage);

  // 3. Joint optimization (eq. 14–24) from the initial paths; its result must survive stages
  // 4 and 5 on its own, else the initial paths are flown (or the plan fails, as configured).
  plan.path_source = PathSource::kInitialPathsOptimizerOff;
  if (options.optimize) {
    stage = Clock::now();
    TrajectoryProblem trajectory_problem;
    trajectory_problem.terrain = problem.terrain.get();
    // On a raster the NLP works on its C² spline, h_safe kept above the raster by the
    // spline's measured bound (world/smooth_terrain.hpp); stages 4 and 5 check the raster.
    std::shared_ptr<const world::Terrain> smooth;
    try {
      smooth = world::make_smooth_terrain(
          *problem.terrain, {problem.area.min_m.x(), problem.area.max_m.x(), problem.area.min_m.y(),
                             problem.area.max_m.y()});
    } catch (const std::exception&) {
      smooth.reset();  // no envelope (e.g. memory): the NLP works on the raster itself
    }
    trajectory_problem.optimization_terrain = smooth.get();
    trajectory_problem.limits = problem.limits;
    for (std::size_t i = 0; i < plan.uavs.size(); ++i)
      trajectory_problem.uavs.push_back(
          {plan.uavs[i].name, plan.uavs[i].waypoints_m, target_indices[i], flying[i]->vehicle});
    TrajectoryOptimizerOptions optimizer = options.optimizer;
    optimizer.validation_terrain_step_m = options.validation_step_m;
    optimizer.validation_separation_period_s = options.timing.control_period_s;
    optimizer.timing = options.timing;
    plan.optimization = optimize_trajectories(trajectory_problem, optimizer);
    plan.optimization_time_s = seconds_since(stage);

    std::string reason;
    if (plan.optimization->ok()) {
      std::vector<UavPlan> optimized = plan.uavs;
      for (std::size_t i = 0; i < optimized.size(); ++i)
        optimized[i].waypoints_m = plan.optimization->paths[i].waypoints_m;
      stage = Clock::now();
      StageFailure failure = time_references(flying, &plan.optimization->timing, options, optimized);
      plan.timing_time_s = seconds_since(stage);
      if (failure.status == GlobalPlanStatus::kPlanned) {
        stage = Clock::now();
        std::swap(plan.uavs, optimized);
        failure.message = validate_references(problem, options, plan, plan.validation);
        plan.validation_time_s = seconds_since(stage);
        if (failure.message.empty()) {
          plan.path_source = PathSource::kOptimized;
          plan.status = GlobalPlanStatus::kPlanned;
          plan.total_time_s = seconds_since(start);
          return plan;
        }
        std::swap(plan.uavs, optimized);
        reason = "the optimized references break a hard constraint: " + failure.message;
      } else {
        reason = "timing the optimized waypoints failed: " + failure.message;
      }
    } else {
      reason = fmt::format("optimizer {}: {}", to_string(plan.optimization->status),
                           plan.optimization->message);
    }
    if (options.on_optimizer_failure == OptimizerFallback::kFail) {
      plan.total_time_s = seconds_since(start);
      return fail(std::move(plan), GlobalPlanStatus::kOptimizationFailed, reason);
    }
    plan.path_source = PathSource::kInitialPathsOptimizerFailed;
    plan.optimizer_message = std::move(reason);
  }

  // 4. Time parametrization of the initial paths at cruise speed.
  stage = Clock::now();
  const StageFailure failure = time_references(flying, nullptr, options, plan.uavs);
  plan.timing_time_s += seconds_since(stage);
  // When the initial paths are the fallback, their failure is the second one: say the first.
  const std::string after_optimizer =
      plan.path_source == PathSource::kInitialPathsOptimizerFailed
          ? " (the initial paths, flown because " + plan.optimizer_message + ")"
          : "";
  if (failure.status != GlobalPlanStatus::kPlanned)
    return fail(std::move(plan), failure.status, failure.message + after_optimizer);

  // 5. Dense validation of the final references.
  stage = Clock::now();
  const std::string violation = validate_references(problem, options, plan, plan.validation);
  plan.validation_time_s += seconds_since(stage);
  plan.total_time_s = seconds_since(start);
  if (!violation.empty())
    return fail(std::move(plan), GlobalPlanStatus::kValidationFailed, violation + after_optimizer);
  plan.status = GlobalPlanStatus::kPlanned;
  return plan;
}

}  // namespace ridgeline::planning
