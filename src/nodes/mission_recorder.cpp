#include "nodes/mission_recorder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/statistics.hpp"

namespace ridgeline::nodes {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTrackingSampleSpacingM = 10.0;  // DESIGN §6: every 10 m of flown path

}  // namespace

MissionRecorder::MissionRecorder(const sim::Scenario& scenario,
                                 std::shared_ptr<const world::Terrain> terrain,
                                 const sim::TruthWorld& world, bool record_trajectories)
    : scenario_(scenario),
      terrain_(std::move(terrain)),
      record_(record_trajectories),
      safety_(scenario.safety, static_cast<int>(scenario.uavs.size()), *terrain_),
      min_turn_radius_(kInf) {
  const int n = world.num_uavs();
  tally_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    tally_[static_cast<std::size_t>(i)].last_position = world.true_position(i);
  for (const char* kind : {"altitude", "pitch", "turn"})
    result_.metrics.constraint_violations[kind] = 0;
}

void MissionRecorder::sensed(int uav, int threat) { safety_.sensed(uav, threat); }

void MissionRecorder::path_and_constraints(int i, double t, const sim::TruthWorld& world,
                                           bool finished, const Vec3& reference_m,
                                           const vehicle::Input* command) {
  sim::MissionMetrics& m = result_.metrics;
  UavTally& u = tally_[static_cast<std::size_t>(i)];
  const vehicle::State& s = world.true_state(i);
  const Vec3 p = s.head<3>();
  u.path_m += (p - u.last_position).norm();
  u.last_position = p;
  if (!finished && command != nullptr && u.path_m >= u.next_sample_m) {
    u.squared_error_sum += (p - reference_m).squaredNorm();
    ++u.samples;
    u.next_sample_m += kTrackingSampleSpacingM;
  }
  if (!world.holding(i)) {
    const vehicle::VehicleParams& vp = scenario_.uavs[static_cast<std::size_t>(i)].vehicle;
    if (p.z() < scenario_.safety.altitude.min_m || p.z() > scenario_.safety.altitude.max_m)
      ++m.constraint_violations["altitude"];
    if (std::abs(vehicle::pitch_angle_rad(s)) > vp.max_pitch_rad + 1e-3)
      ++m.constraint_violations["pitch"];
    // Eq. 3 bounds the command at the speed the vehicle has when it is issued.
    if (!finished && command != nullptr) {
      const double limit = vp.max_turn_rate_rad_s(s[vehicle::kV]);
      const double ratio = std::abs((*command)[1]) / limit;
      m.max_turn_command_ratio = std::max(m.max_turn_command_ratio, ratio);
      if (ratio > 1.0 + 1e-6) ++m.constraint_violations["turn"];
    }
    if (std::abs(s[vehicle::kOmega]) > 1e-9)
      min_turn_radius_ = std::min(min_turn_radius_, s[vehicle::kV] / std::abs(s[vehicle::kOmega]));
  }
  if (record_) {
    result_.trajectories.push_back({t, i, p, finished || command == nullptr ? p : reference_m,
                                    s[vehicle::kV], s[vehicle::kPsi], s[vehicle::kW]});
  }
}

void MissionRecorder::answered(int i, double t, const transport_dds::CommandReport& a,
                               const sim::TruthWorld& world) {
  const bool finished = a.mode == swarm::AgentMode::kFinished;
  if (!finished) {
    if (a.has_tracker) {
      step_us_.push_back(a.mpc_step_us);
      iterations_.push_back(a.qp_iterations);
    }
    UavTally& u = tally_[static_cast<std::size_t>(i)];
    u.max_slack_m = std::max(u.max_slack_m, a.max_slack_m);
  }
  path_and_constraints(i, t, world, finished, a.reference_m, &a.command);
}

void MissionRecorder::unanswered(int i, double t, const sim::TruthWorld& world) {
  path_and_constraints(i, t, world, false, Vec3::Zero(), nullptr);
}

void MissionRecorder::tick(double t, const sim::TruthWorld& world) { safety_.sample(t, world); }

sim::MissionResult MissionRecorder::finish(double t,
                                           const std::vector<transport_dds::CommandReport>& last,
                                           const std::vector<double>& finish_time_s) {
  sim::MissionMetrics& m = result_.metrics;
  m.sim_time_s = t;
  m.min_turn_radius_m = min_turn_radius_;
  m.mpc_solve_us = sim::percentiles(step_us_);
  m.qp_iterations = sim::percentiles(iterations_);
  m.mission_complete = true;
  for (std::size_t i = 0; i < tally_.size(); ++i) {
    const transport_dds::CommandReport& a = last[i];
    const UavTally& u = tally_[i];
    sim::UavMetrics um;
    um.name = scenario_.uavs[i].name;
    um.path_length_m = u.path_m;
    um.tracking_samples = u.samples;
    um.tracking_mse_m2 = u.samples > 0 ? u.squared_error_sum / u.samples : 0.0;
    um.tracking_rmse_m = std::sqrt(um.tracking_mse_m2);
    um.targets_assigned = a.targets_assigned;
    um.targets_inspected = a.targets_inspected;
    um.missed_targets = a.missed_targets;
    um.finished = finish_time_s[i] >= 0.0;
    um.finish_time_s = finish_time_s[i];
    const swarm::AgentCounters& c = a.counters;
    um.replans = static_cast<long long>(c.replans);
    um.neighbour_conflicts = static_cast<long long>(c.neighbour_conflicts);
    um.replan_failures = static_cast<long long>(c.replan_failures);
    um.rejoins = static_cast<long long>(c.rejoins);
    um.fallback_steps = static_cast<long long>(c.fallback_steps);
    um.qp_failures = static_cast<long long>(c.qp_failures);
    um.stale_neighbour_steps = static_cast<long long>(c.stale_neighbour_steps);
    um.messages_rejected = static_cast<long long>(c.messages_rejected);
    um.max_slack_m = u.max_slack_m;
    m.mission_complete =
        m.mission_complete && um.finished && um.targets_inspected == um.targets_assigned;
    m.uavs.push_back(std::move(um));
  }
  safety_.write(m);
  return std::move(result_);
}

}  // namespace ridgeline::nodes
