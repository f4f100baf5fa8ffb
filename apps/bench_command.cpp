// `ridgeline bench mpc [--steps N] [--ipopt-every K]`: measures the tracker's full 50 Hz step
// and compares its QP solver with Ipopt on the same QPs, printing JSON. Figures are medians and
// ratios from one run: absolute times vary on shared machines.
#include <iostream>

#include "apps/commands.hpp"
#include "core/error.hpp"
#include "sim/mpc_benchmark.hpp"

namespace ridgeline::apps {

void register_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Speed measurements, printed as JSON");
  bench->require_subcommand(1);
  auto options = std::make_shared<sim::MpcBenchmarkOptions>();
  CLI::App* mpc = bench->add_subcommand(
      "mpc", "The MPC step (Np 40, Nc 10, 3 threats, 2 neighbours, terrain) and our QP vs Ipopt");
  mpc->add_option("--steps", options->steps, "closed-loop control steps")->capture_default_str();
  mpc->add_option("--ipopt-every", options->ipopt_every, "solve every n-th QP with Ipopt too")
      ->capture_default_str();
  mpc->callback([options] {
    if (options->steps < 1) throw InputError("--steps", "must be at least 1");
    if (options->ipopt_every < 0) throw InputError("--ipopt-every", "must not be negative");
    std::cout << sim::run_mpc_benchmark(*options).to_json().dump(2) << '\n';
  });
}

}  // namespace ridgeline::apps
