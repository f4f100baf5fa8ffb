// `ridgeline ground [--scenario FILE] --out DIR`: the ground station as a process of the
// distributed swarm (src/nodes/ground_node.hpp). Plans the mission with the global planner,
// writes DIR/plan.json, publishes the plans, re-allocates open targets when a UAV is lost, and
// writes DIR/ground.json (the re-allocations) when the world's clock stops. Exit 3 when planning
// fails, 1 when the world never ran or went silent.
#include <fmt/format.h>

#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/node_support.hpp"
#include "io/atomic_file.hpp"
#include "io/plan_file.hpp"
#include "nodes/ground_node.hpp"

namespace ridgeline::apps {

void register_ground_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out";
    DdsArgs dds;
    bool no_reallocate = false;
    nodes::GroundNodeOptions options;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("ground", "The ground station (global planner) as a DDS node");
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  add_dds_options(cmd, args->dds);
  cmd->add_flag("--no-reallocate", args->no_reallocate, "Do not re-allocate a lost UAV's targets");
  cmd->callback([args] {
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded);
    if (!plan) return;
    const std::filesystem::path dir(args->out);
    io::write_file_atomically(dir / "plan.json",
                              io::plan_to_json(*plan, loaded.scenario).dump() + "\n");
    nodes::GroundNodeOptions options = args->options;
    options.reallocate = !args->no_reallocate;
    const nodes::GroundNodeResult r = nodes::run_ground_node(loaded.scenario, loaded.terrain, *plan,
                                                             dds_options(args->dds), options);
    io::write_file_atomically(dir / "ground.json", to_json(r).dump(2) + "\n");
    std::cout << fmt::format("ground: {} re-allocation(s){}\n", r.reallocations.size(),
                             r.message.empty() ? "" : "; " + r.message);
    if (!r.world_stopped) {
      std::cerr << "error: ground: " << r.message << '\n';
      set_exit_code(1);
    }
  });
}

}  // namespace ridgeline::apps
