// `ridgeline scenario default`: prints the embedded default scenario as commented YAML.
#include <iostream>

#include "apps/commands.hpp"
#include "io/scenario_file.hpp"

namespace ridgeline::apps {

void register_scenario_command(CLI::App& app) {
  CLI::App* scenario = app.add_subcommand("scenario", "Scenario files");
  scenario->require_subcommand(1);
  CLI::App* print_default = scenario->add_subcommand(
      "default", "Print the embedded default scenario (DESIGN §7) as YAML you can edit");
  print_default->callback([] { std::cout << io::default_scenario_yaml(); });
}

}  // namespace ridgeline::apps
