// `ridgeline experiment [--runs 10] [--threads T] [--scenario FILE] [--tasks a,b]
// [--methods m1,m2] [--duration S] --out DIR`: the paper's comparison (issue 6): every task ×
// method × run with identical seeds per (task, run) (sim/experiment.hpp), progress on stderr,
// a table per task on stdout; writes DIR/experiment.json and DIR/report.html (Figures 3–5
// as charts). Exit 0 unless an input is wrong or a plan failed (3).
#include <fmt/format.h>

#include <algorithm>
#include <iostream>
#include <sstream>
#include <thread>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/report_html.hpp"
#include "sim/experiment.hpp"

namespace ridgeline::apps {
namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string experiment_table(const nlohmann::json& e) {
  std::string out;
  for (const auto& task : e["tasks"]) {
    out += fmt::format("task {}:\n  {:<11} {:>14} {:>9} {:>10} {:>14} {:>10} {:>9}\n",
                       task["task"].get<std::string>(), "method", "path_m (std)", "avoid",
                       "encounters", "track_mse_m2", "collision", "complete");
    for (const auto& [name, M] : task["methods"].items()) {
      const auto& p = M["path_length_m"];
      const auto& c = M["collisions"];
      out += fmt::format(
          "  {:<11} {:>7.0f} ({:>4.0f}) {:>9.3f} {:>10} {:>14.2f} {:>4}/{}/{} {:>6}/{}\n", name,
          p["mean"].is_null() ? 0.0 : p["mean"].get<double>(),
          p["std"].is_null() ? 0.0 : p["std"].get<double>(),
          M["avoidance_success_rate"].get<double>(), M["threat_encounters"].get<long long>(),
          M["tracking_mse_m2"]["mean"].is_null() ? 0.0 : M["tracking_mse_m2"]["mean"].get<double>(),
          c["terrain"].get<long long>(), c["threat"].get<long long>(),
          c["separation"].get<long long>(), M["missions_complete"].get<long long>(),
          M["flown_runs"].get<std::size_t>());
    }
  }
  return out;
}

}  // namespace

void register_experiment_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out/experiment";
    int runs = 10;
    int threads = 0;
    std::string tasks;
    std::string methods;
    std::string ddpg_model;
    double duration_s = 0.0;
    bool quiet = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* ex = app.add_subcommand(
      "experiment", "The paper's comparison: every task x method x run with identical seeds");
  ex->add_option("--runs", args->runs, "Runs per task and method")
      ->capture_default_str()
      ->check(at_least(1));
  ex->add_option("--threads", args->threads, "Worker threads (0: one per core)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  ex->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  ex->add_option("--tasks", args->tasks,
                 "Comma-separated subset of the tasks: northeast, east, crossing, far_corner");
  ex->add_option("--methods", args->methods,
                 "Comma-separated subset of the methods: proposed, astar_dwa, wind_aware, ddpg");
  add_ddpg_model_option(ex, args->ddpg_model);
  ex->add_option("--duration", args->duration_s,
                 "Simulated seconds at most per flight (0: the scenario's duration)")
      ->check(CLI::NonNegativeNumber);
  ex->add_option("--out", args->out, "Output folder")->capture_default_str();
  ex->add_flag("--quiet", args->quiet, "No progress on stderr");
  ex->callback([args] {
    sim::ExperimentOptions options;
    options.runs = args->runs;
    options.threads = args->threads > 0
                          ? args->threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    if (!args->tasks.empty()) {
      std::vector<sim::ExperimentTask> chosen;
      for (const std::string& name : split(args->tasks)) {
        const auto all = sim::default_experiment_tasks();
        const auto it =
            std::find_if(all.begin(), all.end(), [&](const auto& t) { return t.name == name; });
        if (it == all.end())
          throw InputError(
              "--tasks",
              fmt::format("unknown task '{}' (one of northeast, east, crossing, far_corner)",
                          name));
        chosen.push_back(*it);
      }
      options.tasks = chosen;
    }
    if (!args->methods.empty()) {
      options.methods.clear();
      for (const std::string& name : split(args->methods))
        options.methods.push_back(sim::parse_method(name, "--methods"));
    }
    options.ddpg_policy = load_ddpg_policy_if(
        std::find(options.methods.begin(), options.methods.end(), sim::Method::kDdpg) !=
            options.methods.end(),
        args->ddpg_model);
    io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    if (args->duration_s > 0.0) loaded.scenario.simulation.duration_s = args->duration_s;
    if (!args->quiet) {
      options.progress = [](int done, int total, const std::string& what) {
        std::cerr << fmt::format("\r[{}/{}] {:<40}", done, total, what) << std::flush;
      };
    }
    const nlohmann::json e = sim::run_experiment(loaded.scenario, loaded.terrain, options);
    if (!args->quiet) std::cerr << '\n';
    std::cout << experiment_table(e);
    std::cout << fmt::format(
        "{} flights in {:.1f} s on {} threads\n",
        e["tasks"].size() * e["methods"].size() * static_cast<std::size_t>(args->runs),
        e["wall_time_s"].get<double>(), e["threads"].get<int>());
    const std::filesystem::path dir(args->out);
    io::write_file_atomically(dir / "experiment.json", e.dump(2) + "\n");
    std::cout << "wrote " << (dir / "experiment.json").string() << '\n';
    write_report(
        dir, [&](std::string_view plotly_js) { return io::experiment_report_html(e, plotly_js); });
    for (const auto& task : e["tasks"])
      for (const auto& [name, M] : task["methods"].items())
        if (M["plan_status"] != "planned") {
          std::cerr << fmt::format("error: {} could not plan task {}: {}\n", name,
                                   task["task"].get<std::string>(),
                                   M["plan_message"].get<std::string>());
          set_exit_code(3);
        }
  });
}

}  // namespace ridgeline::apps
