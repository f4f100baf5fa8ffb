// UAV dynamics integrated outside the mission's truth world: for example one MAVLink vehicle
// process per UAV (`ridgeline run --mavlink`). The mission still owns everything else — the
// threats, the wind field, the sensors (noisy position fixes, anemometers, threat sensing),
// the transport between the agents and the metrics — so a flight through external vehicles is
// measured exactly like an in-process one; only the integration of eq. 1 moves out.
//
// Protocol (lock step): start() brings every vehicle to mission time 0 and reports its state;
// then every control period step() hands every UAV's command for [t, t + Δt) (or a hold) and
// returns the states at t + Δt. Δt is the scenario's mpc.control_period_s.
#pragma once

#include <vector>

#include "core/types.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::sim {

/// What a vehicle reports (ENU, the scenario's frame): its position, its ground velocity (the
/// wind's drift included), its heading ψ and turn rate ω.
struct VehicleReport {
  Vec3 position_m = Vec3::Zero();
  Vec3 ground_velocity_m_s = Vec3::Zero();
  double heading_rad = 0.0;
  double turn_rate_rad_s = 0.0;
};

/// What a UAV's vehicle is asked to do for one control period.
struct VehicleCommand {
  vehicle::Input command = vehicle::Input::Zero();
  bool hold = false;  ///< stop and hold at the current position (a finished UAV)
};

class ExternalVehicles {
 public:
  virtual ~ExternalVehicles() = default;
  /// Brings every vehicle to mission time 0 (armed, flying, ready to step); `out` gets one
  /// report per UAV in the scenario's order. Throws std::runtime_error naming the UAV on failure.
  virtual void start(std::vector<VehicleReport>& out) = 0;
  /// Control step `step` at mission time t_s: UAV i follows commands[i] for one control
  /// period; `out` gets the reports at t_s + period. Throws std::runtime_error naming the UAV
  /// when a vehicle does not answer or leaves the flight.
  virtual void step(long long step, double t_s, const std::vector<VehicleCommand>& commands,
                    std::vector<VehicleReport>& out) = 0;
};

}  // namespace ridgeline::sim
