// The tracker's workload for `ridgeline bench mpc` and bench/mpc_bench.cpp: one UAV flies a
// 150 m circle in a 2 m/s wind for `steps` control periods of the closed loop (truth by RK4
// with mismatched lags, outside the timed region), with DESIGN §3's sizes (Np = 40 × 0.1 s,
// Nc = 10) and every kind of soft row active: three slowly moving threat spheres on and beside
// the circle, two neighbours flying it 25 m ahead and behind at a 15 m offset, and hills under
// it within the terrain rows' activation distance.
//
// Each step is timed whole (linearize, build, solve) and in its parts (UavTrackerStepParts:
// linearization, condensing, soft rows, QP, other). `prediction_horizon`/`control_horizon`
// change Np and Nc (the soft rows scale with Np). Every `ipopt_every`-th QP is also
// solved by Ipopt, outside the timed region, for the speed ratio and an accuracy check.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "benchmarks/host_speed.hpp"
#include "mission/statistics.hpp"

namespace ridgeline::benchmarks {

struct MpcBenchmarkOptions {
  int steps = 3000;      ///< control steps (60 s at 50 Hz)
  int prediction_horizon = 40;  ///< Np
  int control_horizon = 10;     ///< Nc
  int ipopt_every = 10;  ///< compare with Ipopt on every n-th QP (0: never)
  /// When set, every step's QP is appended to this RLQP file (outside the timed region), for
  /// `ridgeline bench qp --instances`.
  std::string dump_qps_path;
};

/// Medians of the step's parts (UavTrackerStepParts), wall clock, µs.
struct MpcStepPartMedians {
  double linearization_us = 0.0;
  double condensing_us = 0.0;
  double soft_rows_us = 0.0;
  double qp_us = 0.0;
  double other_us = 0.0;
};

struct MpcBenchmarkReport {
  int steps = 0;
  int prediction_horizon = 0;
  int control_horizon = 0;
  mission::Percentiles step_us;      ///< whole MPC step, wall clock
  mission::Percentiles step_cpu_us;  ///< the same in thread CPU time (robust to preemption)
  mission::Percentiles qp_us;        ///< our QP solve inside the step
  MpcStepPartMedians parts;
  double step_over_qp = 0.0;  ///< median step (CPU) / median QP solve
  mission::Percentiles qp_iterations;
  std::string qp_method;     ///< the tracker's QpSettings::method
  int qp_fallbacks = 0;      ///< active-set solves the interior point had to answer
  int qps_dumped = 0;        ///< QPs written to dump_qps_path
  int not_solved = 0;        ///< steps whose QP did not reach kSolved
  double max_slack_m = 0.0;  ///< largest soft-constraint violation the plans accepted
  double soft_rows_mean = 0.0;        ///< soft rows added a step
  double soft_rows_in_qp_mean = 0.0;  ///< of them, the rows the QP carried (not redundant)
  /// Rows of Γ and Φ the condensing computed a step, of prediction_rows (the others kept)
  double prediction_rows_computed_mean = 0.0;
  int prediction_rows = 0;
  int ipopt_compared = 0;
  double ipopt_qp_us_median = 0.0;  ///< Ipopt on the same QPs
  double ours_on_compared_us_median = 0.0;
  double ipopt_over_ours_ratio = 0.0;  ///< ipopt median / ours median on the compared QPs
  double max_rel_objective_gap = 0.0;  ///< |J_ours − J_ipopt| / max(1, |J_ipopt|)
  HostSpeed host_speed;  ///< this core's speed before and after the steps
  /// This thread's interruptions, probed before the steps (kInterruptionProbeMs), and the
  /// share of steps expected to hold one: per_ms × the median step (wall) / 1000.
  HostInterruptions host_interruptions;
  double interrupted_step_share_expected = 0.0;

  nlohmann::json to_json() const;
};

MpcBenchmarkReport run_mpc_benchmark(const MpcBenchmarkOptions& options = {});

}  // namespace ridgeline::benchmarks
