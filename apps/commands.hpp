// Registry of the command line's subcommands. Each apps/<name>_command.cpp defines one
// `register_<name>_command` that adds a CLI11 subcommand whose callback does the work.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace ridgeline::apps {

using CommandRegistrar = std::function<void(CLI::App&)>;

void register_scenario_command(CLI::App& app);
void register_validate_command(CLI::App& app);
void register_run_command(CLI::App& app);
void register_fit_dem_command(CLI::App& app);
void register_make_dem_command(CLI::App& app);
void register_plan_command(CLI::App& app);
void register_bench_command(CLI::App& app);
void register_montecarlo_command(CLI::App& app);
void register_vehicle_sim_command(CLI::App& app);
void register_fly_command(CLI::App& app);
void register_world_command(CLI::App& app);
void register_agent_command(CLI::App& app);
void register_ground_command(CLI::App& app);
void register_launch_command(CLI::App& app);
void register_export_command(CLI::App& app);
void register_experiment_command(CLI::App& app);
void register_train_command(CLI::App& app);

inline std::vector<CommandRegistrar> all_commands() {
  return {register_scenario_command, register_validate_command, register_run_command,
          register_fit_dem_command, register_make_dem_command, register_plan_command,
          register_bench_command, register_montecarlo_command, register_vehicle_sim_command,
          register_fly_command, register_export_command, register_experiment_command,
          register_world_command, register_agent_command, register_ground_command,
          register_launch_command, register_train_command};
}

/// The agent's options and callback on `command` (the `agent` subcommand, or the root of the
/// `ridgeline-agent` program).
void configure_agent_command(CLI::App* command);

/// Exit code the chosen subcommand asks for (0 unless it called set_exit_code).
int exit_code();
void set_exit_code(int code);

/// Parses the command line and runs the chosen command: its exit code, 2 after an InputError
/// (one "error: field: reason" line), 1 after any other error.
int parse_and_run(CLI::App& app, int argc, char** argv);

}  // namespace ridgeline::apps
