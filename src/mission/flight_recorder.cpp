#include "mission/flight_recorder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mission/statistics.hpp"

namespace ridgeline::mission {
namespace {

constexpr double kTrackingSampleSpacingM = 10.0;  // DESIGN §6: every 10 m of flown path

}  // namespace

FlightRecorder::FlightRecorder(const Scenario& scenario, const world::Terrain& terrain,
                               const TruthWorld& world, bool record_trajectories)
    : scenario_(scenario),
      record_(record_trajectories),
      safety_(scenario.safety, world.num_uavs(), terrain),
      min_turn_radius_m_(std::numeric_limits<double>::infinity()) {
  const int n = world.num_uavs();
  tally_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    tally_[static_cast<std::size_t>(i)].last_position = world.true_position(i);
  for (const char* kind : {"altitude", "pitch", "turn"})
    result_.metrics.constraint_violations[kind] = 0;
  // A row a UAV and control step, up to the scenario's duration: reserved once rather than grown
  // (each regrowth copies the rows and faults in fresh pages). Pages past the rows written are
  // never touched; the cap bounds the address space a very long scenario asks for.
  constexpr double kMaxReservedRows = 1 << 20;
  const double steps =
      std::floor(scenario.simulation.duration_s / scenario.mpc.control_period_s) + 2.0;
  const double wanted = n * steps;
  const auto rows =
      static_cast<std::size_t>(wanted >= 0.0 ? std::min(wanted, kMaxReservedRows) : 0.0);
  if (record_) result_.trajectories.reserve(rows);
  for (std::vector<double>* v : {&step_us_, &step_cpu_us_, &iterations_}) v->reserve(rows);
}

void FlightRecorder::sensed(int uav, int threat, double t, const TruthWorld& world) {
  safety_.sensed(uav, threat, t, world);
}

void FlightRecorder::control_step(int i, double t, const TruthWorld& world,
                                  const ControlReport& r) {
  if (!r.finished) {
    if (r.has_tracker) {
      step_us_.push_back(r.mpc_step_us);
      // A tracker may read the CPU clock on some steps only (NaN on the others).
      if (!std::isnan(r.mpc_step_cpu_us)) step_cpu_us_.push_back(r.mpc_step_cpu_us);
      iterations_.push_back(r.qp_iterations);
    } else if (r.step_time_us >= 0.0) {
      step_us_.push_back(r.step_time_us);
    }
    UavTally& u = tally_[static_cast<std::size_t>(i)];
    u.max_slack_m = std::max(u.max_slack_m, r.max_slack_m);
  }
  path_and_constraints(i, t, world, r.finished, &r.reference_m, &r.command);
}

void FlightRecorder::unanswered(int i, double t, const TruthWorld& world) {
  path_and_constraints(i, t, world, false, nullptr, nullptr);
}

void FlightRecorder::path_and_constraints(int i, double t, const TruthWorld& world, bool finished,
                                          const Vec3* reference_m, const vehicle::Input* command) {
  MissionMetrics& m = result_.metrics;
  UavTally& u = tally_[static_cast<std::size_t>(i)];
  const vehicle::State& s = world.true_state(i);
  const Vec3 p = s.head<3>();
  u.path_m += (p - u.last_position).norm();
  u.last_position = p;
  if (!finished && reference_m != nullptr && u.path_m >= u.next_sample_m) {
    u.squared_error_sum += (p - *reference_m).squaredNorm();
    ++u.samples;
    u.next_sample_m += kTrackingSampleSpacingM;
  }
  if (!world.holding(i)) {
    const vehicle::VehicleParams& vp = scenario_.uavs[static_cast<std::size_t>(i)].vehicle;
    if (!scenario_.safety.altitude.contains(p.z())) ++m.constraint_violations["altitude"];
    if (std::abs(vehicle::pitch_angle_rad(s)) > vp.max_pitch_rad + 1e-3)
      ++m.constraint_violations["pitch"];
    // Eq. 3 bounds the command: |ω_c| ≤ v/R_min at the speed the vehicle has when the command
    // is issued. The flown radius v/|ω| is reported too (it includes the lags).
    if (!finished && command != nullptr) {
      const double limit = vp.max_turn_rate_rad_s(s[vehicle::kV]);
      const double ratio = std::abs((*command)[1]) / limit;
      m.max_turn_command_ratio = std::max(m.max_turn_command_ratio, ratio);
      if (ratio > 1.0 + 1e-6) ++m.constraint_violations["turn"];
    }
    if (std::abs(s[vehicle::kOmega]) > 1e-9)
      min_turn_radius_m_ =
          std::min(min_turn_radius_m_, s[vehicle::kV] / std::abs(s[vehicle::kOmega]));
  }
  if (record_) {
    result_.trajectories.push_back({t, i, p, reference_m != nullptr ? *reference_m : p,
                                    s[vehicle::kV], s[vehicle::kPsi], s[vehicle::kW]});
  }
}

void FlightRecorder::tick(double t, const TruthWorld& world) { safety_.sample(t, world); }

MissionResult FlightRecorder::finish(double t, const std::vector<UavOutcome>& outcomes) {
  MissionMetrics& m = result_.metrics;
  m.sim_time_s = t;
  m.min_turn_radius_m = min_turn_radius_m_;
  m.mpc_solve_us = percentiles(step_us_);
  m.mpc_solve_cpu_us = percentiles(step_cpu_us_);
  m.qp_iterations = percentiles(iterations_);
  m.mission_complete = true;
  for (std::size_t i = 0; i < tally_.size() && i < outcomes.size(); ++i) {
    const UavOutcome& a = outcomes[i];
    const UavTally& u = tally_[i];
    UavMetrics um;
    um.name = scenario_.uavs[i].name;
    um.path_length_m = u.path_m;
    um.tracking_samples = u.samples;
    um.tracking_mse_m2 = u.samples > 0 ? u.squared_error_sum / u.samples : 0.0;
    um.tracking_rmse_m = std::sqrt(um.tracking_mse_m2);
    um.targets_assigned = a.targets_assigned;
    um.targets_inspected = a.targets_inspected;
    um.missed_targets = a.missed_targets;
    um.finished = a.finished;
    um.finish_time_s = a.finish_time_s;
    const std::optional<Vec3>& end = scenario_.uavs[i].end_position_m;
    if (end) {
      um.end_distance_m = (u.last_position - *end).norm();
      um.end_reached = um.end_distance_m <= end_reached_radius_m();
    }
    const swarm::AgentCounters& c = a.counters;
    um.replans = static_cast<long long>(c.replans);
    um.optimizer_replans = static_cast<long long>(c.optimizer_replans);
    um.neighbour_conflicts = static_cast<long long>(c.neighbour_conflicts);
    um.replan_failures = static_cast<long long>(c.replan_failures);
    um.rejoins = static_cast<long long>(c.rejoins);
    um.level_changes = static_cast<long long>(c.level_changes);
    um.delay_changes = static_cast<long long>(c.delay_changes);
    um.reapproaches = static_cast<long long>(c.reapproaches);
    um.guard_steps = static_cast<long long>(c.guard_steps);
    um.fallback_steps = static_cast<long long>(c.fallback_steps);
    um.qp_failures = static_cast<long long>(c.qp_failures);
    um.stale_neighbour_steps = static_cast<long long>(c.stale_neighbour_steps);
    um.messages_rejected = static_cast<long long>(c.messages_rejected);
    um.max_slack_m = u.max_slack_m;
    m.mission_complete = m.mission_complete && um.finished &&
                         um.targets_inspected == um.targets_assigned && (!end || um.end_reached);
    m.uavs.push_back(std::move(um));
  }
  safety_.write(m);
  return std::move(result_);
}

}  // namespace ridgeline::mission
