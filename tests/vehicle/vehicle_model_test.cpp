#include "vehicle/vehicle_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace ridgeline::vehicle {
namespace {

VehicleParams default_params() { return VehicleParams{}; }

State make_state(double psi, double v, double omega, double w) {
  State s = State::Zero();
  s[kZ] = 100.0;
  s[kPsi] = psi;
  s[kV] = v;
  s[kOmega] = omega;
  s[kW] = w;
  return s;
}

State integrate_rk4(State s, const Input& u, const Vec3& wind, const VehicleParams& p,
                    double duration_s, int steps) {
  const double dt = duration_s / steps;
  for (int i = 0; i < steps; ++i) s = rk4_step(s, u, wind, p, dt);
  return s;
}

State integrate_euler(State s, const Input& u, const Vec3& wind, const VehicleParams& p,
                      double duration_s, int steps) {
  const double dt = duration_s / steps;
  for (int i = 0; i < steps; ++i) s = euler_step(s, u, wind, p, dt);
  return s;
}

TEST(VehicleModel, StraightFlightWithWindDriftsLinearly) {
  const VehicleParams p = default_params();
  const double psi = 0.7;
  const State s0 = make_state(psi, 10.0, 0.0, 0.0);
  const Input u(10.0, 0.0, 0.0);  // steady command: the lags stay at equilibrium
  const Vec3 wind(1.5, -2.0, 0.25);
  const State s = integrate_rk4(s0, u, wind, p, 20.0, 2000);
  // Exact answer: constant ground velocity v·(cos ψ, sin ψ) + W. RK4 integrates a constant
  // velocity exactly, so only rounding remains.
  EXPECT_NEAR(s[kX], 20.0 * (10.0 * std::cos(psi) + 1.5), 1e-9);
  EXPECT_NEAR(s[kY], 20.0 * (10.0 * std::sin(psi) - 2.0), 1e-9);
  EXPECT_NEAR(s[kZ], 100.0 + 20.0 * 0.25, 1e-9);
  EXPECT_NEAR(s[kPsi], psi, 1e-12);
}

TEST(VehicleModel, SteadyTurnHasRadiusSpeedOverTurnRate) {
  const VehicleParams p = default_params();
  const double v = 12.0, omega = 0.15;  // radius 80 m
  const State s0 = make_state(0.0, v, omega, 0.0);
  const Input u(v, omega, 0.0);
  const double radius = v / omega;
  // The circle's centre is to the left of the initial heading (east): (0, R).
  const Vec3 centre(0.0, radius, 100.0);
  State s = s0;
  const double dt = 0.01;
  double max_radius_error = 0.0;
  for (int i = 0; i < 6000; ++i) {  // 60 s: more than one full turn (2πR/v ≈ 42 s)
    s = rk4_step(s, u, Vec3::Zero(), p, dt);
    const double r = std::hypot(s[kX] - centre.x(), s[kY] - centre.y());
    max_radius_error = std::max(max_radius_error, std::abs(r - radius));
  }
  // RK4's global error at dt = 0.01 s on this smooth motion is far below a millimetre.
  EXPECT_LT(max_radius_error, 1e-6);
  EXPECT_NEAR(wrap_angle(s[kPsi] - omega * 60.0), 0.0, 1e-9);
}

TEST(VehicleModel, FirstOrderLagsReach63PercentAtTimeConstant) {
  const VehicleParams p = default_params();
  const State s0 = make_state(0.0, 8.0, 0.0, 0.0);
  const Input u(12.0, 0.4, 2.0);
  // Each lag is integrated to its own time constant; 1 − e⁻¹ ≈ 0.632 of the step.
  const double expected = 1.0 - std::exp(-1.0);
  const State sv = integrate_rk4(s0, u, Vec3::Zero(), p, p.tau_v_s, 1000);
  EXPECT_NEAR((sv[kV] - 8.0) / 4.0, expected, 1e-9);
  const State so = integrate_rk4(s0, u, Vec3::Zero(), p, p.tau_omega_s, 1000);
  EXPECT_NEAR(so[kOmega] / 0.4, expected, 1e-9);
  const State sw = integrate_rk4(s0, u, Vec3::Zero(), p, p.tau_w_s, 1000);
  EXPECT_NEAR(sw[kW] / 2.0, expected, 1e-9);
}

// Convergence orders: halving the step must divide the global error by ≈2 (Euler) and ≈16
// (RK4). The reference is RK4 with a step 64× finer than the finest tested one.
TEST(VehicleModel, EulerIsFirstOrderAndRk4IsFourthOrder) {
  const VehicleParams p = default_params();
  const State s0 = make_state(0.3, 9.0, 0.05, -0.5);
  const Input u(13.0, -0.3, 1.5);
  const Vec3 wind(1.0, 0.5, 0.0);
  const double T = 4.0;
  const State reference = integrate_rk4(s0, u, wind, p, T, 64 * 1600);
  auto error = [&](bool rk4, int steps) {
    const State s = rk4 ? integrate_rk4(s0, u, wind, p, T, steps)
                        : integrate_euler(s0, u, wind, p, T, steps);
    return (s - reference).norm();
  };
  const double euler_ratio = error(false, 800) / error(false, 1600);
  const double rk4_ratio = error(true, 100) / error(true, 200);
  EXPECT_NEAR(euler_ratio, 2.0, 0.1);
  EXPECT_NEAR(rk4_ratio, 16.0, 1.5);
}

TEST(VehicleModel, JacobiansMatchFiniteDifferences) {
  const VehicleParams p = default_params();
  const State s = make_state(2.1, 11.0, -0.2, 0.8);
  const Input u(9.0, 0.1, -1.0);
  const Vec3 wind(0.7, -1.2, 0.1);
  const Jacobians J = continuous_jacobians(s, p);
  const double h = 1e-6;
  // Central differences have O(h²) truncation and O(ε/h) rounding error: ~1e-9 here.
  for (int j = 0; j < kStateDim; ++j) {
    State sp = s, sm = s;
    sp[j] += h;
    sm[j] -= h;
    const State col = (derivative(sp, u, wind, p) - derivative(sm, u, wind, p)) / (2 * h);
    for (int i = 0; i < kStateDim; ++i) EXPECT_NEAR(J.A(i, j), col[i], 1e-7) << i << "," << j;
  }
  for (int j = 0; j < kInputDim; ++j) {
    Input up = u, um = u;
    up[j] += h;
    um[j] -= h;
    const State col = (derivative(s, up, wind, p) - derivative(s, um, wind, p)) / (2 * h);
    for (int i = 0; i < kStateDim; ++i) EXPECT_NEAR(J.B(i, j), col[i], 1e-7) << i << "," << j;
  }
  for (int j = 0; j < 3; ++j) {
    Vec3 wp = wind, wm = wind;
    wp[j] += h;
    wm[j] -= h;
    const State col = (derivative(s, u, wp, p) - derivative(s, u, wm, p)) / (2 * h);
    for (int i = 0; i < kStateDim; ++i) EXPECT_NEAR(J.E(i, j), col[i], 1e-7) << i << "," << j;
  }
}

TEST(VehicleModel, DiscreteJacobiansAreTheEulerStepsDerivatives) {
  const VehicleParams p = default_params();
  const State s = make_state(-1.0, 10.0, 0.1, 0.3);
  const Input u(10.0, 0.0, 0.0);
  const double dt = 0.1, h = 1e-6;
  const Jacobians J = discrete_jacobians(s, p, dt);
  for (int j = 0; j < kStateDim; ++j) {
    State sp = s, sm = s;
    sp[j] += h;
    sm[j] -= h;
    const State col =
        (euler_step(sp, u, Vec3::Zero(), p, dt) - euler_step(sm, u, Vec3::Zero(), p, dt)) / (2 * h);
    for (int i = 0; i < kStateDim; ++i) EXPECT_NEAR(J.A(i, j), col[i], 1e-7);
  }
}

// The tracker writes B_d and E_d once and only A_d each step (src/mpc/uav_tracker.cpp), which
// holds while the input and wind enter eq. 4 linearly with constant gains: exactly equal.
TEST(VehicleModel, DiscreteInputAndWindJacobiansDoNotDependOnTheState) {
  const VehicleParams p = default_params();
  const Jacobians J0 = discrete_jacobians(State::Zero(), p, 0.1);
  for (const State& s : {make_state(2.1, 11.0, -0.2, 0.8), make_state(-3.0, 7.5, 0.4, -1.9)}) {
    const Jacobians J = discrete_jacobians(s, p, 0.1);
    EXPECT_EQ(J.B, J0.B);
    EXPECT_EQ(J.E, J0.E);
  }
}

// The tracker writes A_d once and then only its state-dependent entries each step: each must
// be the full Jacobian at its new state, whatever state A_d was built at (an entry missed would
// keep the old state's value; a heading of 0 makes sin ψ an exact zero). The constant entries
// are equal exactly; the four from the heading's sine and cosine, taken four at a time, to a few
// ulp. 37 states: two full batches of sines and cosines and a tail of five, headings over many
// turns.
TEST(VehicleModel, UpdatedDiscreteStateJacobiansEqualTheFullOnes) {
  const VehicleParams p = default_params();
  constexpr int kCount = 37;
  Eigen::MatrixXd states(kStateDim, kCount);
  for (int j = 0; j < kCount; ++j) {
    const double psi = j == 0 ? 0.0 : -40.0 + 2.3 * j + 0.01 * j * j;
    states.col(j) = make_state(psi, 5.0 + 0.27 * j, 0.1 - 0.01 * j, 0.3 * std::sin(j));
  }
  const Eigen::MatrixXd built = discrete_state_jacobian(make_state(0.7, 9.0, 0.1, 0.2), p, 0.1);
  std::vector<Eigen::MatrixXd> A(kCount + 1, built);  // one more than the states: untouched
  update_discrete_state_jacobians(states, 0.1, A);
  for (int j = 0; j < kCount; ++j) {
    const Eigen::MatrixXd full = discrete_state_jacobian(states.col(j), p, 0.1);
    for (int r = 0; r < kStateDim; ++r) {
      for (int c = 0; c < kStateDim; ++c) {
        const bool from_heading = (r == kX || r == kY) && (c == kPsi || c == kV);
        if (from_heading) {
          EXPECT_NEAR(A[j](r, c), full(r, c), 1e-15 * std::max(1.0, std::abs(full(r, c))))
              << "state " << j << " entry (" << r << ", " << c << ")";
        } else {
          EXPECT_EQ(A[j](r, c), full(r, c)) << "state " << j << " entry (" << r << ", " << c << ")";
        }
      }
    }
  }
  EXPECT_EQ(A[kCount], built);
  EXPECT_EQ(A[0](kY, kV), 0.0);  // sin 0, exactly
}

TEST(VehicleModel, ClampRespectsSpeedTurnClimbAndPitchLimits) {
  VehicleParams p = default_params();
  p.max_pitch_rad = deg_to_rad(10.0);  // makes the pitch limit tighter than w_max at 10 m/s
  const State s = make_state(0.0, 10.0, 0.0, 0.0);
  const Input clamped = clamp_to_limits(Input(30.0, 5.0, 10.0), s, p);
  EXPECT_DOUBLE_EQ(clamped[kSpeedCmd], p.max_speed_m_s());
  EXPECT_DOUBLE_EQ(clamped[kTurnRateCmd], 10.0 / p.min_turn_radius_m);
  EXPECT_NEAR(clamped[kClimbRateCmd], 10.0 * std::tan(deg_to_rad(10.0)), 1e-12);
  const Input low = clamp_to_limits(Input(0.0, -5.0, -10.0), s, p);
  EXPECT_DOUBLE_EQ(low[kSpeedCmd], p.min_speed_m_s());
  EXPECT_DOUBLE_EQ(low[kTurnRateCmd], -1.0);
  EXPECT_LT(std::abs(std::atan2(low[kClimbRateCmd], 10.0)), p.max_pitch_rad + 1e-12);
  // Inside the limits a command passes unchanged.
  const Input ok(11.0, 0.2, 0.5);
  EXPECT_EQ(clamp_to_limits(ok, s, p), ok);
}

}  // namespace
}  // namespace ridgeline::vehicle
