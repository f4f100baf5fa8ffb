// `ridgeline`: the command line. A thin shell over library calls: each subcommand lives in
// its own file (apps/<name>_command.cpp) and registers itself here.
#include <CLI/CLI.hpp>

#include "apps/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Ridgeline: cooperative trajectory planning and tracking for UAV teams"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "ridgeline 0.1.0");
  for (const auto& register_command : ridgeline::apps::all_commands()) register_command(app);
  return ridgeline::apps::parse_and_run(app, argc, argv);
}
