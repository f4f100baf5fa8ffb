#include "apps/command_support.hpp"

#include <iostream>

#include "apps/commands.hpp"
#include "sim/mission_problem.hpp"

namespace ridgeline::apps {

io::LoadedScenario load_scenario_argument(const std::string& path) {
  return path.empty() ? io::load_default_scenario() : io::load_scenario_file(path);
}

std::optional<planning::GlobalPlan> plan_or_report(const io::LoadedScenario& loaded) {
  planning::GlobalPlan plan =
      planning::plan_mission(sim::make_planning_problem(loaded.scenario, loaded.terrain),
                             sim::make_planner_options(loaded.scenario));
  if (plan.status == planning::GlobalPlanStatus::kPlanned) return plan;
  std::cerr << "error: planning failed (" << planning::to_string(plan.status)
            << "): " << plan.message << '\n';
  set_exit_code(3);
  return std::nullopt;
}

}  // namespace ridgeline::apps
