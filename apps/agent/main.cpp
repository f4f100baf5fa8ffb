// `ridgeline-agent`: one UAV's on-board agent as a program of its own, the process `ridgeline
// launch --agents-as-processes` starts (and what goes on a vehicle's companion computer). It
// takes the options of `ridgeline agent` and links only what an agent runs: the scenario
// files, the mission layer and the DDS transport; not the simulator, the comparison methods,
// the benchmarks or libtorch (tests/apps/cli_dependencies_test.cpp checks).
#include <CLI/CLI.hpp>

#include "apps/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Ridgeline agent: one UAV's on-board agent as a DDS node"};
  app.set_version_flag("--version", "ridgeline-agent 0.1.0");
  ridgeline::apps::configure_agent_command(&app);
  return ridgeline::apps::parse_and_run(app, argc, argv);
}
