// `ridgeline plan [--scenario FILE] --out DIR`: the ground station's global plan, written to
// DIR/plan.json after dense validation; an invalid plan writes nothing and exits non-zero.
#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/plan_file.hpp"

namespace ridgeline::apps {

void register_plan_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out";
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("plan", "Plan every UAV's reference trajectory (global planner)");
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  cmd->callback([args] {
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded);
    if (!plan) return;
    std::cout << io::plan_summary_text(*plan, loaded.scenario);
    const std::filesystem::path out = std::filesystem::path(args->out) / "plan.json";
    io::write_file_atomically(out, io::plan_to_json(*plan, loaded.scenario).dump() + "\n");
    std::cout << "wrote " << out.string() << '\n';
  });
}

}  // namespace ridgeline::apps
