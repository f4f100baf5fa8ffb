#include "swarm/separation_guard.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace ridgeline::swarm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void require(bool ok, const char* field, const char* reason) {
  if (!ok) throw InputError(std::string("separation_guard.") + field, reason);
}

}  // namespace

void validate(const SeparationGuardOptions& o) {
  require(std::isfinite(o.horizon_s) && o.horizon_s > 0.0, "horizon_s", "must be positive");
  require(std::isfinite(o.step_s) && o.step_s > 0.0 && o.step_s <= o.horizon_s, "step_s",
          "must be positive and at most horizon_s");
  require(std::isfinite(o.trigger_margin_m) && o.trigger_margin_m >= 0.0, "trigger_margin_m",
          "must be finite and non-negative");
  require(std::isfinite(o.comfortable_margin_m) && o.comfortable_margin_m > 0.0,
          "comfortable_margin_m", "must be positive");
  require(std::isfinite(o.release_margin_m) && o.release_margin_m >= o.trigger_margin_m,
          "release_margin_m", "must be finite and at least trigger_margin_m");
  require(std::isfinite(o.switch_margin_m) && o.switch_margin_m >= 0.0, "switch_margin_m",
          "must be finite and non-negative");
  require(std::isfinite(o.priority_horizon_s) && o.priority_horizon_s > 0.0 &&
              o.priority_horizon_s <= o.horizon_s,
          "priority_horizon_s", "must be positive and at most horizon_s");
  require(o.speed_samples >= 2, "speed_samples", "must be at least 2");
  require(o.turn_samples >= 3 && o.turn_samples % 2 == 1, "turn_samples",
          "must be odd and at least 3 (straight flight is a sample)");
  require(o.climb_samples >= 3 && o.climb_samples % 2 == 1, "climb_samples",
          "must be odd and at least 3 (level flight is a sample)");
}

SeparationGuard::SeparationGuard(const SeparationGuardOptions& options,
                                 const vehicle::VehicleParams& vehicle,
                                 const Vec3& max_command_rate)
    : options_(options), vehicle_(vehicle), max_command_rate_(max_command_rate) {
  validate(options_);
  steps_ = std::max(1, static_cast<int>(std::round(options_.horizon_s / options_.step_s)));
  rollout_.reserve(static_cast<std::size_t>(steps_));
  best_path_.reserve(static_cast<std::size_t>(steps_));
  committed_path_.reserve(static_cast<std::size_t>(steps_));
}

template <class NeighbourAt>
double SeparationGuard::worst_margin(std::span<const Vec3> path, double t0, double dt,
                                     const GuardSurroundings& s, NeighbourAt&& neighbour_at) const {
  const world::SafetyLimits& limits = *s.limits;
  const double floor = limits.clearance_floor_m(*s.terrain);
  double margin = kInf;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const Vec3& q = path[k];
    const double t = t0 + static_cast<double>(k) * dt;
    margin = std::min({margin, q.z() - s.terrain->height(q.x(), q.y()) - floor,
                       q.z() - limits.altitude.min_m, limits.altitude.max_m - q.z()});
    for (const world::Threat& threat : s.threats)
      margin = std::min(margin, threat.surface_distance(q, t) - limits.threat_margin_m);
    for (std::size_t n = 0; n < s.neighbours.size(); ++n)
      margin = std::min(margin, (q - neighbour_at(n, k, t)).norm() - limits.separation_m);
  }
  return margin;
}

double SeparationGuard::planned_separation_margin(const GuardInput& in,
                                                  const GuardSurroundings& s) const {
  // A neighbour farther now than two UAVs at full speed can close over the horizon (and the
  // release margin) cannot bind.
  const double d_safe = s.limits->separation_m;
  const double reach = 2.0 * vehicle_.max_speed_m_s() * options_.horizon_s + d_safe +
                       std::max(options_.trigger_margin_m, options_.release_margin_m);
  const Vec3 position = in.state.head<3>();
  double margin = kInf;
  for (std::size_t i = 0; i < s.neighbours.size(); ++i) {
    const PredictedTrajectory& n = *s.neighbours[i];
    if ((messages::expected_position(n, in.t_s) - position).norm() > reach) continue;
    const bool yields = i < s.yields_to_me.size() && s.yields_to_me[i] != 0;
    const double horizon = yields ? options_.priority_horizon_s : options_.horizon_s;
    for (std::size_t k = 0; k < in.planned_path_m.size(); ++k) {
      const double t = in.planned_start_s + static_cast<double>(k) * in.planned_step_s;
      if (t > in.t_s + horizon + 1e-9) break;
      margin = std::min(
          margin, (in.planned_path_m[k] - messages::expected_position(n, t)).norm() - d_safe);
    }
  }
  return margin;
}

double SeparationGuard::held_command_margin(const vehicle::Input& u, const GuardInput& in,
                                            const GuardSurroundings& s) {
  const auto steps = static_cast<std::size_t>(steps_);
  const auto sampled_at = [&](std::size_t n, std::size_t k, double) {
    return neighbour_samples_[n * steps + k];
  };
  vehicle::rollout_positions(in.state, in.last_command, u, max_command_rate_, in.wind_m_s,
                             vehicle_, options_.step_s, steps_, rollout_);
  return worst_margin(rollout_, in.t_s + options_.step_s, options_.step_s, s, sampled_at);
}

GuardDecision SeparationGuard::check(const GuardInput& in, const GuardSurroundings& s) {
  GuardDecision d;
  d.command = in.planned_command;
  if (!options_.enabled || s.neighbours.empty() || in.planned_path_m.empty()) {
    escaping_ = false;
    return d;
  }

  // The trigger and the release: the planned path against the neighbours alone (terrain and
  // threats are the tracker's and the detour's; the guard is for separation).
  const double separation = planned_separation_margin(in, s);
  if (separation >= (escaping_ ? options_.release_margin_m : options_.trigger_margin_m)) {
    escaping_ = false;
    return d;
  }
  d.triggered = true;

  // The neighbours at the guard's times, once for every candidate.
  const std::size_t count = s.neighbours.size();
  const auto steps = static_cast<std::size_t>(steps_);
  neighbour_samples_.resize(count * steps);
  for (std::size_t n = 0; n < count; ++n)
    for (std::size_t k = 0; k < steps; ++k)
      neighbour_samples_[n * steps + k] = messages::expected_position(
          *s.neighbours[n], in.t_s + static_cast<double>(k + 1) * options_.step_s);

  const auto planned_at = [&](std::size_t n, std::size_t, double t) {
    return messages::expected_position(*s.neighbours[n], t);
  };
  std::size_t planned_steps = 0;
  while (planned_steps < in.planned_path_m.size() &&
         in.planned_start_s + static_cast<double>(planned_steps) * in.planned_step_s <=
             in.t_s + options_.horizon_s + 1e-9)
    ++planned_steps;
  d.planned_margin_m = worst_margin(in.planned_path_m.first(planned_steps), in.planned_start_s,
                                    in.planned_step_s, s, planned_at);

  const double v_min = vehicle_.min_speed_m_s(), v_max = vehicle_.max_speed_m_s();
  const double speed = std::max(in.state[vehicle::kV], v_min);
  const double turn_max = vehicle_.max_turn_rate_rad_s(speed);
  // The climb bound that keeps the pitch limit while the speed falls (the tracker's).
  const double climb_max = vehicle_.robust_max_climb_rate_m_s();
  const Vec3 scale(std::max(v_max - v_min, 1e-6), std::max(turn_max, 1e-6), climb_max);
  const double cap = options_.comfortable_margin_m;
  // Among comfortable commands the one closest to what is being flown wins: the plan's, or
  // during an escape the escape's, so an escape changes only when it must.
  const vehicle::Input anchor = escaping_ ? escape_command_ : in.planned_command;
  double best_capped = -kInf, best_distance = kInf;
  const auto consider = [&](const vehicle::Input& u, double margin) {
    const double capped = std::min(margin, cap);
    const double distance = ((u - anchor).cwiseQuotient(scale)).squaredNorm();
    if (capped > best_capped || (capped == best_capped && distance < best_distance)) {
      best_capped = capped;
      best_distance = distance;
      d.command = u;
      d.margin_m = margin;
      best_path_.assign(rollout_.begin(), rollout_.end());
    }
  };
  // The escape under way, held on (its turn bounded at today's speed).
  vehicle::Input committed = escape_command_;
  double committed_margin = -kInf;
  if (escaping_) {
    committed[1] = std::clamp(committed[1], -turn_max, turn_max);
    committed_margin = held_command_margin(committed, in, s);
    committed_path_.assign(rollout_.begin(), rollout_.end());
    consider(committed, committed_margin);
  }
  const double committed_capped = std::min(committed_margin, cap);
  for (int a = 0; a < options_.speed_samples; ++a) {
    const double v = v_min + (v_max - v_min) * a / (options_.speed_samples - 1);
    for (int b = 0; b < options_.turn_samples; ++b) {
      const double w = turn_max * (2.0 * b / (options_.turn_samples - 1) - 1.0);
      for (int c = 0; c < options_.climb_samples; ++c) {
        const double climb = climb_max * (2.0 * c / (options_.climb_samples - 1) - 1.0);
        const vehicle::Input u(v, w, climb);
        consider(u, held_command_margin(u, in, s));
      }
    }
  }
  if (escaping_ && best_capped < committed_capped + options_.switch_margin_m) {
    // Not enough better to give up the escape under way.
    best_capped = committed_capped;
    d.command = committed;
    d.margin_m = committed_margin;
    best_path_.assign(committed_path_.begin(), committed_path_.end());
  }
  // A new escape must beat the plan. Once escaping, the escape goes on until the release: the
  // plan's predicted path assumes commands it will change at the next step (its rows are
  // soft), so a plan that looks better for one step is not one the vehicle would fly.
  const double planned_capped = std::min(d.planned_margin_m, cap);
  if (escaping_ || best_capped > planned_capped) {
    d.escape = true;
    escaping_ = true;
    escape_command_ = d.command;
  } else {
    escaping_ = false;
    d.command = in.planned_command;
    d.margin_m = d.planned_margin_m;
  }
  return d;
}

}  // namespace ridgeline::swarm
