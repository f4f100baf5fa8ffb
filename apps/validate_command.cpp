// `ridgeline validate FILE`: parses and checks a scenario, listing every problem by field.
#include <iostream>

#include "apps/commands.hpp"
#include "io/scenario_file.hpp"
#include "io/scenario_summary.hpp"

namespace ridgeline::apps {

void register_validate_command(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  CLI::App* validate = app.add_subcommand("validate", "Check a scenario file and summarize it");
  validate->add_option("file", *file, "Scenario YAML file")->required();
  validate->callback([file] {
    try {
      const io::LoadedScenario loaded = io::load_scenario_file(*file);
      std::cout << "valid: " << io::summary_text(io::summarize(loaded));
    } catch (const io::InvalidScenario& e) {
      for (const InputError& problem : e.problems()) std::cerr << "error: " << problem.what() << '\n';
      std::cerr << *file << ": " << e.problems().size() << " problem"
                << (e.problems().size() == 1 ? "" : "s") << ", scenario rejected\n";
      set_exit_code(2);
    }
  });
}

}  // namespace ridgeline::apps
