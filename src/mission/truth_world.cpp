#include "mission/truth_world.hpp"

#include <algorithm>

namespace ridgeline::mission {
namespace {
constexpr std::uint64_t kPositionNoiseStream = 11;
}  // namespace

TruthWorld::TruthWorld(const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain)
    : terrain_(std::move(terrain)),
      wind_(scenario.wind),
      threats_(scenario.threats),
      step_s_(1.0 / scenario.simulation.truth_rate_hz),
      position_noise_m_(scenario.simulation.position_noise_m),
      position_noise_rng_(derive_seed(scenario.seed, kPositionNoiseStream)) {
  const double scale = scenario.simulation.truth_time_constant_scale;
  for (std::size_t i = 0; i < scenario.uavs.size(); ++i) {
    const UavSpec& spec = scenario.uavs[i];
    vehicle::State s = vehicle::State::Zero();
    s.head<3>() = spec.start_position_m;
    s[vehicle::kPsi] = spec.start_heading_rad;
    s[vehicle::kV] = spec.start_speed_m_s;
    vehicle::VehicleParams truth = spec.vehicle;
    truth.tau_v_s *= scale;
    truth.tau_omega_s *= scale;
    truth.tau_w_s *= scale;
    const vehicle::Input hold(spec.start_speed_m_s, 0.0, 0.0);
    uavs_.push_back(
        TruthUav{s, hold, truth, spec.sensor_range_m, world::WindSensor(scenario.wind, i)});
  }
}

void TruthWorld::set_command(int uav, const vehicle::Input& command) {
  uavs_[static_cast<std::size_t>(uav)].command = command;
}

void TruthWorld::release(int uav, const vehicle::Input& command) {
  TruthUav& u = uavs_[static_cast<std::size_t>(uav)];
  u.holding = false;
  u.command = command;
  u.state[vehicle::kV] = command[0];
  u.state[vehicle::kOmega] = 0.0;
  u.state[vehicle::kW] = 0.0;
}

void TruthWorld::hold(int uav) {
  TruthUav& u = uavs_[static_cast<std::size_t>(uav)];
  u.holding = true;
  u.state[vehicle::kV] = 0.0;
  u.state[vehicle::kOmega] = 0.0;
  u.state[vehicle::kW] = 0.0;
  u.command = vehicle::Input::Zero();
}

void TruthWorld::advance_to(double t_s) {
  while (time_s_ < t_s) {
    const double dt = std::min(step_s_, t_s - time_s_);
    // Sub-nanosecond remainders come from floating-point time sums; skip them.
    if (dt < 1e-9) {
      time_s_ = t_s;
      break;
    }
    for (TruthUav& u : uavs_) {
      if (u.holding || external_dynamics_) continue;
      // The wind is sampled at the step's start: its correlation time (seconds) is far
      // longer than the 5 ms step.
      const Vec3 w = wind_at_uav(u);
      u.state = vehicle::rk4_step(u.state, u.command, w, u.truth_params, dt);
    }
    time_s_ += dt;
  }
}

const Vec3& TruthWorld::wind_at_uav(TruthUav& u) {
  if (!(u.wind_time_s == time_s_ && u.wind_position_m == u.state.head<3>())) {
    u.wind_position_m = u.state.head<3>();
    u.wind_time_s = time_s_;
    u.wind_m_s = wind_.at(u.wind_position_m, time_s_);
  }
  return u.wind_m_s;
}

Vec3 TruthWorld::true_wind(int uav) const { return wind_.at(true_position(uav), time_s_); }

vehicle::State TruthWorld::measured_state(int uav) {
  vehicle::State s = true_state(uav);
  for (int k = 0; k < 3; ++k) s[k] += position_noise_rng_.normal(0.0, position_noise_m_);
  return s;
}

Vec3 TruthWorld::measured_wind(int uav) {
  TruthUav& u = uavs_[static_cast<std::size_t>(uav)];
  return u.anemometer.corrupt(wind_at_uav(u));
}

void TruthWorld::sensed_threats(int uav, std::vector<int>& out) const {
  out.clear();
  const TruthUav& u = uavs_[static_cast<std::size_t>(uav)];
  for (std::size_t k = 0; k < threats_.size(); ++k) {
    if (threats_[k].sensed_by(u.state.head<3>(), u.sensor_range_m, time_s_))
      out.push_back(static_cast<int>(k));
  }
}

}  // namespace ridgeline::mission
