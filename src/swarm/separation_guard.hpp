// The separation guard: the last line of the separation protocol (agent.hpp, README
// "Separation in dense teams").
//
// Slots, detours and the MPC's neighbour rows keep UAVs apart in the plan; none of them can
// promise it when the rows are outweighed (no free slot, a failed QP, a reference far away, a
// neighbour that changed its mind and whose new prediction is late). So every control step the
// path the agent is about to fly (the MPC's prediction, or the fallback command's rollout) is
// checked against every neighbour within reach (its expected position) at equal times
// (messages::expected_position: its prediction, then its intent) over the guard's horizon.
// When it comes within d_safe + trigger_margin_m of one, the guard scores held commands —
// a lattice of speed × turn rate × climb rate, each reached from the last command at the
// tracker's command-rate limits and rolled out with the Euler model and the wind estimate —
// by their worst margin over the horizon against
//   every neighbour (distance − d_safe), the terrain (clearance − h_safe − model error),
//   the altitude band and every known threat (surface distance − r_safe),
// and the agent flies the best one instead when it beats the path's own worst margin: the
// largest margin up to comfortable_margin_m, then the command closest to the one it replaces.
// The chosen rollout is broadcast as the prediction, so the neighbours see the escape at once.
// An escape is a commitment: it is flown until the plan clears every neighbour by
// release_margin_m, and replaced by another held command only when that one is better by
// switch_margin_m. So what the neighbours were told holds while they learn of it, and the
// vehicle does not alternate between the plan and an escape, or a left and a right turn, from
// one step to the next (each cancelling the other under the rate limits).
#pragma once

#include <span>
#include <vector>

#include "core/types.hpp"
#include "swarm/messages.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::swarm {

struct SeparationGuardOptions {
  bool enabled = true;
  double horizon_s = 4.0;  ///< > 0: how far paths are checked and commands rolled out
  double step_s = 0.1;     ///< > 0, ≤ horizon_s
  /// The path is checked against d_safe + trigger_margin_m (≥ 0).
  double trigger_margin_m = 1.0;
  /// Margins above this (> 0) count as equal; the closest command to the replaced one wins.
  double comfortable_margin_m = 3.0;
  /// An escape, once begun, is flown until the planned path clears every neighbour by
  /// d_safe + release_margin_m (≥ trigger_margin_m). Without this, the plan and the escape
  /// alternate from step to step (each clears the other's conflict for one period) and the
  /// rate-limited vehicle flies neither.
  double release_margin_m = 3.0;
  /// During an escape, another held command replaces the escape's only when its margin
  /// (capped at comfortable_margin_m) is larger by this much (≥ 0): a turn left and a turn
  /// right of nearly equal margins must not alternate.
  double switch_margin_m = 1.0;
  /// A neighbour that yields to this UAV triggers the guard only for a conflict closer in
  /// time than this (> 0, ≤ horizon_s): two guards escaping from each other at once, each on
  /// the other's delayed broadcast, chose the same way out (both climbing, then both
  /// descending) and came closer than either alone would have.
  double priority_horizon_s = 2.0;
  int speed_samples = 3;  ///< ≥ 2: v_min … v_max
  int turn_samples = 5;   ///< ≥ 3, odd: −ω_max … ω_max
  int climb_samples = 3;  ///< ≥ 3, odd: −w_max … w_max
};

/// Throws InputError naming the field (`separation_guard.horizon_s`, ...).
void validate(const SeparationGuardOptions& options);

/// What the guard checks against, at the current control step.
struct GuardSurroundings {
  /// Every neighbour within reach (not only the MPC's nearest max_neighbours: at a crowded
  /// crossing the ninth can be the one that closes fastest).
  std::span<const PredictedTrajectory* const> neighbours;
  /// Per neighbour, whether it yields to this UAV (the priority order). Empty: none does.
  /// Such a neighbour triggers the guard only for a conflict within priority_horizon_s: the
  /// escaping is its job, and a UAV of higher priority that keeps its plan keeps its broadcast
  /// true for it. Every neighbour counts in an escape's score, over the whole horizon.
  std::span<const char> yields_to_me;
  std::span<const world::Threat> threats;
  const world::Terrain* terrain = nullptr;
  const world::SafetyLimits* limits = nullptr;
};

/// The agent's own motion at the current step and the path it intends to fly.
struct GuardInput {
  double t_s = 0.0;
  vehicle::State state = vehicle::State::Zero();
  vehicle::Input last_command = vehicle::Input::Zero();  ///< applied until now
  vehicle::Input planned_command = vehicle::Input::Zero();
  Vec3 wind_m_s = Vec3::Zero();
  /// Positions the planned command leads to, at planned_start_s + k·planned_step_s.
  std::span<const Vec3> planned_path_m;
  double planned_start_s = 0.0;
  double planned_step_s = 0.1;
};

struct GuardDecision {
  bool triggered = false;  ///< the planned path came within d_safe + trigger_margin_m
  bool escape = false;  ///< fly `command` instead of the planned one
  vehicle::Input command = vehicle::Input::Zero();
  double planned_margin_m = 0.0;  ///< the planned path's worst margin (all constraints)
  double margin_m = 0.0;          ///< the flown command's worst margin
};

class SeparationGuard {
 public:
  /// `max_command_rate`: the tracker's |v̇_c|, |ω̇_c|, |ẇ_c|. Throws InputError for invalid
  /// options.
  SeparationGuard(const SeparationGuardOptions& options, const vehicle::VehicleParams& vehicle,
                  const Vec3& max_command_rate);

  const SeparationGuardOptions& options() const { return options_; }

  /// The decision for this step. Allocation-free once warm.
  GuardDecision check(const GuardInput& input, const GuardSurroundings& surroundings);

  /// The escape's positions at t_s + (k+1)·step_s (valid after a check that escaped).
  const std::vector<Vec3>& escape_path() const { return best_path_; }

  /// Whether an escape is under way (the last check escaped and has not been released).
  bool escaping() const { return escaping_; }

 private:
  /// Worst margin of positions at t0 + k·dt (k from 0) over every constraint; the neighbours'
  /// positions are sampled by `neighbour_at`.
  /// The planned path's smallest distance to a neighbour within reach, minus d_safe, over
  /// the horizon.
  double planned_separation_margin(const GuardInput& input, const GuardSurroundings& s) const;

  /// Worst margin of the held command `u` rolled out from the input's state (fills rollout_).
  double held_command_margin(const vehicle::Input& u, const GuardInput& input,
                             const GuardSurroundings& s);

  template <class NeighbourAt>
  double worst_margin(std::span<const Vec3> path, double t0, double dt, const GuardSurroundings& s,
                      NeighbourAt&& neighbour_at) const;

  SeparationGuardOptions options_;
  vehicle::VehicleParams vehicle_;
  Vec3 max_command_rate_;
  int steps_ = 0;
  bool escaping_ = false;
  vehicle::Input escape_command_ = vehicle::Input::Zero();  ///< the escape being flown
  std::vector<Vec3> neighbour_samples_;  ///< neighbours × steps, at the guard's times
  std::vector<Vec3> rollout_;
  std::vector<Vec3> best_path_;
  std::vector<Vec3> committed_path_;  ///< the escape under way's rollout, while others are tried
};

}  // namespace ridgeline::swarm
