#include "mpc/uav_tracker.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/cpu_clock.hpp"
#include "core/error.hpp"
#include "mpc/sphere_rows.hpp"

namespace ridgeline::mpc {

namespace {

using Clock = std::chrono::steady_clock;
using vehicle::kClimbRateCmd;
using vehicle::kOmega;
using vehicle::kPsi;
using vehicle::kSpeedCmd;
using vehicle::kTurnRateCmd;
using vehicle::kV;
using vehicle::kW;
using vehicle::kZ;

// Tolerance above which a change of the QP's command by clamping is reported: the interior
// point meets its bounds to ~1e-9 relative, so anything larger is a real clamp.
constexpr double kClampReportTolerance = 1e-6;

void require(bool ok, const char* field, const char* reason) {
  if (!ok) throw InputError(field, reason);
}

bool positive(double v) { return std::isfinite(v) && v > 0.0; }
bool non_negative(double v) { return std::isfinite(v) && v >= 0.0; }

IncrementalMpcDims tracker_dims(const UavTrackerOptions& o) {
  validate(o);
  IncrementalMpcDims d;
  d.state_dim = vehicle::kStateDim;
  d.input_dim = vehicle::kInputDim;
  d.output_dim = 3;
  d.disturbance_dim = 3;
  d.soft_row_capacity = o.prediction_horizon * (o.max_threats + o.max_neighbours + 1);
  d.slack_groups = kSoftConstraintKinds;
  return d;
}

IncrementalMpcOptions tracker_mpc_options(const UavTrackerOptions& o) {
  IncrementalMpcOptions m;
  m.prediction_horizon = o.prediction_horizon;
  m.control_horizon = o.control_horizon;
  m.output_weight = Vec3(o.weight_xy_per_m2, o.weight_xy_per_m2, o.weight_z_per_m2);
  m.terminal_output_weight = o.terminal_weight_factor * m.output_weight;
  m.move_weight = Vec3(o.weight_speed_move, o.weight_turn_move, o.weight_climb_move);
  m.slack_linear_weight = o.slack_linear_weight;
  m.slack_quadratic_weight = o.slack_quadratic_weight;
  m.qp_settings = o.qp_settings;
  m.time_parts = o.time_step_parts;
  return m;
}

// s_a + a·(s_b − s_a) with the heading interpolated along the shorter arc.
vehicle::State interpolate_state(const vehicle::State& sa, const vehicle::State& sb, double a) {
  vehicle::State s = sa + a * (sb - sa);
  s[kPsi] = sa[kPsi] + a * wrap_angle(sb[kPsi] - sa[kPsi]);
  return s;
}

}  // namespace

void validate(const UavTrackerOptions& o) {
  const vehicle::VehicleParams& v = o.vehicle;
  require(positive(v.cruise_speed_m_s), "vehicle.cruise_speed_m_s", "must be finite and > 0");
  require(non_negative(v.speed_band_m_s) && v.speed_band_m_s < v.cruise_speed_m_s,
          "vehicle.speed_band_m_s", "must be >= 0 and below the cruise speed");
  require(positive(v.min_turn_radius_m), "vehicle.min_turn_radius_m", "must be finite and > 0");
  require(positive(v.max_climb_rate_m_s), "vehicle.max_climb_rate_m_s", "must be finite and > 0");
  require(positive(v.max_pitch_rad) && v.max_pitch_rad < 0.5 * kPi, "vehicle.max_pitch_rad",
          "must be in (0, pi/2)");
  require(positive(v.tau_v_s) && positive(v.tau_omega_s) && positive(v.tau_w_s), "vehicle.tau_*_s",
          "time constants must be finite and > 0");
  require(positive(o.control_period_s), "control_period_s", "must be finite and > 0");
  require(positive(o.prediction_step_s), "prediction_step_s", "must be finite and > 0");
  require(o.prediction_horizon >= 1, "prediction_horizon", "must be >= 1");
  require(o.control_horizon >= 1 && o.control_horizon <= o.prediction_horizon, "control_horizon",
          "must satisfy 1 <= Nc <= Np");
  require(non_negative(o.weight_xy_per_m2) && non_negative(o.weight_z_per_m2) &&
              non_negative(o.terminal_weight_factor),
          "weight_xy_per_m2/weight_z_per_m2/terminal_weight_factor", "must be finite and >= 0");
  require(positive(o.weight_speed_move) && positive(o.weight_turn_move) &&
              positive(o.weight_climb_move),
          "weight_*_move", "move weights must be finite and > 0");
  require(positive(o.max_speed_cmd_rate_m_s2) && positive(o.max_turn_cmd_rate_rad_s2) &&
              positive(o.max_climb_cmd_rate_m_s2),
          "max_*_cmd_rate", "rate limits must be finite and > 0");
  require(non_negative(o.wind_error_bound_m_s), "wind_error_bound_m_s", "must be finite and >= 0");
  require(non_negative(o.max_robust_margin_m), "max_robust_margin_m", "must be finite and >= 0");
  require(non_negative(o.activation_distance_m), "activation_distance_m",
          "must be finite and >= 0");
  require(o.max_threats >= 0, "max_threats", "must be >= 0");
  require(o.max_neighbours >= 0, "max_neighbours", "must be >= 0");
  require(positive(o.slack_linear_weight), "slack_linear_weight", "must be finite and > 0");
  require(positive(o.slack_quadratic_weight), "slack_quadratic_weight", "must be finite and > 0");
  require(o.cpu_time_period_steps >= 0, "cpu_time_period_steps", "must be >= 0");
}

UavTracker::UavTracker(const UavTrackerOptions& options, const world::SafetyLimits& limits)
    : options_(options),
      limits_(limits),
      mpc_(tracker_dims(options), tracker_mpc_options(options)),
      np_(options.prediction_horizon),
      nc_(options.control_horizon) {
  world::validate(limits_);
  IncrementalMpcData& d = mpc_.data();
  d.C.setZero();
  d.C.leftCols(3).setIdentity();  // y = p (DESIGN §3)
  const vehicle::Jacobians J = vehicle::discrete_jacobians(vehicle::State::Zero(), options.vehicle,
                                                           options.prediction_step_s);
  // The wind increments and state offsets after the first step are zero (a held measurement,
  // one command between steps); step() writes the first columns only.
  d.disturbance_delta.setZero();
  d.state_offset.setZero();
  for (int j = 0; j < np_; ++j) {
    d.A[j] = J.A;  // the state-independent entries; step() rewrites the others
    d.B[j] = J.B;
    d.E[j] = J.E;
  }
  const int steps_per_prediction =
      static_cast<int>(std::ceil(options.prediction_step_s / options.control_period_s));
  // Room for calls a few times faster than the nominal period before the history gets short.
  history_.resize(4 * steps_per_prediction + 4);
  previous_states_ = MatX::Zero(vehicle::kStateDim, np_);
  nominal_states_ = MatX::Zero(vehicle::kStateDim, np_);
  nominal_positions_ = MatX::Zero(3, np_);
  reference_points_.resize(np_ + 1);
  nominal_by_axis_ = RowPoints::Zero(3, np_);
  centres_ = RowPoints::Zero(3, np_);
  directions_ = RowPoints::Zero(3, np_);
  distances_.resize(np_);
  bounds_.resize(np_);
  active_.resize(np_);
  // m_j, the robust margin for the wind speed's error over j + 1 prediction steps (DESIGN §3).
  robust_margins_.resize(np_);
  for (int j = 0; j < np_; ++j) {
    robust_margins_[j] =
        std::min(options.wind_error_bound_m_s * (j + 1) * options.prediction_step_s,
                 options.max_robust_margin_m);
  }
  terrain_heights_.resize(np_);
  terrain_gradients_.resize(np_);
  result_.predicted_positions_m = MatX::Zero(3, np_);
  result_.predicted_states = MatX::Zero(vehicle::kStateDim, np_);
  result_.prediction_step_s = options.prediction_step_s;
}

void UavTracker::reset(const vehicle::Input& initial_command) {
  history_size_ = 0;
  history_head_ = 0;
  have_previous_prediction_ = false;
  previous_command_ = initial_command;
  have_previous_command_ = true;
  mpc_.reset();
}

void UavTracker::record_applied_command(const vehicle::Input& applied) {
  if (history_size_ > 0) history_[history_head_].command = applied;
  previous_command_ = applied;
  have_previous_command_ = true;
  have_previous_prediction_ = false;
}

void UavTracker::push_history(const HistoryEntry& entry) {
  const int cap = static_cast<int>(history_.size());
  history_head_ = (history_head_ + 1) % cap;
  history_[history_head_] = entry;
  history_size_ = std::min(history_size_ + 1, cap);
}

bool UavTracker::increment_from_history(double t_s, const vehicle::State& state, const Vec3& wind,
                                        vehicle::State& delta_state, Vec3& delta_wind,
                                        vehicle::Input& mean_command) const {
  const int cap = static_cast<int>(history_.size());
  const auto entry = [&](int age) -> const HistoryEntry& {
    return history_[(history_head_ - age + cap) % cap];
  };
  const double target = t_s - options_.prediction_step_s;
  int oldest_needed = -1;  // age of the newest entry at or before the target time
  for (int age = 0; age < history_size_; ++age) {
    if (entry(age).t_s <= target + 1e-9) {
      oldest_needed = age;
      break;
    }
  }
  if (oldest_needed < 0 || !(t_s > entry(0).t_s)) return false;

  const HistoryEntry& older = entry(oldest_needed);
  vehicle::State s_then;
  Vec3 w_then;
  if (oldest_needed == 0) {
    // Calls further apart than Δt_p: interpolate between the last entry and now.
    const double a = (target - older.t_s) / (t_s - older.t_s);
    s_then = interpolate_state(older.state, state, a);
    w_then = older.wind_m_s + a * (wind - older.wind_m_s);
  } else {
    const HistoryEntry& newer = entry(oldest_needed - 1);
    const double a = (target - older.t_s) / (newer.t_s - older.t_s);
    s_then = interpolate_state(older.state, newer.state, a);
    w_then = older.wind_m_s + a * (newer.wind_m_s - older.wind_m_s);
  }
  delta_state = state - s_then;
  delta_state[kPsi] = wrap_angle(state[kPsi] - s_then[kPsi]);
  delta_wind = wind - w_then;

  // Mean of the piecewise-constant command over [t − Δt_p, t].
  vehicle::Input acc = vehicle::Input::Zero();
  for (int age = oldest_needed; age >= 0; --age) {
    const HistoryEntry& e = entry(age);
    const double begin = std::max(e.t_s, target);
    const double end = age == 0 ? t_s : entry(age - 1).t_s;
    acc += e.command * std::max(end - begin, 0.0);
  }
  mean_command = acc / (t_s - target);
  return true;
}

void UavTracker::build_nominal(double t_s, const vehicle::State& state,
                               const ReferenceTrajectory& ref) {
  const double dt = options_.prediction_step_s;
  ref.sample(t_s, dt, reference_points_);  // r(t + j·dt), j = 0..Np

  // Previous prediction: column i at previous_first_time_s_ + i·dt. Returns false when the
  // time lies beyond its end by more than one step (the reference is used there instead).
  const auto previous_state_at = [&](double tau, vehicle::State& out) {
    if (!have_previous_prediction_) return false;
    const double f = (tau - previous_first_time_s_) / dt;
    if (f > np_) return false;
    if (np_ < 2) {
      out = previous_states_.col(0);
      return true;
    }
    const int i = segment_index(f, np_ - 2);
    const vehicle::State sa = previous_states_.col(i);
    const vehicle::State sb = previous_states_.col(i + 1);
    out = sa + (f - i) * (sb - sa);  // headings of a prediction are continuous
    return true;
  };

  // Sample j (time t + j·dt) gives the nominal state j (j < Np) and the nominal position of
  // the constraints j − 1, both from one look-up of the previous prediction.
  // The columns are written through fixed-size maps: an assignment to a column of a dynamic
  // matrix is a copy of run-time length, which the compiler makes a call of memcpy (four a
  // sample, 1 % of a flight's instructions).
  const auto state_column = [this](int j) {
    return Eigen::Map<vehicle::State>(nominal_states_.col(j).data());
  };
  state_column(0) = state;
  double heading = state[kPsi];
  for (int j = 1; j <= np_; ++j) {
    const double tau = t_s + j * dt;
    vehicle::State previous = vehicle::State::Zero();  // written when have_previous
    const bool have_previous = previous_state_at(tau, previous);
    const ReferencePoint& r = reference_points_[j];
    Eigen::Map<Vec3>(nominal_positions_.col(j - 1).data()) =
        have_previous ? Vec3(previous.head<3>()) : r.position_m;
    if (j == np_) break;
    vehicle::State s;
    if (options_.linearization == LinearizationPoint::kPreviousPrediction && have_previous) {
      s = previous;
    } else {
      s << r.position_m, r.heading_rad, r.speed_m_s, r.turn_rate_rad_s, r.climb_rate_m_s;
    }
    heading += wrap_angle(s[kPsi] - heading);  // unwrap relative to the state (see header)
    s[kPsi] = heading;
    state_column(j) = s;
  }
}

void UavTracker::set_limits(const vehicle::State& state) {
  IncrementalMpcData& d = mpc_.data();
  const vehicle::VehicleParams& p = options_.vehicle;
  const double rates[3] = {options_.max_speed_cmd_rate_m_s2, options_.max_turn_cmd_rate_rad_s2,
                           options_.max_climb_cmd_rate_m_s2};
  // The pitch limit must hold on the vehicle whatever its speed does while the climb command
  // holds (measured: bounded by the nominal speed, a UAV slowing while it climbed away from a
  // neighbour flew 30.2° for 0.2 s). It depends on the vehicle only.
  const double max_climb = p.robust_max_climb_rate_m_s();
  for (int i = 0; i < nc_; ++i) {
    const double v_nominal = i == 0 ? state[kV] : nominal_states_(kV, i);
    const double speed = std::max(v_nominal, p.min_speed_m_s());
    const double max_turn = p.max_turn_rate_rad_s(speed);  // eq. 3
    d.input_min(kSpeedCmd, i) = p.min_speed_m_s();         // eq. 2
    d.input_max(kSpeedCmd, i) = p.max_speed_m_s();
    d.input_min(kTurnRateCmd, i) = -max_turn;
    d.input_max(kTurnRateCmd, i) = max_turn;
    d.input_min(kClimbRateCmd, i) = -max_climb;
    d.input_max(kClimbRateCmd, i) = max_climb;
    const double period = i == 0 ? options_.control_period_s : options_.prediction_step_s;
    for (int c = 0; c < 3; ++c) {
      d.move_min(c, i) = -rates[c] * period;
      d.move_max(c, i) = rates[c] * period;
    }
  }
  // Forward reachability of the rate-limited input: widen a limit that cannot be reached in
  // time to the middle of what can (a strict interior keeps the interior point well posed).
  for (int c = 0; c < 3; ++c) {
    double lo = previous_command_[c];
    double hi = previous_command_[c];
    for (int i = 0; i < nc_; ++i) {
      const double rlo = lo + d.move_min(c, i);
      const double rhi = hi + d.move_max(c, i);
      if (rhi < d.input_min(c, i)) {
        d.input_min(c, i) = 0.5 * (rlo + rhi);
        result_.limits_relaxed = true;
      }
      if (rlo > d.input_max(c, i)) {
        d.input_max(c, i) = 0.5 * (rlo + rhi);
        result_.limits_relaxed = true;
      }
      lo = std::max(rlo, d.input_min(c, i));
      hi = std::min(rhi, d.input_max(c, i));
    }
  }
}

void UavTracker::add_soft_rows(double t_s, const vehicle::State& state,
                               const TrackerEnvironment& env) {
  IncrementalMpcData& d = mpc_.data();
  d.clear_soft_rows();
  const double dt = options_.prediction_step_s;
  const double activation = options_.activation_distance_m;
  const Vec3 here = state.head<3>();
  // `source` tells the rows of one kind apart (which threat, which neighbour) so that the QP's
  // hot start follows each row from step to step; rows are added in (kind, source, step) order.
  const auto add = [&](int j, const Vec3& a, double b, SoftConstraintKind kind, int source) {
    if (d.add_soft_row(j, a.data(), b, static_cast<int>(kind), source)) {
      ++result_.soft_rows[static_cast<int>(kind)];
    }
  };
  // The nominal positions by coordinate, for the vector loops of the sphere rows.
  for (int j = 0; j < np_; ++j) {
    for (int i = 0; i < 3; ++i) nominal_by_axis_(i, j) = nominal_positions_(i, j);
  }
  // The active rows of one sphere whose centres are in centres_.
  const HorizonPoints nominal{nominal_by_axis_.row(0).data(), nominal_by_axis_.row(1).data(),
                              nominal_by_axis_.row(2).data()};
  const SphereRowsOut out{distances_.data(),
                          directions_.row(0).data(),
                          directions_.row(1).data(),
                          directions_.row(2).data(),
                          bounds_.data(),
                          active_.data()};
  const auto add_sphere_rows = [&](SphereSpec& sphere, SoftConstraintKind kind, int source) {
    sphere.centres = {centres_.row(0).data(), centres_.row(1).data(), centres_.row(2).data()};
    sphere.activation_m = activation;
    sphere.t_s = t_s;
    sphere.dt_s = dt;
    sphere_rows(nominal, sphere, np_, out);
    for (int j = 0; j < np_; ++j) {
      if (active_[j] == 0) continue;
      if (distances_[j] > 1e-6) {
        add(j, directions_.col(j), bounds_[j], kind, source);
        continue;
      }
      // p̄_j sits on the centre: the normal points to the UAV's current position, or up.
      const Vec3 c = centres_.col(j);
      const Vec3 diff = here - c;
      const Vec3 n = diff.norm() > 1e-6 ? Vec3(diff.normalized()) : Vec3(Vec3::UnitZ());
      const double need =
          sphere.margins != nullptr ? sphere.required_m + sphere.margins[j] : sphere.required_m;
      add(j, n, n.dot(c) + need, kind, source);
    }
  };

  const int num_threats = std::min<int>(static_cast<int>(env.threats.size()), options_.max_threats);
  result_.dropped_threats = static_cast<int>(env.threats.size()) - num_threats;
  for (int k = 0; k < num_threats; ++k) {
    const world::Threat& threat = env.threats[k];
    moving_centres(threat.centre_m, threat.velocity_m_s, threat.appear_s, t_s, dt, np_,
                   centres_.row(0).data(), centres_.row(1).data(), centres_.row(2).data());
    SphereSpec sphere;
    sphere.margins = robust_margins_.data();
    sphere.required_m = threat.radius_m + limits_.threat_margin_m;
    sphere.windowed = true;
    sphere.from_s = threat.appear_s;
    sphere.to_s = threat.vanish_s;
    add_sphere_rows(sphere, SoftConstraintKind::kThreat, k);
  }

  const int num_neighbours =
      std::min<int>(static_cast<int>(env.neighbours.size()), options_.max_neighbours);
  result_.dropped_neighbours = static_cast<int>(env.neighbours.size()) - num_neighbours;
  for (int k = 0; k < num_neighbours; ++k) {
    const messages::PredictedTrajectory& nb = env.neighbours[k];
    if (nb.positions_m.empty() || !(nb.step_s > 0.0)) {
      ++result_.dropped_neighbours;
      continue;
    }
    const double separation = static_cast<std::size_t>(k) < env.neighbour_separation_m.size()
                                  ? env.neighbour_separation_m[static_cast<std::size_t>(k)]
                                  : limits_.separation_m;
    for (int j = 0; j < np_; ++j) {
      centres_.col(j) = messages::predicted_position(nb, t_s + (j + 1) * dt);
    }
    SphereSpec sphere;
    sphere.margins = nullptr;
    sphere.required_m = separation;
    add_sphere_rows(sphere, SoftConstraintKind::kNeighbour, k);
  }

  if (env.terrain != nullptr) {
    const double model_error = env.terrain->model_error_m();
    env.terrain->heights_and_gradients(nominal_positions_, terrain_heights_, terrain_gradients_);
    for (int j = 0; j < np_; ++j) {
      const Vec3 pbar = nominal_positions_.col(j);
      const Vec2& g = terrain_gradients_[j];
      const double h = terrain_heights_[j];
      const double required = limits_.terrain_clearance_m + robust_margins_[j] + model_error;
      if (pbar.z() - h - required > activation) continue;
      // z − ∇H·(p − p̄)_xy ≥ H(p̄) + h_safe + m_j + e_H
      add(j, Vec3(-g.x(), -g.y(), 1.0), h + required - g.dot(pbar.head<2>()),
          SoftConstraintKind::kTerrain, 0);
    }
  }
}

const UavTrackerResult& UavTracker::step(double t_s, const vehicle::State& state,
                                         const Vec3& measured_wind_m_s,
                                         const ReferenceTrajectory& reference,
                                         const TrackerEnvironment& environment) {
  // The thread's CPU clock is a system call (about 0.5 µs on a virtual machine, as long as a
  // tenth of a step): read outside the wall-clock window, so that the step's wall time and
  // its parts are the step's own. The CPU time spans both readings' ends.
  const int period = options_.cpu_time_period_steps;
  const bool time_cpu = period > 0 && steps_ % period == 0;
  ++steps_;
  const double cpu_start_s = time_cpu ? thread_cpu_time_s() : 0.0;
  const auto start = Clock::now();
  const vehicle::VehicleParams& p = options_.vehicle;
  const double dt = options_.prediction_step_s;
  result_.command_clamped = false;
  result_.limits_relaxed = false;
  result_.fallback = false;
  result_.increment_from_model = false;
  result_.soft_rows.fill(0);
  result_.slack_m.fill(0.0);

  if (!have_previous_command_) {
    // Without a command history, start from what the vehicle is doing (no jump).
    previous_command_ =
        vehicle::clamp_to_limits(vehicle::Input(state[kV], state[kOmega], state[kW]), state, p);
    have_previous_command_ = true;
  }
  const vehicle::Input u_prev = previous_command_;

  // 1. Measured increment (or the model's, at start-up).
  vehicle::State delta_state;
  Vec3 delta_wind;
  vehicle::Input mean_command;
  if (!increment_from_history(t_s, state, measured_wind_m_s, delta_state, delta_wind,
                              mean_command)) {
    delta_state = dt * vehicle::derivative(state, u_prev, measured_wind_m_s, p);
    delta_wind.setZero();
    mean_command = u_prev;
    result_.increment_from_model = true;
  }
  IncrementalMpcData& d = mpc_.data();
  d.delta_state = delta_state;
  d.output = state.head<3>();
  d.state = state;
  d.previous_input = u_prev;

  // 2–4. Nominal trajectory, Jacobians, wind feed-forward, reference.
  build_nominal(t_s, state, reference);
  // B_j, E_j and all but four entries of A_j do not depend on the state (eq. 4): the
  // constructor wrote them once.
  vehicle::update_discrete_state_jacobians(nominal_states_, dt, d.A);
  for (int j = 0; j < np_; ++j) d.reference.col(j) = reference_points_[j + 1].position_m;
  // Only the first columns are ever written (the constructor zeroed the others).
  Eigen::Map<Vec3>(d.disturbance_delta.col(0).data()) = delta_wind;
  Eigen::Map<vehicle::State>(d.state_offset.col(0).data()).noalias() =
      d.B[0] * (u_prev - mean_command);
  const bool time_parts = options_.time_step_parts;
  const auto linearized = time_parts ? Clock::now() : Clock::time_point{};

  // 5–6. Limits and soft rows.
  set_limits(state);
  const auto limited = time_parts ? Clock::now() : Clock::time_point{};
  add_soft_rows(t_s, state, environment);
  const auto soft_rows_added = time_parts ? Clock::now() : Clock::time_point{};

  // 7. Solve and apply.
  const IncrementalMpcResult& r = mpc_.solve();
  result_.qp_status = r.qp_status;
  result_.qp_iterations = r.qp_iterations;
  result_.qp_time_us = r.qp_time_us;
  result_.soft_rows_in_qp = r.soft_rows_in_qp;
  vehicle::Input u = u_prev;
  if (r.solved()) {
    u = r.first_input;
  } else {
    result_.fallback = true;  // r holds the zero-move plan: the previous command held
  }
  vehicle::Input u_cmd = u;
  const double rates[3] = {options_.max_speed_cmd_rate_m_s2, options_.max_turn_cmd_rate_rad_s2,
                           options_.max_climb_cmd_rate_m_s2};
  for (int c = 0; c < 3; ++c) {
    const double step_max = rates[c] * options_.control_period_s;
    u_cmd[c] = std::clamp(u_cmd[c], u_prev[c] - step_max, u_prev[c] + step_max);
  }
  u_cmd = vehicle::clamp_to_limits(u_cmd, state, p);  // eq. 2–3 win over the rate limit
  result_.command_clamped = (u_cmd - u).cwiseAbs().maxCoeff() > kClampReportTolerance;
  result_.command = u_cmd;

  result_.predicted_positions_m = r.predicted_outputs;
  result_.predicted_states = r.predicted_states;
  result_.first_prediction_time_s = t_s + dt;
  for (int g = 0; g < kSoftConstraintKinds; ++g) result_.slack_m[g] = r.slack[g];

  previous_states_ = r.predicted_states;
  previous_first_time_s_ = t_s + dt;
  have_previous_prediction_ = true;
  push_history(HistoryEntry{t_s, state, measured_wind_m_s, u_cmd});
  previous_command_ = u_cmd;
  const auto us = [](Clock::duration d) {
    return std::chrono::duration<double, std::micro>(d).count();
  };
  result_.step_time_us = us(Clock::now() - start);
  UavTrackerStepParts& parts = result_.parts;
  if (time_parts) {
    parts.linearization_us = us(linearized - start);
    parts.condensing_us = r.condensing_time_us;
    parts.soft_rows_us = us(soft_rows_added - limited) + r.soft_rows_time_us;
    parts.qp_us = r.qp_time_us;
    parts.other_us = result_.step_time_us - parts.linearization_us - parts.condensing_us -
                     parts.soft_rows_us - parts.qp_us;
  } else {
    constexpr double kUntimed = std::numeric_limits<double>::quiet_NaN();
    parts = {kUntimed, kUntimed, kUntimed, kUntimed, kUntimed};
  }
  result_.step_cpu_time_us = time_cpu ? (thread_cpu_time_s() - cpu_start_s) * 1e6
                                      : std::numeric_limits<double>::quiet_NaN();
  return result_;
}

}  // namespace ridgeline::mpc
