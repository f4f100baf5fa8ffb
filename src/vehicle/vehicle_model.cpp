#include "vehicle/vehicle_model.hpp"

#include <algorithm>
#include <cmath>

#include "core/sin_cos.hpp"

namespace ridgeline::vehicle {

double VehicleParams::max_turn_rate_rad_s(double speed_m_s) const {
  return std::max(speed_m_s, 0.0) / min_turn_radius_m;
}

double VehicleParams::robust_max_climb_rate_m_s() const {
  return std::min(max_climb_rate_m_s, min_speed_m_s() * std::tan(max_pitch_rad));
}

State derivative(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p) {
  const double psi = s[kPsi];
  const double v = s[kV];
  State ds;
  ds[kX] = v * std::cos(psi) + wind_m_s.x();
  ds[kY] = v * std::sin(psi) + wind_m_s.y();
  ds[kZ] = s[kW] + wind_m_s.z();
  ds[kPsi] = s[kOmega];
  ds[kV] = (u[kSpeedCmd] - v) / p.tau_v_s;
  ds[kOmega] = (u[kTurnRateCmd] - s[kOmega]) / p.tau_omega_s;
  ds[kW] = (u[kClimbRateCmd] - s[kW]) / p.tau_w_s;
  return ds;
}

State euler_step(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p,
                 double dt_s) {
  return s + dt_s * derivative(s, u, wind_m_s, p);
}

State rk4_step(const State& s, const Input& u, const Vec3& wind_m_s, const VehicleParams& p,
               double dt_s) {
  const State k1 = derivative(s, u, wind_m_s, p);
  const State k2 = derivative(s + 0.5 * dt_s * k1, u, wind_m_s, p);
  const State k3 = derivative(s + 0.5 * dt_s * k2, u, wind_m_s, p);
  const State k4 = derivative(s + dt_s * k3, u, wind_m_s, p);
  return s + (dt_s / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

namespace {

// The entries of ∂f/∂s that depend on the state (x and y against heading and speed), from the
// heading's cosine and sine and the speed, each times `scale`: 1 for A itself, Δt for
// A_d = I + Δt·A, whose entries there are 0 + Δt·a, i.e. Δt·a exactly. The one place these
// derivatives are written.
template <typename Matrix>
void write_state_dependent_entries(double cos_psi, double sin_psi, double v, double scale,
                                   Matrix& A) {
  A(kX, kPsi) = scale * (-v * sin_psi);
  A(kX, kV) = scale * cos_psi;
  A(kY, kPsi) = scale * (v * cos_psi);
  A(kY, kV) = scale * sin_psi;
}

}  // namespace

StateMatrix continuous_state_jacobian(const State& s, const VehicleParams& p) {
  StateMatrix A = StateMatrix::Zero();
  write_state_dependent_entries(std::cos(s[kPsi]), std::sin(s[kPsi]), s[kV], 1.0, A);
  A(kZ, kW) = 1.0;
  A(kPsi, kOmega) = 1.0;
  A(kV, kV) = -1.0 / p.tau_v_s;
  A(kOmega, kOmega) = -1.0 / p.tau_omega_s;
  A(kW, kW) = -1.0 / p.tau_w_s;
  return A;
}

Jacobians continuous_jacobians(const State& s, const VehicleParams& p) {
  Jacobians J;
  J.A = continuous_state_jacobian(s, p);

  J.B.setZero();
  J.B(kV, kSpeedCmd) = 1.0 / p.tau_v_s;
  J.B(kOmega, kTurnRateCmd) = 1.0 / p.tau_omega_s;
  J.B(kW, kClimbRateCmd) = 1.0 / p.tau_w_s;

  J.E.setZero();
  J.E(kX, 0) = 1.0;
  J.E(kY, 1) = 1.0;
  J.E(kZ, 2) = 1.0;
  return J;
}

StateMatrix discrete_state_jacobian(const State& s, const VehicleParams& p, double dt_s) {
  return StateMatrix::Identity() + dt_s * continuous_state_jacobian(s, p);
}

void update_discrete_state_jacobians(const Eigen::Ref<const Eigen::MatrixXd>& states,
                                     double dt_s, std::span<Eigen::MatrixXd> A_d) {
  constexpr int kBatch = 16;  // headings a call of sin_cos (on the stack)
  double psi[kBatch], sin_psi[kBatch], cos_psi[kBatch];
  const int n = static_cast<int>(states.cols());
  for (int begin = 0; begin < n; begin += kBatch) {
    const int count = std::min(kBatch, n - begin);
    for (int k = 0; k < count; ++k) psi[k] = states(kPsi, begin + k);
    sin_cos(psi, sin_psi, cos_psi, count);
    for (int k = 0; k < count; ++k) {
      write_state_dependent_entries(cos_psi[k], sin_psi[k], states(kV, begin + k), dt_s,
                                    A_d[static_cast<std::size_t>(begin + k)]);
    }
  }
}

Jacobians discrete_jacobians(const State& s, const VehicleParams& p, double dt_s) {
  Jacobians J = continuous_jacobians(s, p);
  J.A = discrete_state_jacobian(s, p, dt_s);
  J.B *= dt_s;
  J.E *= dt_s;
  return J;
}

Input clamp_to_limits(const Input& u, const State& s, const VehicleParams& p) {
  Input out;
  out[kSpeedCmd] = std::clamp(u[kSpeedCmd], p.min_speed_m_s(), p.max_speed_m_s());
  // The turn-rate bound uses the speed the vehicle has now (eq. 3); below the speed band the
  // band's floor applies so a slow vehicle can still turn at R_min.
  const double speed = std::max(s[kV], p.min_speed_m_s());
  const double max_turn = p.max_turn_rate_rad_s(speed);
  out[kTurnRateCmd] = std::clamp(u[kTurnRateCmd], -max_turn, max_turn);
  const double max_climb = std::min(p.max_climb_rate_m_s, speed * std::tan(p.max_pitch_rad));
  out[kClimbRateCmd] = std::clamp(u[kClimbRateCmd], -max_climb, max_climb);
  return out;
}

double pitch_angle_rad(const State& s) { return std::atan2(s[kW], s[kV]); }

void rollout_positions(const State& s, const Input& from, const Input& target,
                       const Vec3& max_command_rate, const Vec3& wind_m_s, const VehicleParams& p,
                       double step_s, int steps, std::vector<Vec3>& positions) {
  positions.clear();
  State state = s;
  Input u = from;
  const Vec3 max_change = max_command_rate * step_s;
  for (int k = 0; k < steps; ++k) {
    for (int i = 0; i < 3; ++i)
      u[i] = std::clamp(target[i], u[i] - max_change[i], u[i] + max_change[i]);
    state = euler_step(state, clamp_to_limits(u, state, p), wind_m_s, p, step_s);
    positions.emplace_back(state.head<3>());
  }
}

}  // namespace ridgeline::vehicle
