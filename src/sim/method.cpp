#include "sim/method.hpp"

#include <fmt/format.h>

#include "baselines/baseline_planner.hpp"
#include "baselines/ddpg_agent.hpp"
#include "baselines/dwa_agent.hpp"
#include "baselines/pursuit_agent.hpp"
#include "core/error.hpp"
#include "mission/stage_inputs.hpp"

namespace ridgeline::sim {
namespace {

// The proposed tracker's step CPU time is read on one step in this many (see
// UavTrackerOptions::cpu_time_period_steps).
constexpr int kFlightCpuTimePeriod = 32;

}  // namespace

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

planning::GlobalPlan plan_for_method(const mission::Scenario& scenario,
                                     std::shared_ptr<const world::Terrain> terrain, Method method) {
  const planning::GlobalPlanningProblem problem = mission::make_planning_problem(scenario, terrain);
  const planning::GlobalPlannerOptions proposed = mission::make_planner_options(scenario);
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

baselines::BaselineAgentOptions make_baseline_agent_options(const mission::Scenario& scenario,
                                                            int index,
                                                            const planning::UavPlan& plan) {
  const mission::UavSpec& uav = scenario.uavs[static_cast<std::size_t>(index)];
  baselines::BaselineAgentOptions o;
  o.id = index;
  o.num_uavs = static_cast<int>(scenario.uavs.size());
  o.vehicle = uav.vehicle;
  for (const int k : plan.targets) {
    const mission::InspectionTarget& t = scenario.targets.at(static_cast<std::size_t>(k));
    o.targets.push_back({t.name, t.position_m, t.inspection_radius_m, t.inspection_radius_m});
  }
  o.fly_to_end = uav.end_position_m.has_value();
  o.control_period_s = scenario.mpc.control_period_s;
  o.prediction_step_s = scenario.mpc.prediction_step_s;
  o.prediction_steps = scenario.mpc.horizon_steps;
  // The proposed tracker's command-rate limits (max_moves per prediction step).
  o.max_command_rate = scenario.mpc.max_moves / scenario.mpc.prediction_step_s;
  return o;
}

std::unique_ptr<swarm::UavAgent> make_agent(
    Method method, const mission::Scenario& scenario, int index, const planning::UavPlan& plan,
    std::shared_ptr<const mpc::SampledReference> reference,
    std::shared_ptr<const world::Terrain> terrain,
    std::shared_ptr<const learning::DdpgPolicy> ddpg_policy) {
  switch (method) {
    case Method::kProposed: {
      swarm::AgentOptions options = mission::make_agent_options(scenario, index, plan);
      // A simulated flight's step CPU times are a statistic over ~10⁴ steps a UAV: one step
      // in kFlightCpuTimePeriod is timed, which spares the rest the clock's system calls. Its
      // metrics read the whole step's time only: its parts are not timed.
      options.tracker.cpu_time_period_steps = kFlightCpuTimePeriod;
      options.tracker.time_step_parts = false;
      return std::make_unique<swarm::Agent>(options, scenario.safety, std::move(reference),
                                            std::move(terrain));
    }
    case Method::kAstarDwa:
      return std::make_unique<baselines::DwaAgent>(
          make_baseline_agent_options(scenario, index, plan), scenario.safety,
          baselines::DwaOptions{}, std::move(reference), std::move(terrain));
    case Method::kWindAware:
      return std::make_unique<baselines::PursuitAgent>(
          make_baseline_agent_options(scenario, index, plan), scenario.safety,
          baselines::PursuitOptions{}, std::move(reference), std::move(terrain));
    case Method::kDdpg:
      if (!ddpg_policy)
        throw InputError("--ddpg-model", "method ddpg needs a DDPG model (none loaded)");
      return std::make_unique<baselines::DdpgAgent>(
          make_baseline_agent_options(scenario, index, plan), scenario.safety,
          std::move(ddpg_policy), std::move(reference), std::move(terrain));
  }
  throw InputError("--method", "unknown method");
}

}  // namespace ridgeline::sim
