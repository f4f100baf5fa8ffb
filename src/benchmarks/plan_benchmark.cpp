#include "benchmarks/plan_benchmark.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "core/cpu_clock.hpp"
#include "core/error.hpp"
#include "mission/stage_inputs.hpp"
#include "mission/team_scenario.hpp"

namespace ridgeline::benchmarks {
namespace {

double process_cpu_s() { return process_cpu_time_s(); }

}  // namespace

nlohmann::json PlanScalingRow::to_json() const {
  nlohmann::json j = {{"uavs", uavs},
                      {"waypoints", waypoints},
                      {"targets", targets},
                      {"plan_s", plan_s.median},
                      {"plan_cpu_s", plan_cpu_s.median},
                      {"optimizer_s", optimizer_s},
                      {"ipopt_s", ipopt_s},
                      {"ipopt_iterations", ipopt_iterations},
                      {"solves", solves},
                      {"decomposed", decomposed},
                      {"priority_swaps", priority_swaps},
                      {"variables", variables},
                      {"constraints", constraints},
                      {"separation_rows", separation_rows},
                      {"status", status},
                      {"path_source", path_source},
                      {"optimizer_status", optimizer_status},
                      {"objective", objective},
                      {"initial_objective", initial_objective},
                      {"guess",
                       {{"min_separation_before_m", guess_separation_before_m},
                        {"min_separation_after_m", guess_separation_after_m},
                        {"conflicts_before", guess_conflicts_before},
                        {"conflicts_after", guess_conflicts_after}}},
                      {"min_clearance_m", min_clearance_m},
                      {"min_separation_m", min_separation_m},
                      {"stage_s",
                       {{"allocation", stage_s[0]},
                        {"initial_paths", stage_s[1]},
                        {"optimization", stage_s[2]},
                        {"time_parametrization", stage_s[3]},
                        {"validation", stage_s[4]}}}};
  if (!message.empty()) j["message"] = message;
  if (!optimizer_message.empty()) j["optimizer_message"] = optimizer_message;
  return j;
}

nlohmann::json PlanBenchmarkReport::to_json() const {
  nlohmann::json j = {
      {"case", fmt::format("default scenario, {} UAVs x {} waypoints", base.uavs, base.waypoints)},
      {"plan_s", mission::to_json(base.plan_s)},
      {"plan_cpu_s", mission::to_json(base.plan_cpu_s)},
      {"base", base.to_json()}};
  j["scaling"] = nlohmann::json::array();
  for (const PlanScalingRow& row : scaling) j["scaling"].push_back(row.to_json());
  return j;
}

PlanRun time_plan(const planning::GlobalPlanningProblem& problem,
                  const planning::GlobalPlannerOptions& options) {
  PlanRun run;
  const double cpu_start = process_cpu_s();
  const auto start = std::chrono::steady_clock::now();
  run.plan = planning::plan_mission(problem, options);
  run.plan_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.plan_cpu_s = process_cpu_s() - cpu_start;
  return run;
}

PlanScalingRow measure_plan(const planning::GlobalPlanningProblem& problem,
                            const planning::GlobalPlannerOptions& options, int runs) {
  if (runs < 1) throw InputError("repeats", fmt::format("must be >= 1, got {}", runs));
  PlanScalingRow row;
  row.uavs = static_cast<int>(problem.uavs.size());
  row.waypoints = options.optimizer.waypoints_per_uav;
  row.targets = static_cast<int>(problem.targets.size());
  std::vector<double> wall, cpu;
  PlanRun run;
  for (int r = 0; r < runs; ++r) {
    run = time_plan(problem, options);
    wall.push_back(run.plan_s);
    cpu.push_back(run.plan_cpu_s);
  }
  row.plan_s = mission::percentiles(wall);
  row.plan_cpu_s = mission::percentiles(cpu);
  const planning::GlobalPlan& plan = run.plan;
  row.status = std::string(planning::to_string(plan.status));
  row.path_source = std::string(planning::to_string(plan.path_source));
  row.message = plan.status == planning::GlobalPlanStatus::kPlanned ? "" : plan.message;
  row.optimizer_message = plan.optimizer_message;
  row.optimizer_s = plan.optimization_time_s;
  if (plan.optimization) {
    const planning::TrajectoryResult& o = *plan.optimization;
    row.optimizer_status = std::string(planning::to_string(o.status));
    row.ipopt_s = o.solve_time_s;
    row.ipopt_iterations = o.ipopt_iterations;
    row.solves = o.solves;
    row.decomposed = o.decomposed;
    row.priority_swaps = o.priority_swaps;
    row.variables = o.variables;
    row.constraints = o.constraints;
    row.separation_rows = o.separation_rows;
    row.objective = o.objective;
    row.initial_objective = o.initial_objective;
    row.guess_separation_before_m = o.guess.min_separation_before_m;
    row.guess_separation_after_m = o.guess.min_separation_after_m;
    row.guess_conflicts_before = o.guess.conflicts_before;
    row.guess_conflicts_after = o.guess.conflicts_after;
  }
  row.min_clearance_m = plan.validation.min_terrain_clearance_m;
  row.min_separation_m = plan.validation.min_separation_m;
  const double stages[5] = {plan.allocation_time_s, plan.search_time_s, plan.optimization_time_s,
                            plan.timing_time_s, plan.validation_time_s};
  std::copy(std::begin(stages), std::end(stages), row.stage_s);
  return row;
}

PlanBenchmarkReport run_plan_benchmark(const mission::Scenario& base,
                                       std::shared_ptr<const world::Terrain> terrain,
                                       const PlanBenchmarkOptions& options) {
  if (options.scaling_repeats < 0)
    throw InputError("scaling_repeats",
                     fmt::format("must be >= 0, got {}", options.scaling_repeats));
  if (!(options.scaling_time_budget_s > 0.0))
    throw InputError("scaling_time_budget_s", "must be > 0");
  PlanBenchmarkReport report;
  report.base = measure_plan(mission::make_planning_problem(base, terrain),
                             mission::make_planner_options(base), options.repeats);
  if (options.scaling_repeats == 0) return report;
  for (int uavs : options.uav_counts) {
    const mission::Scenario team =
        mission::make_team_scenario(base, *terrain, {uavs, uavs, options.team_seed});
    const planning::GlobalPlanningProblem problem = mission::make_planning_problem(team, terrain);
    for (int waypoints : options.waypoint_counts) {
      if (waypoints < 2)
        throw InputError("waypoints", fmt::format("must be >= 2, got {}", waypoints));
      planning::GlobalPlannerOptions o = mission::make_planner_options(team);
      o.optimizer.waypoints_per_uav = waypoints;
      o.optimizer.time_budget_s = options.scaling_time_budget_s;
      report.scaling.push_back(measure_plan(problem, o, options.scaling_repeats));
    }
  }
  return report;
}

}  // namespace ridgeline::benchmarks
