// `ridgeline run [--scenario FILE] --out DIR`: the main job. It loads and validates the
// scenario (the embedded default without --scenario), plans every UAV's reference with the
// global planner and writes DIR/summary.json and DIR/plan.json. The closed-loop flight
// (simulator, agents, metrics) is the next stage of this command.
#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/plan_file.hpp"
#include "io/scenario_summary.hpp"

namespace ridgeline::apps {

void register_run_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out";
  };
  auto args = std::make_shared<Args>();
  CLI::App* run = app.add_subcommand("run", "Run the mission on a scenario (default: embedded)");
  run->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  run->add_option("--out", args->out, "Output folder")->capture_default_str();
  run->callback([args] {
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    nlohmann::json summary = io::summarize(loaded);
    std::cout << io::summary_text(summary);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded);
    if (!plan) return;
    std::cout << io::plan_summary_text(*plan, loaded.scenario);
    const nlohmann::json plan_json = io::plan_to_json(*plan, loaded.scenario);
    summary["plan"] = {{"status", plan_json["status"]},
                       {"solve_time_s", plan_json["solve_time_s"]},
                       {"cost", plan_json["cost"]},
                       {"validation", plan_json["validation"]}};
    const std::filesystem::path dir(args->out);
    io::write_file_atomically(dir / "plan.json", plan_json.dump() + "\n");
    io::write_file_atomically(dir / "summary.json", summary.dump(2) + "\n");
    std::cout << "wrote " << (dir / "summary.json").string() << " and "
              << (dir / "plan.json").string() << '\n';
  });
}

}  // namespace ridgeline::apps
