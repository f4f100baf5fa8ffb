// `ridgeline run [--scenario FILE] --out DIR`: the main job. It loads and validates the
// scenario (the embedded default without --scenario) and writes DIR/summary.json. The
// closed-loop flight lands with the simulator; until then the job plans nothing.
#include <iostream>

#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/scenario_file.hpp"
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
    const io::LoadedScenario loaded = args->scenario.empty()
                                          ? io::load_default_scenario()
                                          : io::load_scenario_file(args->scenario);
    const nlohmann::json summary = io::summarize(loaded);
    std::cout << io::summary_text(summary);
    const std::filesystem::path out = std::filesystem::path(args->out) / "summary.json";
    io::write_file_atomically(out, summary.dump(2) + "\n");
    std::cout << "wrote " << out.string() << '\n';
  });
}

}  // namespace ridgeline::apps
