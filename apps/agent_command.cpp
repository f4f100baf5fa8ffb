// `ridgeline agent --id I [--scenario FILE]`: one UAV's on-board agent as a process of the
// distributed swarm (src/nodes/agent_node.hpp). Prints one line at the end; exit 1 when it
// gave up (no plan, or the world went silent). The same command is the program
// `ridgeline-agent` (apps/agent/main.cpp), which links no simulator.
#include <fmt/format.h>

#include <iostream>

#include "apps/commands.hpp"
#include "apps/node_support.hpp"
#include "apps/scenario_argument.hpp"
#include "core/error.hpp"
#include "nodes/agent_node.hpp"

namespace ridgeline::apps {

void register_agent_command(CLI::App& app) {
  configure_agent_command(app.add_subcommand("agent", "One UAV's on-board agent as a DDS node"));
}

void configure_agent_command(CLI::App* cmd) {
  struct Args {
    std::string scenario;
    DdsArgs dds;
    nodes::AgentNodeOptions options;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--id", args->options.id, "UAV index (0-based)")->required();
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  add_dds_options(cmd, args->dds);
  cmd->add_option("--link-loss", args->options.emulated_link.drop_rate,
                  "Emulated loss of UAV-to-UAV messages, in [0, 1]");
  cmd->add_option("--link-latency-s", args->options.emulated_link.latency_s,
                  "Emulated extra latency of UAV-to-UAV messages (mission time)");
  cmd->add_option("--link-jitter-s", args->options.emulated_link.jitter_s,
                  "Emulated jitter, uniform in [0, J]");
  cmd->add_option("--plan-timeout-s", args->options.plan_timeout_s, "Wall time to wait for a plan")
      ->capture_default_str();
  cmd->callback([args] {
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    nodes::AgentNodeOptions options = args->options;
    options.seed = loaded.scenario.seed * 1000003ULL + static_cast<std::uint64_t>(options.id);
    const nodes::AgentNodeResult r =
        nodes::run_agent_node(loaded.scenario, loaded.terrain, dds_options(args->dds), options);
    std::cout << fmt::format(
        "agent {}: {} steps, plan version {}, {} messages rejected, {} dropped "
        "by the emulated link, {} lock-step waits timed out{}\n",
        options.id, r.steps, r.plan_version, r.rejected, r.dropped, r.lock_step_timeouts,
        r.message.empty() ? "" : "; " + r.message);
    if (!r.world_stopped) {
      std::cerr << "error: agent " << options.id << ": " << r.message << '\n';
      set_exit_code(1);
    }
  });
}

}  // namespace ridgeline::apps
