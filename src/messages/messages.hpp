// The messages UAVs and the ground station exchange (DESIGN §1): their one C++ definition,
// used by the in-process transport and the agents (swarm/), the DDS transport's conversions
// (transport_dds/) and the tracker (mpc/, which reads neighbours' PredictedTrajectory as they
// arrive). Agents never reach into each other's memory: everything they learn about one
// another arrives as one of these, through a Transport, so every field is a plain value.
#pragma once

#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/types.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::messages {

/// A UAV's MPC prediction, broadcast every 10 ms: positions at stamp + k·step, k = 1..Np.
struct PredictedTrajectory {
  int uav = -1;
  double stamp_s = 0.0;
  double step_s = 0.1;  ///< > 0
  std::vector<Vec3> positions_m;
};

/// The predicted position at time t (needs ≥ 1 position): linear between the samples, the
/// nearest segment extended outside them.
Vec3 predicted_position(const PredictedTrajectory& prediction, double t_s);

/// A sensed sudden threat (eq. 13): sphere of `radius_m` whose centre is `centre_m` at
/// `stamp_s` and moves at `velocity_m_s`.
struct ThreatReport {
  int reporter = -1;
  int threat_id = -1;
  double stamp_s = 0.0;
  Vec3 centre_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  double radius_m = 0.0;
};

/// A UAV's measured state.
struct StateReport {
  int uav = -1;
  double stamp_s = 0.0;
  vehicle::State state = vehicle::State::Zero();
};

/// The ground station's reference for one UAV: waypoints passed at the given times.
struct ReferencePlan {
  int uav = -1;
  double stamp_s = 0.0;
  std::vector<Vec3> waypoints_m;
  std::vector<double> times_s;
};

using Message = std::variant<PredictedTrajectory, ThreatReport, StateReport, ReferencePlan>;

/// A message as delivered: who sent it and when.
struct Envelope {
  int sender = -1;
  double sent_s = 0.0;
  double delivered_s = 0.0;
  Message message;
};

/// Checks a received message before anyone acts on it: finite numbers, sizes within bounds,
/// ids within [0, num_uavs), positive radius and step, times consistent. Returns the reason
/// a message is rejected, or nothing when it is acceptable.
std::optional<std::string> check_message(const Message& message, int num_uavs,
                                         std::size_t max_points = 1000);

/// Name of the message type ("PredictedTrajectory", ...), for logs and counters.
const char* message_type_name(const Message& message);

}  // namespace ridgeline::messages
