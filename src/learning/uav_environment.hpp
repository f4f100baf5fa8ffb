// The reinforcement-learning environment of the DDPG comparison method (paper ref. [8],
// issue 11): one UAV flies to one target over terrain, through sudden moving threats, in
// wind. It is built on the project's own models, not a copy of them: the truth dynamics are
// vehicle::rk4_step with the truth's lags (time_constant_scale × the controller's τ, as
// mission::TruthWorld does), the wind is world::WindField read through a noisy
// world::WindSensor, the terrain a world::PeakTerrain drawn by world::random_peaks, the
// threats world::Threat spheres (eq. 13) sensed within the sensor range.
//
// Time. The policy acts every action_period_s (0.4 s); between decisions the command is
// applied as every on-board method applies it: every control_period_s (20 ms) it moves
// towards the policy's command by at most max_command_rate·Δt (the comparison agents' rate
// limits) and is clamped to the maneuver limits (vehicle::clamp_to_limits, eq. 2–3); the
// truth integrates with RK4 at truth_step_s.
//
// Action a ∈ [−1, 1]³ (the actor's tanh output), mapped by action_to_command:
//   v_c = v0 + a0·Δv,   ω_c = a1·v/R_min (v floored at the band's minimum),   w_c = a2·w_max,
// then clamp_to_limits (the pitch limit). So any action is within the same limits as the
// other methods' commands.
//
// Observation (kObservationSize floats, every one scaled to about [−2, 2]; fixed scales, no
// running statistics, so a saved policy needs nothing but its weights). "Body frame": the
// horizontal frame turned by the heading ψ, forward f and left l.
//   [0..2]   (v − v0)/Δv,  ω·R_min/v0,  w/w_max
//   [3..6]   target: cos β, sin β (β its horizontal bearing from the heading),
//            tanh(d_h/300 m), clamp((z_t − z)/100 m, ±2)
//   [7]      clearance now: clamp((z − H(x, y) − h_safe)/100 m, −1, 2)
//   [8..19]  terrain ahead: clamp((z − H(q) − h_safe)/100 m, ±2) at the points q at
//            kTerrainDistances_m along the directions kTerrainAngles_rad from the heading
//            (angle-major: 3 angles × 4 distances)
//   [20..35] the two nearest obstacles (sensed threats, and in the closed loop the neighbours'
//            broadcast positions with radius d_safe), nearest surface first; for each:
//            present (1/0), relative centre (f, l, z)/300 m, obstacle velocity (f, l, z)/10 m/s,
//            tanh(surface distance/100 m); zeros when absent
//   [36..38] measured (filtered) wind (f, l, z)/5 m/s
//   [39..40] altitude band: clamp((z − H_min)/100 m, 0, 2), clamp((H_max − z)/100 m, 0, 2)
//
// Reward of one decision (documented terms, RewardTerms):
//   progress  = (d_before − d_after)/(v0·T_a)      d the 3-D distance to the target, T_a the
//                                                  action period: ≈ 1 flying straight at v0
//   time      = −w_time
//   terrain   = −w_terrain·max(0, 1 − (z − H − h_safe)/band_terrain)   below the band over h_safe
//   threat    = −w_threat·max(0, 1 − (s − r_safe)/band_threat)   s the nearest surface distance
//   effort    = −w_effort·(a1² + a2²)                turn and climb effort
//   terminal  = +w_success on reaching the target (3-D distance ≤ radius, |Δz| ≤ band),
//               −w_collision on a collision (below the terrain, inside a threat, or outside
//               the altitude band by more than altitude_tolerance_m); a timeout ends the
//               episode with no terminal term.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/random.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"
#include "world/wind.hpp"

namespace ridgeline::learning {

constexpr int kObservationSize = 41;
constexpr int kActionSize = 3;
using Observation = std::array<float, kObservationSize>;

constexpr std::array<double, 3> kTerrainAngles_rad = {-0.7, 0.0, 0.7};
constexpr std::array<double, 4> kTerrainDistances_m = {25.0, 50.0, 100.0, 150.0};
constexpr int kObservedObstacles = 2;

/// An obstacle the UAV knows of, at the time of the observation.
struct ObstacleView {
  Vec3 centre_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  double radius_m = 0.0;
};

/// What the observation is computed from; the same in training and in the closed loop.
struct ObservationInput {
  vehicle::State state = vehicle::State::Zero();  ///< the position fix
  Vec3 wind_m_s = Vec3::Zero();                   ///< the filtered anemometer reading
  Vec3 target_m = Vec3::Zero();
  std::vector<ObstacleView> obstacles;
  const world::Terrain* terrain = nullptr;  ///< required
  world::SafetyLimits limits;               ///< h_safe and the band (world/safety_limits.hpp)
};

/// The scaled observation of the header comment. The terrain's model error is counted
/// against the clearance (as every method does).
Observation make_observation(const ObservationInput& input, const vehicle::VehicleParams& vehicle);

/// Maps an action in [−1, 1]³ (values outside are clipped) to a command within the maneuver
/// limits at state s (header comment).
vehicle::Input action_to_command(const Vec3& action, const vehicle::State& s,
                                 const vehicle::VehicleParams& vehicle);

struct RewardWeights {
  double time = 0.05;
  double terrain = 1.0;
  double terrain_band_m = 20.0;
  double threat = 1.0;
  double threat_band_m = 30.0;
  double effort = 0.05;
  double success = 50.0;
  double collision = 50.0;
};

enum class EpisodeOutcome {
  kRunning,
  kReached,            ///< within the target's radius and altitude band
  kTerrainCollision,   ///< below the terrain
  kThreatCollision,    ///< inside a threat sphere
  kAltitudeViolation,  ///< outside [H_min, H_max] by more than altitude_tolerance_m
  kTimeout,
};
std::string_view to_string(EpisodeOutcome outcome);
bool is_collision(EpisodeOutcome outcome);

struct RewardTerms {
  double progress = 0.0;
  double time = 0.0;
  double terrain = 0.0;
  double threat = 0.0;
  double effort = 0.0;
  double terminal = 0.0;
  double total() const { return progress + time + terrain + threat + effort + terminal; }
};

/// What the reward of one decision is computed from.
struct RewardInput {
  double distance_before_m = 0.0;
  double distance_after_m = 0.0;
  double clearance_over_safe_m = 0.0;  ///< z − H − model error − h_safe after the decision
  double threat_surface_m = 1e9;       ///< nearest threat surface after the decision
  Vec3 action = Vec3::Zero();
  EpisodeOutcome outcome = EpisodeOutcome::kRunning;
};
RewardTerms compute_reward(const RewardInput& input, const RewardWeights& weights,
                           double cruise_speed_m_s, double action_period_s, double threat_margin_m);

/// The ranges an episode is drawn from (Environment::random_episode).
struct EpisodeRandomization {
  double area_m = 2000.0;  ///< square [0, area]²
  bool terrain = true;     ///< false: flat ground at height 0
  int min_peaks = 4, max_peaks = 8;
  double min_peak_height_m = 80.0, max_peak_height_m = 300.0;
  double min_target_distance_m = 400.0, max_target_distance_m = 1200.0;
  double height_above_terrain_m = 60.0;  ///< of the start and the target
  int max_threats = 3;                   ///< 0..max_threats, crossing the direct line
  double min_threat_radius_m = 30.0, max_threat_radius_m = 60.0;
  double min_threat_speed_m_s = 2.0, max_threat_speed_m_s = 8.0;
  double max_mean_wind_m_s = 3.0;
  double max_gust_std_m_s = 1.0;
};

/// One episode's world.
struct EpisodeSetup {
  std::shared_ptr<const world::Terrain> terrain;
  vehicle::State start = vehicle::State::Zero();
  Vec3 target_m = Vec3::Zero();
  std::vector<world::Threat> threats;
  world::WindConfig wind;
  double time_limit_s = 200.0;
};

struct EnvironmentOptions {
  EpisodeRandomization randomization;
  vehicle::VehicleParams vehicle;
  RewardWeights reward;
  double truth_time_constant_scale = 1.2;  ///< as mission::SimulationConfig
  double position_noise_m = 0.1;
  double control_period_s = 0.02;
  double truth_step_s = 0.01;
  double action_period_s = 0.4;
  Vec3 max_command_rate = Vec3(4.0, 1.5, 4.0);  ///< as baselines::BaselineAgentOptions
  double wind_filter_time_s = 0.5;
  double sensor_range_m = 300.0;
  world::SafetyLimits limits;  ///< h_safe, r_safe and the band of the training episodes
  double altitude_tolerance_m = 20.0;
  double target_radius_m = 30.0;
  double target_altitude_band_m = 30.0;
  /// time limit = factor · (direct distance / v0) + extra
  double time_limit_factor = 2.0;
  double time_limit_extra_s = 30.0;
};

/// Throws InputError naming the field for an invalid option.
void validate(const EnvironmentOptions& options);

struct StepResult {
  Observation observation{};
  RewardTerms reward;
  EpisodeOutcome outcome = EpisodeOutcome::kRunning;
  bool done() const { return outcome != EpisodeOutcome::kRunning; }
};

/// Named training tasks: `mountain` (the defaults above: random peak terrain, up to three
/// crossing threats, wind up to 3 m/s mean and 1 m/s gusts, targets 400–1200 m away) and
/// `flat` (flat ground, no threats, calm air, targets 150–300 m away: a task a few seconds of
/// training improve on, for tests).
enum class TrainingTask { kMountain, kFlat };
std::string_view to_string(TrainingTask task);
/// Throws InputError(field, "unknown task ...").
TrainingTask parse_training_task(std::string_view text, const std::string& field = "--task");
EnvironmentOptions task_environment(TrainingTask task);

class UavEnvironment {
 public:
  explicit UavEnvironment(const EnvironmentOptions& options);

  /// Draws an episode from the randomization ranges; deterministic for a seed.
  EpisodeSetup random_episode(std::uint64_t seed) const;
  /// Starts an episode (random or hand-made); returns the first observation.
  Observation reset(const EpisodeSetup& setup, std::uint64_t noise_seed = 1);
  Observation reset(std::uint64_t seed) { return reset(random_episode(seed), seed); }
  /// One decision: the action held for action_period_s.
  StepResult step(const Vec3& action);

  const EnvironmentOptions& options() const { return options_; }
  const vehicle::State& true_state() const { return state_; }
  const vehicle::Input& command() const { return command_; }
  double time_s() const { return time_s_; }
  const EpisodeSetup& setup() const { return setup_; }
  /// The observation of the current truth (with a fresh position fix).
  Observation observe();

 private:
  EpisodeOutcome outcome() const;
  double clearance_over_safe_m(const Vec3& p_m) const;
  double nearest_threat_surface_m(const Vec3& p_m) const;

  EnvironmentOptions options_;
  vehicle::VehicleParams truth_params_;
  EpisodeSetup setup_;
  std::unique_ptr<world::WindField> wind_;
  std::unique_ptr<world::WindSensor> anemometer_;
  Rng noise_{1};
  vehicle::State state_ = vehicle::State::Zero();
  vehicle::Input command_ = vehicle::Input::Zero();
  Vec3 wind_estimate_ = Vec3::Zero();
  double time_s_ = 0.0;
};

}  // namespace ridgeline::learning
