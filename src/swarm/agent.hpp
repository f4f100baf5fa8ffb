// One UAV's on-board agent (DESIGN §1, issue "main job", parts 3–4). It knows its own
// measurements and what arrives as messages; never another agent's memory.
//
// Every control period (50 Hz) control():
//  0. state estimate: the position fix is noisy (0.1 m), and the incremental MPC differences
//     positions over one prediction step (0.1 s), which would turn that noise into ~1.4 m/s of
//     velocity noise — and ~20 interior-point iterations instead of ~5. A fixed-gain observer
//     predicts the position with the controller's model (applied command, measured wind) and
//     corrects it by position_filter_gain·(fix − prediction); the other states are taken as
//     measured. Gain g leaves sqrt(g/(2−g)) of the noise (0.02: a tenth, 1 cm) with a bias of
//     (1−g)/g times one step's model error (~0.6 mm, so ~3 cm). Measured on the default
//     terrain with one UAV: interior-point iterations median 10 → 3 (gain 0.2: 8; 0.05: 4),
//     MPC step 740 → 280 µs; tracking RMSE 0.17 → 0.21 m.
//     An innovation above position_reset_m restarts from the fix.
//     The anemometer is low-passed with time constant wind_filter_time_s: the tracker feeds
//     the wind's change over a prediction step forward, and differencing raw readings (0.2 m/s
//     noise) made that term noise — measured: median 10 interior-point iterations against 8
//     with a noiseless anemometer. Gusts are correlated over seconds, so a 0.5 s lag costs
//     little, and the tracker's robust margin covers the wind error.
//  1. mission: the next target counts as inspected when the UAV passes within its radius and
//     altitude band; after the last one, and once the reference has ended, the agent is
//     finished (it holds — the default team are multirotors) — but not while a known threat
//     is predicted to pass its hold point within finish_threat_guard_s: a hovering UAV cannot
//     dodge (measured: a threat crossing a finished UAV's hold point was the only intrusion of
//     the proposed method in the experiment, task "crossing", seed 4200005). Targets still open
//     `missed_after_s` after the plan's end are reported as missed, never silently skipped.
//  2. local re-plan (at most every replan_period_s, and at once when a threat becomes known):
//     the reference is checked against every known threat's predicted motion over the
//     look-ahead and, on a conflict, replaced by a detour (agent_reference.hpp). When the UAV
//     has fallen more than rejoin_distance_m behind its reference (after an avoidance), it
//     re-joins the plan at the nearest point (a delay, same validated path).
//     Neighbour conflicts are re-planned the same way: a neighbour whose broadcast prediction,
//     extrapolated at its mean velocity over neighbour_lookahead_s, comes within
//     d_safe + neighbour_conflict_margin_m of this UAV's reference at equal times is a moving
//     obstacle (radius d_safe) for the detour — but only for the UAV that yields: the one with
//     the higher id, or either one when the other is (nearly) stationary, e.g. finished and
//     holding. One rule known to all avoids two UAVs swerving into each other; the MPC's
//     neighbour rows keep d_safe in any case.
//     Before the detour, the separation protocol's slot (choose_slot, README "Separation in
//     dense teams"): every prediction carries its sender's intent (where its reference will
//     be every second over the look-ahead, its level and delay included); the UAV that
//     yields gives its own reference a level (a vertical offset) and a delay (the plan flown
//     later, slower meanwhile) such that, checked at equal times with the ramps, no intent of
//     a neighbour it yields to comes within d_safe + the conflict margin horizontally while
//     less than a level apart vertically. It keeps a free slot (the others plan around it),
//     takes the cheapest free one otherwise, and re-checks at once when such a neighbour's
//     intent moves. A neighbour a free slot clears needs no detour.
//  3. tracking: the MPC tracker with the known threats, the neighbours' broadcast predictions
//     and the terrain as soft constraints.
//  4. separation guard (separation_guard.hpp): the command about to be flown (the tracker's or
//     the fallback's) is rolled out and checked against the neighbours' expected positions;
//     when it comes within d_safe + a trigger margin of one, the held command with the
//     largest worst margin (neighbours, terrain, band, threats) is flown instead, and its
//     rollout is broadcast.
//  5. safe fallback: when the QP is not solved for fallback_after_failures consecutive steps,
//     or the reference is lost (farther than lost_reference_m even after re-joining), the
//     agent slows to the band's lower end, turns toward its reference and climbs while the
//     terrain clearance is below 2·h_safe (never above H_max); it returns to tracking once
//     the QP has been solved again for recover_after_successes steps.
// Messages: every broadcast period (10 ms) the latest prediction as PredictedTrajectory; a
// ThreatReport when a threat is first sensed and then every threat_report_period_s while it is
// sensed. Received messages are checked (check_message) and rejected ones counted. A
// neighbour's prediction older than neighbour_stale_s is still used — extrapolated at its last
// velocity — and counted as stale: forgetting a neighbour is never safer than a stale guess.
// A threat not confirmed (sensed or reported) for threat_forget_s is dropped.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mpc/uav_tracker.hpp"
#include "planning/local_replan.hpp"
#include "swarm/agent_reference.hpp"
#include "swarm/messages.hpp"
#include "swarm/separation_guard.hpp"
#include "swarm/uav_agent.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::swarm {

struct AgentOptions {
  int id = 0;
  int num_uavs = 1;
  mpc::UavTrackerOptions tracker;
  DetourOptions detour;
  std::vector<AgentTarget> targets;  ///< this UAV's, in visiting order
  /// The plan ends at the UAV's end position (return home, a landing point) after its last
  /// target: the agent finishes only once it has flown the reference to its end.
  bool fly_to_end = false;
  /// The end counts as reached this close (> 0; set from mission::end_reached_radius_m(), as
  /// the flight recorder judges it).
  double end_radius_m = 30.0;
  double broadcast_period_s = 0.01;
  double threat_report_period_s = 1.0;
  double neighbour_stale_s = 1.0;
  double threat_forget_s = 10.0;
  double replan_period_s = 1.0;
  double neighbour_lookahead_s = 8.0;      ///< > 0; how far a neighbour's motion is extrapolated
  double neighbour_conflict_margin_m = 10.0;  ///< ≥ 0, added to d_safe for the conflict test
  /// The separation protocol's margins (file comment): the MPC rows against a neighbour this
  /// UAV yields to keep d_safe + separation_margin_m + min(age_margin_m_s·age,
  /// max_age_margin_m), with `age` the age of that neighbour's newest prediction.
  double separation_margin_m = 4.0;
  /// Slots (README "Separation in dense teams"): a UAV that yields to neighbours whose
  /// intents (or predictions) cross its reference horizontally (within d_safe +
  /// neighbour_conflict_margin_m) within level_lookahead_s, less than a level apart, gives its
  /// reference a slot none of them occupies there: a level (the whole reference moved up or
  /// down by a multiple of level_spacing_m, at most max_levels each way, inside the altitude
  /// band, h_safe + level_terrain_margin_m above the terrain and inside the altitude band of
  /// every target it passes) and a delay (the plan flown later by up to max_delay_s more, in
  /// steps of delay_step_s, the delay growing at delay_rate: the plan at (1 − rate) of its
  /// speed meanwhile). A level step costs as much as delay_per_level_s of delay.
  double level_spacing_m = 15.0;
  double level_lookahead_s = 40.0;
  int max_levels = 4;
  double level_terrain_margin_m = 10.0;
  double max_delay_s = 30.0;      ///< ≥ 0; 0 turns delays off
  double delay_step_s = 2.0;      ///< > 0
  double delay_rate = 0.4;        ///< in (0, 1): 10 m/s flown at 6 m/s, above v_min
  double delay_per_level_s = 3.0;  ///< > 0
  /// The intent broadcast with every prediction: the reference every intent_step_s over
  /// level_lookahead_s (and one step more, so it still covers it when a step old).
  double intent_step_s = 1.0;
  /// A higher-priority neighbour's new intent re-plans at once, but not more often than this.
  double min_replan_interval_s = 0.2;
  double age_margin_m_s = 5.0;
  double max_age_margin_m = 10.0;
  double rejoin_distance_m = 40.0;
  double lost_reference_m = 120.0;
  double missed_after_s = 30.0;
  /// A blocked target is not given up: when the reference has gone reapproach_after_s past a
  /// target's pass (the plan's closest approach to it) and the target is still open, the UAV
  /// flies a racetrack (two 180° turns at half its turn rate) back onto the plan
  /// reapproach_lead_s before the pass and flies the plan again from there, at most
  /// max_reapproaches times a target, while the mission's time lasts.
  double reapproach_after_s = 3.0;
  double reapproach_lead_s = 5.0;
  int max_reapproaches = 3;
  /// A UAV that has inspected its last target holds (hovers) only once no known threat is
  /// predicted to come within R + r_safe + detour clearance of it within this time; until
  /// then it keeps tracking, so its detour re-plan can take it out of the threat's way.
  double finish_threat_guard_s = 60.0;
  double position_filter_gain = 0.02;  ///< in (0, 1]; 1 uses the raw fix
  double position_reset_m = 10.0;     ///< innovation beyond which the estimate restarts
  double wind_filter_time_s = 0.5;    ///< ≥ 0; 0 uses the raw anemometer
  int fallback_after_failures = 5;
  int recover_after_successes = 10;
  /// The last line of the protocol (separation_guard.hpp): the path about to be flown is
  /// checked against the neighbours every step and, when it comes too close, the safest held
  /// command is flown instead.
  SeparationGuardOptions separation_guard;
  /// Re-plan a conflict with the local optimizer (planning/local_replan.hpp: the window
  /// re-optimized against the known threats and the neighbour conflicts, densely validated)
  /// instead of the geometric detour; the detour stays the fallback when the optimizer finds
  /// no valid window. Off by default: an optimizer re-plan costs tens of milliseconds.
  bool optimizer_replan = false;
  /// Its options. The window is detour.lookahead_s; the limits are the agent's. The threats (and
  /// neighbours, which enter as moving spheres) are avoided within ±threat_time_margin_s of their
  /// predicted times: a neighbour's sweep over the whole window would lie along its route.
  planning::LocalReplanOptions local_replan = default_local_replan();

  static planning::LocalReplanOptions default_local_replan() {
    planning::LocalReplanOptions o;
    o.threat_time_margin_s = 2.0;
    return o;
  }
};

/// How far a neighbour may be and still enter the MPC (before its age's v_max·age): two UAVs
/// farther apart cannot come within a row's activation distance of d_safe (plus every
/// margin) within the horizon, whatever either does. Also the transport's reach
/// (prediction_reach.hpp).
double mpc_neighbour_reach_m(const AgentOptions& options, const world::SafetyLimits& limits);

class Agent final : public UavAgent {
 public:
  /// `plan` is this UAV's reference from the global planner; `limits` the mission's (the
  /// tracker's soft rows, the detour, the local re-plan, the fallback's climb). Throws
  /// InputError for invalid options (names the field) or limits.
  Agent(const AgentOptions& options, const world::SafetyLimits& limits,
        std::shared_ptr<const mpc::SampledReference> plan,
        std::shared_ptr<const world::Terrain> terrain);

  int id() const override { return options_.id; }

  /// A message from the transport. Invalid ones are counted and ignored.
  void receive(const Envelope& envelope) override;

  /// The agent's own sensing at t; appends the ThreatReports to broadcast to `outbox`.
  void sense(double t_s, std::span<const ThreatObservation> observations,
             std::vector<Message>& outbox) override;

  /// One control period at t with the measured state and wind.
  AgentStep control(double t_s, const vehicle::State& measured_state,
                    const Vec3& measured_wind_m_s) override;

  std::shared_ptr<const Message> prediction_message() const override { return prediction_; }

  AgentMode mode() const { return mode_; }
  bool finished() const override { return mode_ == AgentMode::kFinished; }
  int targets_inspected() const override { return next_target_; }
  /// Names of targets declared missed (open when the plan ended + missed_after_s).
  const std::vector<std::string>& missed_targets() const override { return missed_; }
  const AgentCounters& counters() const override { return counters_; }
  const AgentReference& reference() const { return *reference_; }
  /// Threats the agent knows now (own sensing and reports).
  std::vector<world::Threat> known_threats() const;

 private:
  struct KnownThreat {
    world::Threat threat;
    double confirmed_s = 0.0;     ///< last time sensed or reported
    double last_reported_s = -1e9;  ///< last time this agent broadcast it
  };
  struct KnownNeighbour {
    std::shared_ptr<const Message> message;  ///< the newest received, as broadcast (shared)
    const PredictedTrajectory& prediction() const {
      return std::get<PredictedTrajectory>(*message);
    }
  };

  void update_mission(double t_s, const Vec3& position_m);
  /// True when a known threat's predicted centre comes within R + r_safe + detour clearance
  /// of `position_m` during [t, t + finish_threat_guard_s].
  bool hold_point_threatened(double t_s, const Vec3& position_m) const;
  void replan(double t_s, const Vec3& position_m);
  /// Rewinds the reference when the next target was passed without being inspected.
  void reapproach_blocked_target(double t_s);
  /// The separation protocol's slot: level and delay (AgentOptions::level_spacing_m).
  /// Returns whether the slot changed.
  bool choose_slot(double t_s, const Vec3& position_m);
  /// The intent broadcast with the prediction (PredictedTrajectory::intent_m).
  void update_intent(double t_s);
  /// Neighbours this UAV must yield to, as moving obstacles (appended to `obstacles`).
  int add_neighbour_conflicts(double t_s, std::vector<world::Threat>& obstacles) const;
  /// The separation protocol's priority: this UAV yields to a neighbour with a lower id, and
  /// to a (nearly) stationary one.
  bool yields_to(int neighbour, const PredictedTrajectory& prediction) const;
  /// The neighbours whose rows enter the MPC this step: those within reach, nearest first, up
  /// to the tracker's capacity, each with the distance its rows keep.
  void select_neighbours(double t_s, const Vec3& position_m);
  vehicle::Input fallback_command(double t_s, const vehicle::State& state) const;
  /// `target` moved from the last command at most one control period's command rates, then
  /// clamped into the limits at `state`: what may be flown this step.
  vehicle::Input rate_limited(const vehicle::Input& target, const vehicle::State& state) const;
  /// The positions the agent will fly: positions[k] at first_time_s + k·step_s.
  struct FlownPath {
    const std::vector<Vec3>* positions = nullptr;
    double first_time_s = 0.0;
    double step_s = 0.0;
  };
  /// Runs the separation guard on the command about to be flown (the tracker's, or the
  /// fallback's); returns the command to fly and sets `path` to what will be flown (the
  /// tracker's prediction, the fallback's or the escape's rollout), which is broadcast.
  vehicle::Input guard_command(double t_s, const vehicle::State& state,
                               const vehicle::Input& planned, const mpc::UavTrackerResult& r,
                               FlownPath& path);
  void forget_old_threats(double t_s);

  AgentOptions options_;
  world::SafetyLimits limits_;
  std::shared_ptr<const world::Terrain> terrain_;
  std::shared_ptr<AgentReference> reference_;
  mpc::UavTracker tracker_;
  Vec3 command_rate_;  ///< the tracker's |v̇_c|, |ω̇_c|, |ẇ_c|, which every command obeys
  SeparationGuard guard_;
  std::vector<Vec3> planned_path_;  ///< the path the guard checks (tracker's or fallback's)
  std::map<int, KnownThreat> threats_;
  std::map<int, KnownNeighbour> neighbours_;
  std::vector<world::Threat> threat_buffer_;
  std::vector<PredictedTrajectory> neighbour_buffer_;  ///< the MPC's neighbours, nearest first
  std::vector<double> neighbour_separation_;          ///< the distance each one's rows keep
  std::vector<std::pair<double, int>> nearby_;        ///< (distance now, id) within reach
  std::vector<const PredictedTrajectory*> guard_neighbours_;  ///< every one within reach
  std::vector<char> guard_yields_to_me_;  ///< per guard neighbour: it yields to this UAV
  // choose_slot's work space: candidate levels and added delays, the yielded-to neighbours'
  // expected positions per sample, each candidate's earliest conflict time and feasibility.
  std::vector<double> levels_;
  std::vector<double> delays_;
  std::vector<Vec3> yielded_positions_;
  std::vector<double> conflict_time_;
  std::vector<char> feasible_;
  std::vector<Vec3> intent_;
  double intent_start_s_ = -1e9;
  int intent_revision_ = -1;
  bool neighbour_replan_requested_ = false;
  double last_slot_check_s_ = -1e9;
  AgentMode mode_ = AgentMode::kTracking;
  int next_target_ = 0;
  std::vector<std::string> missed_;
  std::vector<double> target_pass_s_;  ///< plan time of the plan's closest approach, per target
  std::vector<int> reapproaches_;      ///< per target
  double reapproach_until_s_ = -1e9;   ///< the end of a re-approach loop being flown
  int consecutive_failures_ = 0;
  int consecutive_successes_ = 0;
  double last_replan_s_ = -1e9;
  bool replan_requested_ = true;
  vehicle::Input last_command_ = vehicle::Input::Zero();
  std::shared_ptr<const Message> prediction_;  ///< a PredictedTrajectory, never null
  AgentCounters counters_;
  std::optional<vehicle::State> estimate_;
  Vec3 wind_estimate_ = Vec3::Zero();
  double estimate_time_s_ = 0.0;
};

}  // namespace ridgeline::swarm
