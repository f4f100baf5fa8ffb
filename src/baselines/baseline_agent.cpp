#include "baselines/baseline_agent.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.hpp"

namespace ridgeline::baselines {
namespace {

void require(bool ok, const char* field, const char* reason) {
  if (!ok) throw InputError(field, reason);
}

}  // namespace

PathGeometry::PathGeometry(const mpc::SampledReference& reference, double path_step_m) {
  // Sample the reference finely in time and keep points every path_step_m of arc length.
  const double t0 = reference.start_time_s(), t1 = reference.end_time_s();
  Vec3 last = reference.at(t0).position_m;
  points_.push_back(last);
  s_.push_back(0.0);
  const double dt = 0.05;
  for (double t = t0 + dt;; t += dt) {
    const bool end = t >= t1;
    const Vec3 p = reference.at(std::min(t, t1)).position_m;
    const double d = (p - last).norm();
    if (d >= path_step_m || (end && d > 1e-6)) {
      s_.push_back(s_.back() + d);
      points_.push_back(p);
      last = p;
    }
    if (end) break;
  }
  if (points_.size() == 1) {
    points_.push_back(points_.front());
    s_.push_back(1e-6);
  }
}

Vec3 PathGeometry::at(double s_m) const {
  if (s_m <= 0.0) return points_.front();
  if (s_m >= s_.back()) return points_.back();
  const auto it = std::upper_bound(s_.begin(), s_.end(), s_m);
  const std::size_t k = static_cast<std::size_t>(it - s_.begin());
  const double f = (s_m - s_[k - 1]) / std::max(s_[k] - s_[k - 1], 1e-12);
  return points_[k - 1] + f * (points_[k] - points_[k - 1]);
}

double PathGeometry::project(const Vec3& p_m, double s_from_m, double window_m) const {
  const double s_to = std::min(s_.back(), s_from_m + window_m);
  std::size_t k =
      static_cast<std::size_t>(std::upper_bound(s_.begin(), s_.end(), s_from_m) - s_.begin());
  k = k == 0 ? 0 : k - 1;
  double best_s = s_from_m, best_d = (at(s_from_m) - p_m).squaredNorm();
  for (; k + 1 < points_.size() && s_[k] <= s_to; ++k) {
    const Vec3 a = points_[k], b = points_[k + 1];
    const Vec3 ab = b - a;
    const double len2 = ab.squaredNorm();
    const double f = len2 > 0 ? std::clamp((p_m - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double s = std::clamp(s_[k] + f * (s_[k + 1] - s_[k]), s_from_m, s_to);
    const double d = (at(s) - p_m).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best_s = s;
    }
  }
  return best_s;
}

Vec3 BaselineAgent::Neighbour::at(double t_s) const {
  const auto& pts = prediction.positions_m;
  const int n = static_cast<int>(pts.size());
  const double first = prediction.stamp_s + prediction.step_s;
  const double u = (t_s - first) / prediction.step_s;
  if (n == 1 || u <= 0.0) return pts.front();
  const Vec3 velocity = (pts.back() - pts.front()) / (prediction.step_s * (n - 1));
  if (u >= n - 1) return Vec3(pts.back() + velocity * (u - (n - 1)) * prediction.step_s);
  const int k = static_cast<int>(u);
  const double f = u - k;
  return pts[static_cast<std::size_t>(k)] +
         f * (pts[static_cast<std::size_t>(k + 1)] - pts[static_cast<std::size_t>(k)]);
}

BaselineAgent::BaselineAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
                             std::shared_ptr<const mpc::SampledReference> reference,
                             std::shared_ptr<const world::Terrain> terrain)
    : options_(options),
      limits_(limits),
      reference_(std::move(reference)),
      terrain_(std::move(terrain)),
      path_(*reference_) {
  require(options.num_uavs >= 1, "num_uavs", "must be at least 1");
  require(options.id >= 0 && options.id < options.num_uavs, "id", "must be in [0, num_uavs)");
  require(options.control_period_s > 0.0, "control_period_s", "must be positive");
  require(options.prediction_step_s > 0.0 && options.prediction_steps >= 1, "prediction_step_s",
          "step must be positive and steps at least 1");
  require(terrain_ != nullptr, "terrain", "is required");
  require(options.max_command_rate.allFinite() && options.max_command_rate.minCoeff() > 0.0,
          "max_command_rate", "must be positive and finite");
  last_command_ = vehicle::Input(options.vehicle.cruise_speed_m_s, 0.0, 0.0);
  publish_prediction(0.0, {});  // before the first control(): no positions yet
}

void BaselineAgent::receive(const swarm::Envelope& envelope) {
  ++counters_.messages_received;
  if (swarm::check_message(envelope.message(), options_.num_uavs).has_value() ||
      envelope.sender < 0 || envelope.sender >= options_.num_uavs ||
      envelope.sender == options_.id) {
    ++counters_.messages_rejected;
    return;
  }
  // Only positions are shared between UAVs of these methods (issue 6): threat reports of
  // others are not used.
  if (const auto* p = std::get_if<swarm::PredictedTrajectory>(&envelope.message())) {
    if (p->uav != envelope.sender || p->positions_m.empty()) {
      ++counters_.messages_rejected;
      return;
    }
    auto it = neighbours_.find(p->uav);
    if (it != neighbours_.end() && it->second.prediction.stamp_s >= p->stamp_s) return;
    neighbours_[p->uav] = Neighbour{p->uav, *p};
  }
}

void BaselineAgent::sense(double t_s, std::span<const swarm::ThreatObservation> observations,
                          std::vector<swarm::Message>& /*outbox*/) {
  for (const swarm::ThreatObservation& o : observations) {
    world::Threat th;
    th.name = fmt::format("threat{}", o.threat_id);
    th.centre_m = o.centre_m;
    th.velocity_m_s = o.velocity_m_s;
    th.radius_m = o.radius_m;
    th.appear_s = t_s;
    threats_[o.threat_id] = {th, t_s};
  }
}

double BaselineAgent::clearance_m(const Vec3& p_m) const {
  return p_m.z() - terrain_->height(p_m.x(), p_m.y()) - terrain_->model_error_m();
}

void BaselineAgent::update_mission(double t_s, const Vec3& position_m) {
  const int n = static_cast<int>(options_.targets.size());
  while (next_target_ < n) {
    const swarm::AgentTarget& target = options_.targets[static_cast<std::size_t>(next_target_)];
    if ((position_m - target.position_m).norm() > target.radius_m ||
        std::abs(position_m.z() - target.position_m.z()) > target.altitude_band_m)
      break;
    ++next_target_;
  }
  if (next_target_ == n) {
    if ((n > 0 && !options_.fly_to_end) || t_s >= reference_->end_time_s()) finished_ = true;
    return;
  }
  if (t_s > reference_->end_time_s() + options_.missed_after_s) {
    for (int k = next_target_; k < n; ++k)
      missed_.push_back(options_.targets[static_cast<std::size_t>(k)].name);
    finished_ = true;
  }
}

void BaselineAgent::rollout(const vehicle::State& state, const vehicle::Input& from,
                            const vehicle::Input& target, const Vec3& wind_m_s, double step_s,
                            int steps, std::vector<Vec3>& positions) const {
  vehicle::rollout_positions(state, from, target, options_.max_command_rate, wind_m_s,
                             options_.vehicle, step_s, steps, positions);
}

swarm::AgentStep BaselineAgent::control(double t_s, const vehicle::State& measured,
                                        const Vec3& measured_wind_m_s) {
  swarm::AgentStep out;
  const Vec3 position = measured.head<3>();
  if (last_control_s_ < 0.0) {
    wind_estimate_ = measured_wind_m_s;
  } else {
    const double dt = t_s - last_control_s_;
    wind_estimate_ +=
        dt / (options_.wind_filter_time_s + dt) * (measured_wind_m_s - wind_estimate_);
  }
  last_control_s_ = t_s;
  if (!finished_) update_mission(t_s, position);
  if (finished_) {
    out.mode = swarm::AgentMode::kFinished;
    out.reference_m = position;
    publish_prediction(
        t_s, std::vector<Vec3>(static_cast<std::size_t>(options_.prediction_steps), position));
    return out;
  }
  const auto start = std::chrono::steady_clock::now();
  // Progress along the path: never backwards, a window ahead wide enough for any step.
  progress_m_ = path_.project(position, std::max(0.0, progress_m_ - 5.0), 120.0);
  threat_list_.clear();
  for (auto it = threats_.begin(); it != threats_.end();) {
    if (t_s - it->second.second > options_.threat_forget_s) {
      it = threats_.erase(it);
    } else {
      threat_list_.push_back(it->second.first);
      ++it;
    }
  }
  neighbour_list_.clear();
  for (const auto& [id, n] : neighbours_) neighbour_list_.push_back(n);

  std::vector<Vec3> predicted;
  vehicle::Input u = compute(t_s, measured, wind_estimate_, predicted);
  // The same command-rate limits per control period as the proposed tracker, and eq. 2–3.
  const Vec3 max_change = options_.max_command_rate * options_.control_period_s;
  for (int i = 0; i < 3; ++i)
    u[i] = std::clamp(u[i], last_command_[i] - max_change[i], last_command_[i] + max_change[i]);
  u = vehicle::clamp_to_limits(u, measured, options_.vehicle);
  last_command_ = u;
  out.command = u;
  out.mode = swarm::AgentMode::kTracking;
  out.reference_m = reference_->at(std::min(t_s, reference_->end_time_s())).position_m;
  out.step_time_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  if (predicted.empty())
    predicted.assign(static_cast<std::size_t>(options_.prediction_steps), position);
  publish_prediction(t_s, std::move(predicted));
  return out;
}

void BaselineAgent::publish_prediction(double t_s, std::vector<Vec3> positions) {
  swarm::PredictedTrajectory p;
  p.uav = options_.id;
  p.stamp_s = t_s;
  p.step_s = options_.prediction_step_s;
  p.positions_m = std::move(positions);
  prediction_ = std::make_shared<const swarm::Message>(std::move(p));
}

}  // namespace ridgeline::baselines
