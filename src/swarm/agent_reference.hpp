// The reference an agent actually tracks: the global plan's r_i(t), possibly delayed and
// locally deformed by the agent's own re-planning (issue "main job", part 3).
//
// Two local changes keep the plan's validated geometry wherever they can:
//  - a delay δ: r(t) = r_plan(t − δ). After a long avoidance manoeuvre the UAV is behind its
//    plan; instead of racing to catch up (or cutting corners across terrain), the agent
//    re-joins the plan at the point nearest to it. The path stays the validated one; only
//    its timing changes, and the MPC's neighbour rows keep the separation the new timing no
//    longer guarantees.
//  - a detour over a window [t_a, t_b] around known moving threats (detour()). Outside the
//    window r is the delayed plan, so the detour joins it continuously.
//  - a level: a vertical offset of the whole reference (set_level()), the separation
//    protocol's way of crossing a neighbour's path above or below it.
//  - a growing delay (set_delay()): the plan flown slower for a while, the separation
//    protocol's way of letting a neighbour pass first. The delay grows at a rate ρ < 1: the
//    reference moves along the plan at (1 − ρ) of its speed meanwhile, and its speed, turn
//    rate and climb rate say so (the tracker's feed-forward).
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>

#include "mpc/reference.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::swarm {

class AgentReference : public mpc::ReferenceTrajectory {
 public:
  explicit AgentReference(std::shared_ptr<const mpc::SampledReference> plan);

  mpc::ReferencePoint at(double t_s) const override;
  /// Equal to at() bit for bit; the plan's look-ups walk on from one another where no detour
  /// lies within the samples' times.
  void sample(double t0_s, double step_s, std::span<mpc::ReferencePoint> out) const override;

  /// The plan's own (undeformed) reference at the agent's time t, with the delay at t.
  mpc::ReferencePoint plan_at(double t_s) const;
  /// The plan at its own time (no delay, detour or level).
  mpc::ReferencePoint plan_point(double plan_time_s) const { return plan_->at(plan_time_s); }
  /// The delay at t: it grows from its value at the last set_delay() toward its target.
  double delay_at(double t_s) const;
  double delay_target_s() const { return delay_target_s_; }
  double delay_rate() const { return delay_rate_; }
  double plan_end_time_s() const { return plan_->end_time_s() + delay_target_s_; }
  double plan_start_time_s() const { return plan_->start_time_s(); }
  /// Grows with every change of the reference's future (level, delay, detour, re-join).
  int revision() const { return revision_; }

  /// Sets the delay so that r(t) is the plan at `plan_time_s` (earlier than now: the plan is
  /// flown again from there), and drops any detour.
  void rewind(double t_s, double plan_time_s);

  /// Lets the delay grow from its value at t to `target_s` (not below it) at `rate` in [0, 1).
  void set_delay(double t_s, double target_s, double rate);
  bool has_detour() const { return detour_.has_value(); }

  /// Re-joins the plan at the point nearest to `position_m` among plan times within
  /// [t − max_back_s, t + max_ahead_s] (plan time, before delay): sets the delay so that
  /// r(t) is that point, and drops any detour. Returns the new delay.
  double rejoin(double t_s, const Vec3& position_m, double max_back_s, double max_ahead_s);

  /// The separation protocol's level (agent.hpp): the whole reference raised (or lowered) by
  /// an offset that moves from its value at t toward `target_m` at `rate_m_s`, so a UAV can
  /// cross another's path above or below it. The detour and the delay apply beneath it.
  void set_level(double t_s, double target_m, double rate_m_s);
  double level_at(double t_s) const;
  double level_target_m() const { return level_target_m_; }

  /// Replaces the detour (or removes it with std::nullopt). The detour must start and end on
  /// the delayed plan (built by plan_detour below).
  void set_detour(std::optional<mpc::SampledReference> detour);

 private:
  /// plan_at's speeds and rates, for the delay δ(t) = delay_s: times 1 − δ̇ while δ grows.
  void slow_down(double t_s, double delay_s, mpc::ReferencePoint& p) const;
  /// at()'s level: the offset at t added to the height, its rate to the climb rate.
  void raise_to_level(double t_s, mpc::ReferencePoint& p) const;

  std::shared_ptr<const mpc::SampledReference> plan_;
  double delay_from_s_ = 0.0;  ///< the delay at delay_since_s_
  double delay_target_s_ = 0.0;
  double delay_since_s_ = 0.0;
  double delay_rate_ = 0.0;
  int revision_ = 0;
  std::optional<mpc::SampledReference> detour_;
  double level_from_m_ = 0.0;    ///< the offset at level_since_s_
  double level_target_m_ = 0.0;
  double level_since_s_ = 0.0;
  double level_rate_m_s_ = 1.0;
};

struct DetourOptions {
  double lookahead_s = 40.0;       ///< window of the check and of the detour
  double sample_step_s = 0.5;      ///< spacing of the detour's samples
  double clearance_m = 15.0;       ///< kept beyond R + r_safe, horizontally
  double lateral_rate_m_s = 4.0;   ///< how fast the offset may grow or shrink (ramps)
  double max_climb_rate_m_s = 3.0;  ///< the detour's climbs stay below this
};

/// Outcome of a local re-plan.
struct DetourResult {
  enum class Status {
    kNoConflict,  ///< the reference already keeps R + r_safe + clearance from every threat
    kPlanned,     ///< `reference` avoids every known threat over the window
    kFailed,      ///< no valid detour (terrain or altitude band); `message` says why
  };
  Status status = Status::kNoConflict;
  std::optional<mpc::SampledReference> reference;
  std::string message;
};

/// A re-approach loop (a racetrack): from `from` (position, heading) a 180° turn of radius
/// `radius_m` toward the side of `entry`, straight back, and a 180° turn the same way that
/// ends at `entry` on its heading, flown at `speed_m_s` from t_s; the altitude moves
/// linearly from the start's to the entry's, raised to h_safe + 5 m above the terrain.
/// Returns nothing when the loop would leave the altitude band.
std::optional<mpc::SampledReference> plan_reapproach_loop(double t_s, const Vec3& from_m,
                                                          double from_heading_rad,
                                                          const mpc::ReferencePoint& entry,
                                                          double radius_m, double speed_m_s,
                                                          const world::Terrain& terrain,
                                                          const world::SafetyLimits& limits);

/// Checks the reference over [t, t + lookahead] against the threats' predicted motion and, on
/// a conflict, builds a detour: each sample is pushed horizontally away from the threat centre
/// at its own time to R + r_safe + clearance, the push is dilated in time so it grows and
/// shrinks at most lateral_rate_m_s (smooth turns in, smooth turns out), raised where the
/// terrain needs it (climb-limited), and checked against the altitude band. A threat is
/// treated as a vertical cylinder (conservative: flying over it is not attempted). r_safe,
/// h_safe and the band are `limits`'.
DetourResult plan_detour(const mpc::ReferenceTrajectory& reference, double t_s,
                         std::span<const world::Threat> threats, const world::Terrain& terrain,
                         const world::SafetyLimits& limits, const DetourOptions& options);

}  // namespace ridgeline::swarm
