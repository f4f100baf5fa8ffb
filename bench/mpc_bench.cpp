// The UAV tracker's full control step at DESIGN §3's sizes (Np = 40 × 0.1 s, Nc = 10) with 3
// threats, 2 neighbours and terrain rows active: the workload of sim/mpc_benchmark.hpp, the
// same one `ridgeline bench mpc` runs. Counters give the step's median, p99 and max (µs), the
// QP's share and its iterations, and Ipopt's time on the same QPs as a ratio of one run.
#include <benchmark/benchmark.h>

#include "benchmarks/mpc_benchmark.hpp"

namespace {

void BM_UavTrackerClosedLoop(benchmark::State& state) {
  ridgeline::benchmarks::MpcBenchmarkReport report;
  for (auto _ : state) {
    ridgeline::benchmarks::MpcBenchmarkOptions options;
    options.steps = 3000;
    options.ipopt_every = 30;
    report = ridgeline::benchmarks::run_mpc_benchmark(options);
  }
  state.counters["step_median_us"] = report.step_us.median;
  state.counters["step_p99_us"] = report.step_us.p99;
  state.counters["step_max_us"] = report.step_us.max;
  state.counters["step_cpu_median_us"] = report.step_cpu_us.median;
  state.counters["qp_median_us"] = report.qp_us.median;
  state.counters["qp_iter_median"] = report.qp_iterations.median;
  state.counters["qp_iter_max"] = report.qp_iterations.max;
  state.counters["not_solved"] = report.not_solved;
  state.counters["ipopt_over_ours"] = report.ipopt_over_ours_ratio;
}
BENCHMARK(BM_UavTrackerClosedLoop)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
