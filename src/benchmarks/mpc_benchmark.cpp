#include "benchmarks/mpc_benchmark.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <vector>

#include "core/cpu_clock.hpp"
#include "mpc/reference.hpp"
#include "mpc/uav_tracker.hpp"
#include "qp/ipopt_reference.hpp"
#include "qp/qp_instance_file.hpp"
#include "qp/qp_solver.hpp"
#include "world/terrain.hpp"

namespace ridgeline::benchmarks {
namespace {

double thread_cpu_us() { return thread_cpu_time_s() * 1e6; }

}  // namespace

nlohmann::json MpcBenchmarkReport::to_json() const {
  return {{"steps", steps},
          {"prediction_horizon", prediction_horizon},
          {"control_horizon", control_horizon},
          {"mpc_step_us", mission::to_json(step_us)},
          {"mpc_step_cpu_us", mission::to_json(step_cpu_us)},
          {"qp_solve_us", mission::to_json(qp_us)},
          {"step_part_medians_us",
           {{"linearization", parts.linearization_us},
            {"condensing", parts.condensing_us},
            {"soft_rows", parts.soft_rows_us},
            {"qp", parts.qp_us},
            {"other", parts.other_us}}},
          {"step_cpu_over_qp_median", step_over_qp},
          {"qp_iterations", mission::to_json(qp_iterations)},
          {"qp_method", qp_method},
          {"qp_fallbacks", qp_fallbacks},
          {"qps_dumped", qps_dumped},
          {"not_solved", not_solved},
          {"max_slack_m", max_slack_m},
          {"soft_rows_mean", soft_rows_mean},
          {"soft_rows_in_qp_mean", soft_rows_in_qp_mean},
          {"prediction_rows_computed_mean", prediction_rows_computed_mean},
          {"prediction_rows", prediction_rows},
          {"ipopt_compared", ipopt_compared},
          {"ipopt_qp_us_median", ipopt_qp_us_median},
          {"ours_on_compared_qp_us_median", ours_on_compared_us_median},
          {"ipopt_over_ours_ratio", ipopt_over_ours_ratio},
          {"max_rel_objective_gap", max_rel_objective_gap},
          {"host_speed", host_speed.to_json()},
          {"host_interruptions", host_interruptions.to_json()},
          {"interrupted_step_share_expected", interrupted_step_share_expected}};
}

MpcBenchmarkReport run_mpc_benchmark(const MpcBenchmarkOptions& options) {
  mpc::UavTrackerOptions tracker_options;  // Np 40 × 0.1 s, Nc 10, 50 Hz by default
  tracker_options.prediction_horizon = options.prediction_horizon;
  tracker_options.control_horizon = options.control_horizon;
  // Each step is timed here, from outside; the tracker's own reading of the CPU clock (two
  // system calls, about 1 µs) would be counted in the step it measures.
  tracker_options.cpu_time_period_steps = 0;
  // The benchmark's own workload, unchanged since it was first measured: r_safe 5 m (the
  // missions' default is 10 m); d_safe and h_safe at their defaults.
  world::SafetyLimits limits;
  limits.threat_margin_m = 5.0;
  mpc::UavTracker tracker(tracker_options, limits);
  mpc::HelixReference::Config circle;
  circle.centre_m = Vec3(0.0, 0.0, 120.0);
  circle.radius_m = 150.0;
  circle.speed_m_s = 10.0;
  const mpc::HelixReference reference(circle);

  std::vector<world::Threat> threats(3);
  const double phase_s[3] = {9.0, 36.0, 63.0};
  for (int i = 0; i < 3; ++i) {
    threats[i].name = fmt::format("threat{}", i);
    threats[i].centre_m = reference.at(phase_s[i]).position_m + Vec3(0.0, 0.0, 10.0 * i);
    threats[i].velocity_m_s = Vec3(1.0, -1.0, 0.0);
    threats[i].radius_m = 25.0;
  }
  auto neighbour = [&](int id, double lead_s, double offset_m) {
    messages::PredictedTrajectory nb;
    nb.uav = id;
    nb.step_s = 0.5;
    nb.stamp_s = -nb.step_s;  // the first position at t = 0
    for (int i = 0; i < 400; ++i) {
      const mpc::ReferencePoint r = reference.at(i * 0.5 + lead_s);
      const Vec3 left(-std::sin(r.heading_rad), std::cos(r.heading_rad), 0.0);
      nb.positions_m.push_back(r.position_m + offset_m * left);
    }
    return nb;
  };
  const std::vector<messages::PredictedTrajectory> neighbours{neighbour(1, 2.5, 15.0),
                                                              neighbour(2, -2.5, -15.0)};
  // Hills under the circle, 60–90 m below the flight: inside the terrain rows' activation.
  world::PeakTerrainConfig hills;
  hills.peaks = {{150, 0, 80, 120, 120}, {-100, 120, 80, 120, 120}, {0, -150, 80, 120, 120}};
  const world::PeakTerrain terrain(hills);
  const mpc::TrackerEnvironment environment{threats, neighbours, &terrain};

  vehicle::VehicleParams truth = tracker_options.vehicle;  // mismatched lags
  truth.tau_v_s *= 1.3;
  truth.tau_omega_s *= 0.75;
  const Vec3 wind(1.4, 1.4, 0.0);
  const mpc::ReferencePoint r0 = reference.at(0.0);
  vehicle::State state;
  state << r0.position_m, r0.heading_rad, r0.speed_m_s, r0.turn_rate_rad_s, 0.0;

  MpcBenchmarkReport report;
  report.qp_method = std::string(qp::to_string(tracker_options.qp_settings.method));
  std::optional<qp::QpInstanceWriter> dump;
  if (!options.dump_qps_path.empty()) dump.emplace(options.dump_qps_path);
  std::vector<double> step_us, cpu_us, qp_us, iterations, ours_compared, ipopt_us;
  std::vector<double> linearization_us, condensing_us, soft_rows_us, part_qp_us, other_us;
  const int truth_substeps = 4;  // 200 Hz truth
  const double dt_truth = tracker_options.control_period_s / truth_substeps;
  double t = 0.0;
  double rows = 0.0, rows_in_qp = 0.0, rows_computed = 0.0;
  report.host_speed.read_before();
  report.host_interruptions = probe_interruptions();
  for (int k = 0; k < options.steps; ++k) {
    const double cpu_start = thread_cpu_us();
    const auto start = std::chrono::steady_clock::now();
    const mpc::UavTrackerResult& r = tracker.step(t, state, wind, reference, environment);
    step_us.push_back(
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
            .count());
    cpu_us.push_back(thread_cpu_us() - cpu_start);
    qp_us.push_back(r.qp_time_us);
    linearization_us.push_back(r.parts.linearization_us);
    condensing_us.push_back(r.parts.condensing_us);
    soft_rows_us.push_back(r.parts.soft_rows_us);
    part_qp_us.push_back(r.parts.qp_us);
    other_us.push_back(r.parts.other_us);
    iterations.push_back(r.qp_iterations);
    rows += r.soft_rows[0] + r.soft_rows[1] + r.soft_rows[2];
    rows_in_qp += r.soft_rows_in_qp;
    rows_computed += tracker.mpc().last_result().prediction_rows_computed;
    report.max_slack_m = std::max(report.max_slack_m, r.max_slack_m());
    if (r.qp_status != qp::QpStatus::kSolved) ++report.not_solved;
    if (tracker.mpc().qp_result().fell_back) ++report.qp_fallbacks;
    if (dump) dump->write(tracker.mpc().qp_problem());

    if (options.ipopt_every > 0 && k % options.ipopt_every == 0 &&
        r.qp_status == qp::QpStatus::kSolved) {
      // bound_relax_factor 0: Ipopt's default relaxation of the sides by 1e-8 (relative) shifts
      // the objective by up to ~3e-4 on these QPs, hiding the solvers' own accuracy.
      const qp::IpoptQpSolution ipopt = qp::solve_with_ipopt(tracker.mpc().qp_problem(), 1e-9, 0.0);
      if (ipopt.solved()) {
        ++report.ipopt_compared;
        ipopt_us.push_back(ipopt.solve_time_us);
        ours_compared.push_back(r.qp_time_us);
        const double ours = tracker.mpc().qp_result().objective;
        report.max_rel_objective_gap =
            std::max(report.max_rel_objective_gap,
                     std::abs(ours - ipopt.objective) / std::max(1.0, std::abs(ipopt.objective)));
      }
    }
    for (int i = 0; i < truth_substeps; ++i)
      state = vehicle::rk4_step(state, r.command, wind, truth, dt_truth);
    t += tracker_options.control_period_s;
  }
  report.host_speed.read_after();
  report.steps = options.steps;
  report.prediction_horizon = options.prediction_horizon;
  report.control_horizon = options.control_horizon;
  if (dump) {
    dump->close();
    report.qps_dumped = dump->count();
  }
  report.step_us = mission::percentiles(step_us);
  report.step_cpu_us = mission::percentiles(cpu_us);
  report.qp_us = mission::percentiles(qp_us);
  report.interrupted_step_share_expected =
      report.host_interruptions.per_ms * report.step_us.median / 1000.0;
  report.qp_iterations = mission::percentiles(iterations);
  report.parts.linearization_us = mission::percentiles(linearization_us).median;
  report.parts.condensing_us = mission::percentiles(condensing_us).median;
  report.parts.soft_rows_us = mission::percentiles(soft_rows_us).median;
  report.parts.qp_us = mission::percentiles(part_qp_us).median;
  report.parts.other_us = mission::percentiles(other_us).median;
  if (report.qp_us.median > 0.0) report.step_over_qp = report.step_cpu_us.median / report.qp_us.median;
  report.soft_rows_mean = options.steps > 0 ? rows / options.steps : 0.0;
  report.soft_rows_in_qp_mean = options.steps > 0 ? rows_in_qp / options.steps : 0.0;
  report.prediction_rows_computed_mean = options.steps > 0 ? rows_computed / options.steps : 0.0;
  report.prediction_rows = (tracker.mpc().dims().state_dim + tracker.mpc().dims().output_dim) *
                           options.prediction_horizon;
  if (report.ipopt_compared > 0) {
    report.ipopt_qp_us_median = mission::percentiles(ipopt_us).median;
    report.ours_on_compared_us_median = mission::percentiles(ours_compared).median;
    report.ipopt_over_ours_ratio = report.ipopt_qp_us_median / report.ours_on_compared_us_median;
  }
  return report;
}

}  // namespace ridgeline::benchmarks
