#include "baselines/dwa_agent.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace ridgeline::baselines {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double lattice(double lo, double hi, int i, int n) {
  return n <= 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * i / (n - 1);
}

}  // namespace

DwaAgent::DwaAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
                   const DwaOptions& dwa, std::shared_ptr<const mpc::SampledReference> reference,
                   std::shared_ptr<const world::Terrain> terrain)
    : BaselineAgent(options, limits, std::move(reference), std::move(terrain)), dwa_(dwa) {
  if (!(dwa.dwa_period_s > 0.0 && dwa.horizon_s > 0.0 && dwa.rollout_step_s > 0.0))
    throw InputError("dwa.horizon_s", "period, horizon and step must be positive");
  if (dwa.speed_samples < 1 || dwa.turn_samples < 2 || dwa.climb_samples < 1)
    throw InputError("dwa.turn_samples", "needs at least 1 speed, 2 turn and 1 climb samples");
}

vehicle::Input DwaAgent::compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                                 std::vector<Vec3>& prediction) {
  const BaselineAgentOptions& o = options();
  const vehicle::VehicleParams& vp = o.vehicle;
  if (t_s + 1e-9 >= next_dwa_s_) {
    next_dwa_s_ = t_s + dwa_.dwa_period_s;
    // The speed that keeps the schedule of the timed reference.
    const mpc::ReferencePoint ref = reference().at(std::min(t_s, reference().end_time_s()));
    const double s_ref = path().project(ref.position_m, std::max(0.0, progress_m() - 200.0), 400.0);
    const double v_des =
        std::clamp(ref.speed_m_s + dwa_.along_track_gain_1_s * (s_ref - progress_m()),
                   vp.min_speed_m_s(), vp.max_speed_m_s());
    const int steps =
        std::max(1, static_cast<int>(std::round(dwa_.horizon_s / dwa_.rollout_step_s)));
    const Vec3 goal = path().at(progress_m() + v_des * dwa_.horizon_s);
    const double v_now = std::max(state[vehicle::kV], vp.min_speed_m_s());
    const double turn_max = vp.max_turn_rate_rad_s(v_now);
    const double threat_keep = limits().threat_margin_m + dwa_.threat_clearance_m;
    const double neighbour_keep = limits().separation_m + dwa_.neighbour_clearance_m;

    double best_cost = kInf, best_margin = -kInf;
    vehicle::Input best = last_command(), safest = last_command();
    std::vector<Vec3> rollout_positions, best_rollout, safest_rollout;
    for (int a = 0; a < dwa_.speed_samples; ++a) {
      for (int b = 0; b < dwa_.turn_samples; ++b) {
        for (int c = 0; c < dwa_.climb_samples; ++c) {
          const vehicle::Input u(
              lattice(vp.min_speed_m_s(), vp.max_speed_m_s(), a, dwa_.speed_samples),
              lattice(-turn_max, turn_max, b, dwa_.turn_samples),
              lattice(-vp.max_climb_rate_m_s, vp.max_climb_rate_m_s, c, dwa_.climb_samples));
          rollout(state, last_command(), u, wind_m_s, dwa_.rollout_step_s, steps,
                  rollout_positions);
          // The worst margin of the rollout over every constraint (m; < 0: violated).
          double margin = kInf, obstacle = 0.0, cross = 0.0;
          double s_hint = progress_m();
          for (int k = 0; k < steps; ++k) {
            const Vec3& q = rollout_positions[static_cast<std::size_t>(k)];
            const double tk = t_s + (k + 1) * dwa_.rollout_step_s;
            margin = std::min(margin, clearance_m(q) - limits().terrain_clearance_m);
            margin = std::min(
                {margin, q.z() - limits().altitude.min_m, limits().altitude.max_m - q.z()});
            for (const world::Threat& th : threats()) {
              const double d = (q - th.centre_at(tk)).norm() - th.radius_m;
              margin = std::min(margin, d - threat_keep);
              obstacle += std::max(0.0, dwa_.influence_m - (d - limits().threat_margin_m)) /
                          dwa_.influence_m;
            }
            for (const Neighbour& n : neighbours()) {
              const double d = (q - n.at(tk)).norm();
              margin = std::min(margin, d - neighbour_keep);
              obstacle += std::max(0.0, dwa_.influence_m - d) / dwa_.influence_m;
            }
            if (k % 4 == 3) {
              s_hint = path().project(q, std::max(0.0, s_hint - 5.0), 80.0);
              cross += (path().at(s_hint) - q).norm();
            }
          }
          cross /= std::max(1, steps / 4);
          if (margin > best_margin) {
            best_margin = margin;
            safest = u;
            safest_rollout = rollout_positions;
          }
          if (margin < 0.0) continue;
          const double cost = (rollout_positions.back() - goal).norm() + dwa_.weight_cross * cross +
                              dwa_.weight_speed * std::abs(u[0] - v_des) +
                              dwa_.weight_obstacle * obstacle / steps;
          if (cost < best_cost) {
            best_cost = cost;
            best = u;
            best_rollout = rollout_positions;
          }
        }
      }
    }
    if (best_cost < kInf) {
      chosen_ = best;
      chosen_rollout_ = std::move(best_rollout);
    } else {
      chosen_ = safest;
      chosen_rollout_ = std::move(safest_rollout);
      ++mutable_counters().fallback_steps;
    }
    // Counted as avoidance steps: DWA periods with a sensed threat.
    if (!threats().empty()) ++mutable_counters().replans;
    chosen_at_s_ = t_s;
  }
  // Broadcast: the chosen rollout resampled at the message's step.
  prediction.clear();
  const double dt = dwa_.rollout_step_s;
  for (int k = 1; k <= o.prediction_steps; ++k) {
    const double u = (t_s + k * o.prediction_step_s - chosen_at_s_) / dt - 1.0;
    const int n = static_cast<int>(chosen_rollout_.size());
    if (n == 0) break;
    if (u <= 0.0) {
      prediction.push_back(chosen_rollout_.front());
    } else if (u >= n - 1) {
      const Vec3 v = n >= 2 ? Vec3((chosen_rollout_[static_cast<std::size_t>(n - 1)] -
                                    chosen_rollout_[static_cast<std::size_t>(n - 2)]) /
                                   dt)
                            : Vec3::Zero();
      prediction.push_back(chosen_rollout_.back() + v * (u - (n - 1)) * dt);
    } else {
      const int i = static_cast<int>(u);
      const double f = u - i;
      prediction.push_back(chosen_rollout_[static_cast<std::size_t>(i)] +
                           f * (chosen_rollout_[static_cast<std::size_t>(i + 1)] -
                                chosen_rollout_[static_cast<std::size_t>(i)]));
    }
  }
  return chosen_;
}

}  // namespace ridgeline::baselines
