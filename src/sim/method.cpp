#include "sim/method.hpp"

#include <fmt/format.h>

#include "baselines/baseline_planner.hpp"
#include "core/error.hpp"
#include "sim/mission_problem.hpp"

namespace ridgeline::sim {

std::string_view to_string(Method method) {
  switch (method) {
    case Method::kProposed:
      return "proposed";
    case Method::kAstarDwa:
      return "astar_dwa";
    case Method::kWindAware:
      return "wind_aware";
    case Method::kDdpg:
      return "ddpg";
  }
  return "unknown";
}

std::vector<Method> all_methods() {
  return {Method::kProposed, Method::kAstarDwa, Method::kWindAware, Method::kDdpg};
}

Method parse_method(std::string_view text, const std::string& field) {
  for (const Method m : all_methods())
    if (text == to_string(m)) return m;
  throw InputError(
      field, fmt::format("unknown method '{}' (one of proposed, astar_dwa, wind_aware, ddpg)", text));
}

planning::GlobalPlan plan_for_method(const Scenario& scenario,
                                     std::shared_ptr<const world::Terrain> terrain, Method method) {
  const planning::GlobalPlanningProblem problem = make_planning_problem(scenario, terrain);
  const planning::GlobalPlannerOptions proposed = make_planner_options(scenario);
  if (method == Method::kProposed) return planning::plan_mission(problem, proposed);
  baselines::BaselinePlannerOptions o;
  o.method = method == Method::kWindAware ? baselines::BaselinePathMethod::kWindAware
                                          : baselines::BaselinePathMethod::kImprovedAStar;
  o.allocation = proposed.allocation;
  o.cost_estimate = proposed.cost_estimate;
  o.timing = proposed.timing;
  o.forecast_wind_m_s = scenario.wind.mean_m_s;  // the forecast: the scenario's mean wind
  return baselines::plan_baseline_mission(problem, o);
}

}  // namespace ridgeline::sim
