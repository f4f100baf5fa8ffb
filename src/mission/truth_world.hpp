// The simulator's truth: every UAV's dynamics integrated with RK4 in the real wind field,
// the sudden threats' motion, and what the sensors report (DESIGN §4, issue "main job").
//
// The truth deliberately differs from what the controllers believe: its first-order lags are
// `time_constant_scale` times the controller's τ (model mismatch), positions are measured with
// Gaussian noise, and the wind through each UAV's own noisy anemometer. Commands are held
// between control steps (zero-order hold). Deterministic for a seed.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "core/random.hpp"
#include "mission/scenario.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"
#include "world/wind.hpp"

namespace ridgeline::mission {

class TruthWorld {
 public:
  /// Builds the truth of `scenario` over `terrain` (shared with whoever else needs it).
  TruthWorld(const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain);

  int num_uavs() const { return static_cast<int>(uavs_.size()); }
  double time_s() const { return time_s_; }

  /// Sets the command a UAV's flight controller follows from now on.
  void set_command(int uav, const vehicle::Input& command);
  /// The UAV stops and holds its position from now on (a multirotor hovering at the end of its
  /// mission); it is no longer integrated and its rates read zero.
  void hold(int uav);
  bool holding(int uav) const { return uavs_[static_cast<std::size_t>(uav)].holding; }
  /// Ends a hold: the UAV is integrated again from where it holds, leaving at the commanded
  /// horizontal speed v_c (hovering is outside the motion model's speed band, eq. 2, so the
  /// model cannot describe the acceleration out of it) with its turn and climb rates zero.
  /// For a UAV whose agent started late, or a finished one given new targets.
  void release(int uav, const vehicle::Input& command);
  /// External dynamics (sim/external_vehicles.hpp): from now on advance_to() only moves the
  /// clock and the UAVs' states come from set_state(); threats, wind and sensors stay here.
  void set_external_dynamics() { external_dynamics_ = true; }
  bool external_dynamics() const { return external_dynamics_; }
  /// A UAV's true state from its external vehicle.
  void set_state(int uav, const vehicle::State& state) {
    uavs_[static_cast<std::size_t>(uav)].state = state;
  }
  /// Integrates every UAV up to time t_s with fixed RK4 steps of 1/truth_rate_hz (the last
  /// step may be shorter, so any t_s is reached exactly).
  void advance_to(double t_s);

  const vehicle::State& true_state(int uav) const {
    return uavs_[static_cast<std::size_t>(uav)].state;
  }
  Vec3 true_position(int uav) const { return true_state(uav).head<3>(); }
  Vec3 true_wind(int uav) const;
  /// A state fix: the truth with N(0, σ²) noise on each position component.
  vehicle::State measured_state(int uav);
  /// The UAV's anemometer reading at its true position.
  Vec3 measured_wind(int uav);
  /// Indices of the threats this UAV senses now (active and their surface within range).
  void sensed_threats(int uav, std::vector<int>& out) const;

  const std::vector<world::Threat>& threats() const { return threats_; }
  const world::Terrain& terrain() const { return *terrain_; }
  const world::WindField& wind() const { return wind_; }
  /// The truth model's parameters of a UAV (its lags differ from the controller's).
  const vehicle::VehicleParams& truth_params(int uav) const {
    return uavs_[static_cast<std::size_t>(uav)].truth_params;
  }

 private:
  struct TruthUav {
    vehicle::State state;
    vehicle::Input command;
    vehicle::VehicleParams truth_params;
    double sensor_range_m;
    world::WindSensor anemometer;
    bool holding = false;
    // The wind last evaluated for this UAV, and where and when: the anemometer's reading at a
    // control step and the first truth step after it sample the same point (64 modes each).
    Vec3 wind_position_m = Vec3::Zero();
    double wind_time_s = std::numeric_limits<double>::quiet_NaN();
    Vec3 wind_m_s = Vec3::Zero();
  };
  /// The true wind at the UAV's position now, evaluated once per position and time.
  const Vec3& wind_at_uav(TruthUav& u);

  std::shared_ptr<const world::Terrain> terrain_;
  world::WindField wind_;
  std::vector<world::Threat> threats_;
  std::vector<TruthUav> uavs_;
  double step_s_;
  double position_noise_m_;
  double time_s_ = 0.0;
  bool external_dynamics_ = false;
  Rng position_noise_rng_;
};

}  // namespace ridgeline::mission
