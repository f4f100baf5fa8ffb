// Vehicle motion model of a fixed-heading-rate UAV (DESIGN §2, paper eq. 1–4).
//
// State  s = [x, y, z, ψ, v, ω, w]: ENU position (m), heading ψ (rad, from east,
//            counter-clockwise), horizontal speed v (m/s), turn rate ω (rad/s),
//            vertical speed w (m/s).
// Input  u = [v_c, ω_c, w_c]: commanded speed, turn rate and vertical speed.
// Wind   W = [Wx, Wy, Wz]: the air mass's drift (m/s), added to the ground velocity.
//
//   ẋ = v cos ψ + Wx    ẏ = v sin ψ + Wy    ż = w + Wz                       (eq. 1)
//   ψ̇ = ω    v̇ = (v_c − v)/τ_v    ω̇ = (ω_c − ω)/τ_ω    ẇ = (w_c − w)/τ_w
//
// The MPC predicts with the explicit Euler step (eq. 4); the simulator's truth integrates
// with RK4, possibly with different time constants (model mismatch is deliberate).
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/types.hpp"

namespace ridgeline::vehicle {

constexpr int kStateDim = 7;
constexpr int kInputDim = 3;

using State = Eigen::Matrix<double, kStateDim, 1>;
using Input = Eigen::Matrix<double, kInputDim, 1>;
using StateMatrix = Eigen::Matrix<double, kStateDim, kStateDim>;
using InputMatrix = Eigen::Matrix<double, kStateDim, kInputDim>;
using WindMatrix = Eigen::Matrix<double, kStateDim, 3>;

/// Indices into State.
enum StateIndex : int { kX = 0, kY, kZ, kPsi, kV, kOmega, kW };
/// Indices into Input.
enum InputIndex : int { kSpeedCmd = 0, kTurnRateCmd, kClimbRateCmd };

/// Physical parameters and maneuver limits of one UAV (eq. 2–3).
struct VehicleParams {
  double cruise_speed_m_s = 10.0;     ///< v0
  double speed_band_m_s = 5.0;        ///< Δv: v0 − Δv ≤ v_c ≤ v0 + Δv
  double min_turn_radius_m = 10.0;    ///< R_min: |ω_c| ≤ v / R_min
  double max_climb_rate_m_s = 3.0;    ///< w_max: |w_c| ≤ w_max
  double max_pitch_rad = deg_to_rad(30.0);  ///< θ_max: |atan2(w, v)| ≤ θ_max
  double tau_v_s = 0.5;               ///< speed lag τ_v
  double tau_omega_s = 0.2;           ///< turn-rate lag τ_ω
  double tau_w_s = 0.4;               ///< climb-rate lag τ_w

  double min_speed_m_s() const { return cruise_speed_m_s - speed_band_m_s; }
  double max_speed_m_s() const { return cruise_speed_m_s + speed_band_m_s; }
  /// Largest admissible |ω_c| at horizontal speed v (eq. 3).
  double max_turn_rate_rad_s(double speed_m_s) const;
  /// The climb-rate bound that keeps the pitch limit |w| ≤ v·tan θ_max whatever the speed does
  /// while a climb command holds: the speed lags the commands and may fall to the band's
  /// floor, so the floor bounds the climb (and w_max): min(w_max, v_min·tan θ_max).
  double robust_max_climb_rate_m_s() const;
};

/// Continuous-time dynamics f(s, u, W) of eq. 1.
State derivative(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p);

/// Explicit Euler step s⁺ = s + Δt·f(s, u, W) (eq. 4), the MPC's prediction model.
State euler_step(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p,
                 double dt_s);

/// Classical fourth-order Runge–Kutta step with u and W held over the step: the truth model.
State rk4_step(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p,
               double dt_s);

/// Analytic Jacobians of f: A = ∂f/∂s, B = ∂f/∂u, E = ∂f/∂W.
struct Jacobians {
  StateMatrix A;
  InputMatrix B;
  WindMatrix E;
};
Jacobians continuous_jacobians(const State& s, const VehicleParams& p);
/// A = ∂f/∂s alone (the only Jacobian that depends on the state; the MPC's step needs it
/// along the whole horizon, B and E once).
StateMatrix continuous_state_jacobian(const State& s, const VehicleParams& p);

/// Jacobians of the Euler step: A_d = I + Δt·A, B_d = Δt·B, E_d = Δt·E.
Jacobians discrete_jacobians(const State& s, const VehicleParams& p, double dt_s);
/// A_d = I + Δt·A alone.
StateMatrix discrete_state_jacobian(const State& s, const VehicleParams& p, double dt_s);
/// For each column j of `states` (n_s × N, N ≤ A_d.size()): rewrites in A_d[j], a
/// discrete_state_jacobian of the same parameters and step at any state, the four entries that
/// depend on the state (x and y against speed and heading), so that it equals
/// discrete_state_jacobian(states.col(j), p, dt_s). The MPC's step calls it once for its 40
/// prediction steps: it skips building and copying the constant 45 entries of each, and takes
/// the headings' sines and cosines together (core/sin_cos.hpp: four a call where the CPU has
/// AVX2, within a few ulp of libm's, so those entries equal the full Jacobian's to round-off).
void update_discrete_state_jacobians(const Eigen::Ref<const Eigen::MatrixXd>& states,
                                     double dt_s, std::span<Eigen::MatrixXd> A_d);

/// Clamps a command into the maneuver limits at state s: the speed band, |ω_c| ≤ v/R_min
/// (with v the current horizontal speed, floored at the minimum speed), and the climb
/// command to both w_max and the pitch limit |w_c| ≤ v·tan θ_max.
Input clamp_to_limits(const Input& u, const State& s, const VehicleParams& p);

/// Positions reached by flying toward the command `target` from the command `from` with the
/// Euler model over `steps` steps of `step_s`: the command moves at most
/// max_command_rate·step_s a step (the tracker's rate limits) and is clamped into the limits at
/// each state. `positions` is cleared and gets one position a step. For local planners that
/// score held commands (the DWA baseline, the agent's separation guard).
void rollout_positions(const State& s, const Input& from, const Input& target,
                       const Vec3& max_command_rate, const Vec3& wind_m_s, const VehicleParams& p,
                       double step_s, int steps, std::vector<Vec3>& positions);

/// Flight-path (pitch) angle θ = atan2(w, v) of a state.
double pitch_angle_rad(const State& s);

}  // namespace ridgeline::vehicle
