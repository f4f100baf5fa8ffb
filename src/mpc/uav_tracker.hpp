// Receding-horizon tracker of one UAV (DESIGN §3): the incremental MPC of
// incremental_mpc.hpp applied to the vehicle model of eq. 1–4, with threat, neighbour and
// terrain constraints.
//
// Each call of step() (every control period, 50 Hz by default):
//  1. ξ_k = [Δs_k; p_k]. Δs_k = s(t) − s(t − Δt_p) is the MEASURED increment over one
//     prediction step Δt_p, interpolated from the tracker's own history of states (Δψ wrapped
//     to (−π, π]). Measuring it is what gives the incremental form its integral action: an
//     unmodelled constant drift (wind error, τ mismatch) is inside Δs_k and is predicted to
//     persist. Until the history spans Δt_p (first calls) Δs_k = Δt_p·f(s, u_{k−1}, W_meas).
//     Because the control period is shorter than Δt_p, the input changed within the measured
//     interval; the step's known offset o_0 = B_0(u_{k−1} − ū) (ū the mean command over the
//     interval) makes the first predicted increment use the input actually held now.
//  2. Linearize the Euler step (eq. 4) with Δt_p along a nominal trajectory s̄_j
//     (vehicle::discrete_jacobians): s̄_0 = s(t), then the reference (heading, speed, rates),
//     or — with LinearizationPoint::kPreviousPrediction — the previous step's predicted states
//     where they exist. Headings are unwrapped relative to the state (ψ̄_j = ψ̄_{j−1} +
//     wrap(ψ_r − ψ̄_{j−1})), so a reference heading of +179° and a state at −179° are 2° apart.
//  3. Wind feed-forward: the measured wind enters the incremental model through its change,
//     Δd_k = W_meas(t) − W_meas(t − Δt_p), and is held over the horizon (Δd_j = 0, j ≥ 1); the
//     wind itself is already in the measured Δs_k.
//  4. Cost (eq. 10): position error weights Q = diag(q_xy, q_xy, q_z) on y = p at the Np
//     prediction times t + (j+1)Δt_p; move weights R on Δu per prediction step.
//  5. Hard limits (eq. 2–3, 11), per move i with the nominal speed v̄_i (v̄_0 = v(t), as in
//     vehicle::clamp_to_limits): v0 − Δv ≤ v_c ≤ v0 + Δv, |ω_c| ≤ max(v̄, v_min)/R_min,
//     |w_c| ≤ min(w_max, max(v̄, v_min)·tan θ_max) (the pitch limit). Rate limits (per second)
//     become |Δu_0| ≤ rate·T_ctrl for the move applied now (so consecutive 50 Hz commands obey
//     them) and |Δu_i| ≤ rate·Δt_p later. If the previous command lies outside a limit that
//     the rate limit cannot reach in time, that move's limit is relaxed to the middle of what
//     is reachable (flagged limits_relaxed), so the hard part of the QP is always feasible and
//     keeps a strict interior.
//  6. Soft rows (DESIGN §3), linearized about the nominal positions p̄_j (the previous
//     prediction, else the reference), each with a slack shared by its kind:
//       threat    n_jᵀ(p_j − c_j) ≥ R + r_safe + m_j,  c_j = c_0 + v_T(t_j − t_appear),
//                 n_j = (p̄_j − c_j)/|p̄_j − c_j|, for t_appear ≤ t_j ≤ t_vanish;
//       neighbour n_jᵀ(p_j − q_j) ≥ d_k, q_j the neighbour's broadcast prediction at t_j and d_k
//                 the distance the environment gives for it (d_safe by default);
//       terrain   z_j − ∇H(p̄_j)·(p_j − p̄_j)_xy ≥ H(p̄_j) + h_safe + m_j + e_H (e_H the
//                 terrain model's known error).
//     The robust margin m_j = min(ē_W·(j+1)Δt_p, m_max) is the position error a wind error
//     bounded by ē_W accumulates by t_j. A row is added only while its nominal distance to the
//     boundary is below activation_distance_m (far constraints cannot be active in 4 s).
//  7. Solve and apply the first move: u_k = u_{k−1} + Δu_k, clamped to the rate limit of one
//     control period and then by vehicle::clamp_to_limits (flagged command_clamped if that
//     changed it by more than the solver tolerance). If the QP is not solved the previous
//     command is held (flagged fallback) and the prediction is the free response. The
//     prediction is kept for the next linearization and for broadcasting.
//
// Units: SI, ENU. Not thread-safe (one tracker per UAV). step() does not throw. After warm-up
// it does not allocate, except when the number of soft rows grows past a block of 16 (the QP
// is resized, see incremental_mpc.hpp); tests/mpc/uav_tracker_allocation_test.cpp checks it.
// Threats and neighbours beyond the capacity are dropped and counted in the result.
#pragma once

#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include "messages/messages.hpp"
#include "mpc/incremental_mpc.hpp"
#include "mpc/reference.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::mpc {

/// What the nominal trajectory of the linearization follows (step 2 above). Near the
/// reference both agree to first order. Far from it they do not: the Jacobians rotate with
/// the heading, so a vehicle 90° off the reference heading is mispredicted by kReference
/// (in the test that starts 60 m off a line facing away from it, kReference flies off while
/// kPreviousPrediction converges). Hence the default.
enum class LinearizationPoint {
  kReference,           ///< the reference trajectory (the literal reading of DESIGN §3)
  kPreviousPrediction,  ///< the previous step's prediction, the reference beyond it
};

struct UavTrackerOptions {
  vehicle::VehicleParams vehicle;  ///< the controller's model and limits
  double control_period_s = 0.02;  ///< T_ctrl (50 Hz)
  double prediction_step_s = 0.1;  ///< Δt_p
  int prediction_horizon = 40;     ///< Np
  int control_horizon = 10;        ///< Nc
  LinearizationPoint linearization = LinearizationPoint::kPreviousPrediction;

  double weight_xy_per_m2 = 1.0;        ///< q_xy
  double weight_z_per_m2 = 1.0;         ///< q_z
  double terminal_weight_factor = 1.0;  ///< Q_N = factor·Q
  double weight_speed_move = 2.0;       ///< R for Δv_c, per (m/s)²
  double weight_turn_move = 200.0;      ///< R for Δω_c, per (rad/s)²
  double weight_climb_move = 2.0;       ///< R for Δw_c, per (m/s)²

  double max_speed_cmd_rate_m_s2 = 4.0;   ///< |v̇_c|
  double max_turn_cmd_rate_rad_s2 = 1.5;  ///< |ω̇_c|
  double max_climb_cmd_rate_m_s2 = 4.0;   ///< |ẇ_c|

  double wind_error_bound_m_s = 0.5;  ///< ē_W, bound on the wind measurement's error
  double max_robust_margin_m = 10.0;  ///< m_max
  double activation_distance_m = 60.0;
  int max_threats = 4;  ///< capacity; more are dropped and counted
  int max_neighbours = 4;

  /// ρ₁ per metre of violation. The penalty is exact (σ = 0 whenever the rows can be met)
  /// while ρ₁ exceeds the sum of the multipliers of a kind's rows: a path pushed ~40 m off the
  /// reference for ~20 steps at q = 1/m² gives Σλ ≈ 2·40·20 = 1.6e3, so 1e4 covers it. 1e5
  /// was measured to raise the interior point's p99 iteration count from 25 to 43.
  double slack_linear_weight = 1e4;
  double slack_quadratic_weight = 1e3;  ///< ρ₂ per m²
  /// Relative KKT tolerance 1e-7: with positions in metres and costs of 1e2–1e5 this is far
  /// below a millimetre, and it spares the interior point the last, ill-conditioned iterations
  /// (at 1e-9 it stalled on some threat-avoidance QPs). The 50 Hz step uses the hot-started
  /// active-set method (exact vertices; the interior point is its fallback).
  qp::QpSettings qp_settings{.tolerance = 1e-7, .method = qp::QpMethod::kActiveSet};
  /// The step's thread CPU time (step_cpu_time_us) is read on every this many steps, the
  /// others report NaN: the thread CPU clock is a system call (no vDSO), 0.5 to 1.3 µs each on
  /// the virtual machines measured, two a step: 5 to 13 % of a simulated flight. 0: never (a
  /// caller that times the step from outside, such as `bench mpc`). ≥ 0.
  int cpu_time_period_steps = 1;
  /// Split step_time_us into its parts (UavTrackerResult::parts): seven more readings of the
  /// steady clock a step, about 0.2 µs (1 % of a step). Off, the parts are NaN.
  bool time_step_parts = true;
};

/// Throws ridgeline::InputError naming the field (e.g. `prediction_step_s`) and the reason.
void validate(const UavTrackerOptions& options);

/// Which slack group a soft row belongs to.
enum class SoftConstraintKind : int { kThreat = 0, kNeighbour = 1, kTerrain = 2 };
constexpr int kSoftConstraintKinds = 3;

/// The world around the UAV for one step. Pointers/spans must stay valid during step().
struct TrackerEnvironment {
  std::span<const world::Threat> threats;
  std::span<const messages::PredictedTrajectory> neighbours;  ///< as broadcast (messages/)
  const world::Terrain* terrain = nullptr;
  /// The distance each neighbour's rows keep (same length as `neighbours`, nearest first:
  /// the capacity keeps the first); empty: d_safe for every one. The agent's separation
  /// protocol sets it (swarm/agent.hpp): d_safe plus its margins for a neighbour it yields to.
  std::span<const double> neighbour_separation_m = {};
};

/// Where one step's time went, in wall-clock µs (steady clock, about 30 ns a reading; a
/// preempted part includes the wait). NaN when UavTrackerOptions::time_step_parts is off.
struct UavTrackerStepParts {
  double linearization_us = 0.0;  ///< steps 1–4: increment, nominal, Jacobians, wind, reference
  double condensing_us = 0.0;     ///< the MPC's Φ, free response, H and f
  double soft_rows_us = 0.0;      ///< step 6 and the soft rows' QP rows
  double qp_us = 0.0;             ///< the QP solve
  double other_us = 0.0;          ///< the rest: limits, bounds, solution, command, bookkeeping
};

struct UavTrackerResult {
  vehicle::Input command = vehicle::Input::Zero();  ///< to send; within every hard limit
  bool command_clamped = false;       ///< the QP's first input needed clamping (> 1e-6)
  bool limits_relaxed = false;        ///< an input limit was widened to stay reachable (step 5)
  bool fallback = false;              ///< QP not solved: previous command held
  bool increment_from_model = false;  ///< history too short: Δs_k from the model (step 1)
  qp::QpStatus qp_status = qp::QpStatus::kInvalidInput;
  int qp_iterations = 0;
  double qp_time_us = 0.0;
  double step_time_us = 0.0;  ///< the whole step: history, linearization, rows, solve
  UavTrackerStepParts parts;  ///< step_time_us split; the parts sum to it (NaN untimed)
  /// The same step in this thread's CPU time: without the time a shared machine's other
  /// processes held the core, which the wall-clock figure includes. NaN on the steps
  /// UavTrackerOptions::cpu_time_period_steps leaves unmeasured.
  double step_cpu_time_us = 0.0;
  /// Predicted positions (3×Np) at times prediction_time_s(j) = t + (j+1)Δt_p, and states.
  MatX predicted_positions_m;
  MatX predicted_states;
  double first_prediction_time_s = 0.0;
  double prediction_step_s = 0.0;
  /// Slack (m) per kind (SoftConstraintKind): the largest violation the plan accepts.
  std::array<double, kSoftConstraintKinds> slack_m{};
  std::array<int, kSoftConstraintKinds> soft_rows{};  ///< added per kind
  /// Of them, the rows the QP carried (IncrementalMpcResult::soft_rows_in_qp): the others no
  /// move within the rate limits can violate.
  int soft_rows_in_qp = 0;
  int dropped_threats = 0;
  int dropped_neighbours = 0;

  double max_slack_m() const { return std::max({slack_m[0], slack_m[1], slack_m[2]}); }
};

class UavTracker {
 public:
  /// `limits`: r_safe, d_safe and h_safe of the soft rows (the mission's). Throws
  /// ridgeline::InputError for invalid options or limits.
  UavTracker(const UavTrackerOptions& options, const world::SafetyLimits& limits);

  /// One control step at mission time t_s with the measured state and wind.
  const UavTrackerResult& step(double t_s, const vehicle::State& state,
                               const Vec3& measured_wind_m_s, const ReferenceTrajectory& reference,
                               const TrackerEnvironment& environment);

  /// Forgets history, previous prediction, previous command and warm start; the next step
  /// starts from `initial_command`.
  void reset(const vehicle::Input& initial_command);

  /// The last step's command was not flown: `applied` was (the agent's separation guard chose
  /// another). The history and the next step's increments start from it, and the last
  /// prediction, which assumed the tracker's command, no longer seeds the linearization.
  void record_applied_command(const vehicle::Input& applied);

  const UavTrackerOptions& options() const { return options_; }
  const world::SafetyLimits& limits() const { return limits_; }
  const IncrementalMpc& mpc() const { return mpc_; }
  const UavTrackerResult& last_result() const { return result_; }

 private:
  struct HistoryEntry {
    double t_s = 0.0;
    vehicle::State state = vehicle::State::Zero();
    Vec3 wind_m_s = Vec3::Zero();
    vehicle::Input command = vehicle::Input::Zero();  ///< applied from t_s on
  };
  bool increment_from_history(double t_s, const vehicle::State& state, const Vec3& wind,
                              vehicle::State& delta_state, Vec3& delta_wind,
                              vehicle::Input& mean_command) const;
  void build_nominal(double t_s, const vehicle::State& state, const ReferenceTrajectory& ref);
  void set_limits(const vehicle::State& state);
  void add_soft_rows(double t_s, const vehicle::State& state, const TrackerEnvironment& env);
  void push_history(const HistoryEntry& entry);

  UavTrackerOptions options_;
  world::SafetyLimits limits_;
  IncrementalMpc mpc_;
  UavTrackerResult result_;
  int np_, nc_;

  std::vector<HistoryEntry> history_;  // ring buffer
  int history_head_ = 0;               // index of the newest entry
  int history_size_ = 0;
  long long steps_ = 0;  // calls of step(), for cpu_time_period_steps
  vehicle::Input previous_command_ = vehicle::Input::Zero();
  bool have_previous_command_ = false;

  // Previous prediction (for the nominal trajectory and the constraint linearization).
  bool have_previous_prediction_ = false;
  double previous_first_time_s_ = 0.0;
  MatX previous_states_;  // 7×Np

  MatX nominal_states_;                           // 7×Np: s̄_j at the start of prediction step j
  MatX nominal_positions_;                        // 3×Np: p̄ at t + (j+1)Δt_p
  std::vector<ReferencePoint> reference_points_;  // r(t + jΔt_p), j = 0..Np
  // The soft rows' geometry by coordinate (rows x, y, z; a column a prediction step): the
  // nominal positions, one threat's or neighbour's centre, the unit vectors from it.
  using RowPoints = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>;
  RowPoints nominal_by_axis_, centres_, directions_;
  std::vector<double> distances_;        // Np: ‖p̄_j − c_j‖ for the centres above
  std::vector<double> bounds_;           // Np: the sphere rows' bounds there
  std::vector<std::int64_t> active_;     // Np: 1 where the row is active
  std::vector<double> robust_margins_;   // Np: m_j, from the options
  std::vector<double> terrain_heights_;  // Np: H at the nominal positions
  std::vector<Vec2> terrain_gradients_;  // Np: ∇H there
};

}  // namespace ridgeline::mpc
