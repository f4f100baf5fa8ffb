// `ridgeline montecarlo --runs N --threads T [--scenario FILE] --out DIR`: one plan, N flights
// of randomized variations (threat paths and times, wind, sensor noise, start jitter), on T
// threads, with a progress bar on stderr. Writes DIR/summary.json (counts, rates with Wilson
// 95 % intervals, each metric's distribution, every failed run's seed), DIR/runs.json (each
// run's metrics) and DIR/report.html (the rates and distributions as charts). Exit 0 when
// every run was safe, 4 otherwise (the files are still written).
#include <fmt/format.h>

#include <iostream>
#include <thread>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/report_html.hpp"
#include "sim/monte_carlo.hpp"

namespace ridgeline::apps {

void register_montecarlo_command(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string out = "out/montecarlo";
    int runs = 100;
    int threads = 0;
    bool quiet = false;
    std::string method = "proposed";
    std::string ddpg_model;
  };
  auto args = std::make_shared<Args>();
  CLI::App* mc = app.add_subcommand("montecarlo", "Fly many randomized variations of a mission");
  mc->add_option("--runs", args->runs, "Number of flights")
      ->capture_default_str()
      ->check(at_least(1));
  mc->add_option("--threads", args->threads, "Worker threads (0: one per core)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  mc->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  mc->add_option("--out", args->out, "Output folder")->capture_default_str();
  mc->add_flag("--quiet", args->quiet, "No progress bar");
  mc->add_option("--method", args->method,
                 "proposed, astar_dwa, wind_aware or ddpg (see run --help)")
      ->capture_default_str();
  add_ddpg_model_option(mc, args->ddpg_model);
  mc->callback([args] {
    const sim::Method method = sim::parse_method(args->method);
    const std::shared_ptr<const learning::DdpgPolicy> ddpg_policy =
        load_ddpg_policy_if(method == sim::Method::kDdpg, args->ddpg_model);
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const std::optional<planning::GlobalPlan> plan = plan_or_report(loaded, method);
    if (!plan) return;
    sim::MonteCarloOptions options;
    options.method = method;
    options.ddpg_policy = ddpg_policy;
    options.runs = args->runs;
    options.threads = args->threads > 0
                          ? args->threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    if (!args->quiet) {
      options.progress = [](int done, int total, int failed) {
        const int width = 30;
        const int filled = done * width / total;
        std::cerr << fmt::format("\r[{}{}] {}/{} runs, {} failed", std::string(filled, '#'),
                                 std::string(width - filled, '.'), done, total, failed)
                  << std::flush;
      };
    }
    const sim::MonteCarloReport report =
        sim::run_monte_carlo(loaded.scenario, loaded.terrain, *plan, options);
    if (!args->quiet) std::cerr << '\n';
    nlohmann::json summary = report.summary();
    summary["scenario"] = loaded.scenario.name;
    summary["method"] = sim::to_string(method);
    summary["global_plan_s"] = plan->total_time_s;
    nlohmann::json runs = nlohmann::json::array();
    for (const sim::MonteCarloRun& r : report.runs) {
      nlohmann::json j = mission::to_json(r.metrics);
      j["run"] = r.index;
      j["seed"] = r.seed;
      j["failures"] = r.failures;
      runs.push_back(std::move(j));
    }
    const std::filesystem::path dir(args->out);
    io::write_file_atomically(dir / "runs.json", runs.dump() + "\n");
    io::write_file_atomically(dir / "summary.json", summary.dump(2) + "\n");
    const auto& c = summary["counts"];
    std::cout << fmt::format(
        "{} runs in {:.1f} s ({:.2f} runs/s, {} threads; {:.2f} runs per CPU second): {} safe, {} "
        "complete; terrain "
        "collisions {}, threat intrusions {} of {} encounters, separation violations {}, "
        "constraint violations {}\n",
        report.runs.size(), report.wall_time_s, summary["runs_per_second"].get<double>(),
        report.threads, summary["runs_per_cpu_second"].get<double>(),
        c["safe_runs"].get<long long>(), c["complete_missions"].get<long long>(),
        c["terrain_collisions"].get<long long>(), c["threat_intrusions"].get<long long>(),
        c["threat_encounters"].get<long long>(), c["separation_violations"].get<long long>(),
        c["constraint_violations"].get<long long>());
    for (const auto& f : summary["failed_runs"])
      std::cout << fmt::format("failed: run {} seed {}: {}\n", f["run"].get<int>(),
                               f["seed"].get<std::uint64_t>(), f["reasons"].dump());
    std::cout << "wrote " << (dir / "summary.json").string() << " and "
              << (dir / "runs.json").string() << '\n';
    write_report(dir, [&](std::string_view plotly_js) {
      return io::montecarlo_report_html(summary, runs, plotly_js);
    });
    if (!summary["failed_runs"].empty()) set_exit_code(4);
  });
}

}  // namespace ridgeline::apps
