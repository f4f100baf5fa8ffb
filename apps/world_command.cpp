// `ridgeline world [--scenario FILE] [--real-time] --out DIR`: the truth simulator as a process
// of the distributed swarm (src/nodes/world_node.hpp). It waits for the agents' hellos, runs the
// clock (lock-step by default, --real-time at the control rate), and writes DIR/metrics.json
// (the same metrics as `ridgeline run`, plus "distributed": per-agent loop period jitter, compute
// time and missed deadlines, lost UAVs), DIR/trajectories.csv and DIR/report.html. Exit 4 when
// the flight broke a safety constraint.
#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <optional>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/node_support.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/report_html.hpp"
#include "nodes/world_node.hpp"

namespace ridgeline::apps {

void register_world_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out";
    DdsArgs dds;
    bool real_time = false;
    bool quiet = false;
    std::optional<double> duration_s;
    nodes::WorldNodeOptions options;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("world", "The truth simulator as a DDS node (see launch)");
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  add_dds_options(cmd, args->dds);
  cmd->add_flag("--real-time", args->real_time, "Run at the control rate on the wall clock");
  cmd->add_option("--wait-for-agents", args->options.wait_for_agents,
                  "Agents to wait for before starting (default: all)");
  cmd->add_option("--start-timeout-s", args->options.start_timeout_s, "Wall time to wait for them")
      ->capture_default_str();
  cmd->add_option("--answer-timeout-s", args->options.answer_timeout_s,
                  "Lock-step: wall time before a silent agent is declared lost")
      ->capture_default_str();
  cmd->add_option("--lost-after-periods", args->options.lost_after_periods,
                  "Real time: silent control periods before an agent is declared lost")
      ->capture_default_str();
  cmd->add_option("--duration-s", args->duration_s,
                  "Stop the mission at this time (default: the scenario's simulation.duration_s)");
  cmd->add_flag("--quiet", args->quiet, "No progress on stderr");
  cmd->callback([args] {
    io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    if (args->duration_s) {
      if (!(*args->duration_s > 0.0 && std::isfinite(*args->duration_s)))
        throw InputError("--duration-s",
                         fmt::format("must be positive, got {}", *args->duration_s));
      loaded.scenario.simulation.duration_s = *args->duration_s;
    }
    nodes::WorldNodeOptions options = args->options;
    options.lock_step = !args->real_time;
    if (!args->quiet) {
      options.progress = [](double t, double duration) {
        if (static_cast<int>(t) % 10 == 0)
          std::cerr << fmt::format("\rworld: t = {:5.0f} s of at most {:.0f} s", t, duration)
                    << std::flush;
      };
    }
    const nodes::WorldNodeResult world =
        nodes::run_world_node(loaded.scenario, loaded.terrain, dds_options(args->dds), options);
    if (!args->quiet) std::cerr << '\n';
    const mission::MissionMetrics& m = world.mission.metrics;
    nlohmann::json metrics = mission::to_json(m);
    metrics["distributed"] = to_json(world);
    const std::filesystem::path dir(args->out);
    io::write_file_atomically(dir / "metrics.json", metrics.dump(2) + "\n");
    io::write_file_atomically(
        dir / "trajectories.csv",
        mission::trajectories_csv(world.mission.trajectories, loaded.scenario));
    std::cout << fmt::format(
        "world: {} in {:.1f} s simulated, {:.1f} s wall; min separation {:.1f} m, terrain "
        "collisions {}, threat intrusions {}, lost UAVs {}\n",
        m.mission_complete ? "mission complete" : "mission NOT complete", m.sim_time_s,
        world.wall_time_s, m.min_separation_m, m.terrain_collisions, m.threat_intrusions,
        world.lost.size());
    write_report(dir, [&](std::string_view plotly_js) {
      return io::mission_report_html(
          {loaded.scenario, *loaded.terrain, m, world.mission.trajectories}, plotly_js);
    });
    if (!m.safe()) {
      std::cerr << "error: the flight broke a safety constraint (see metrics.json)\n";
      set_exit_code(4);
    }
  });
}

}  // namespace ridgeline::apps
