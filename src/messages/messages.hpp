// The messages UAVs and the ground station exchange (DESIGN §1): their one definition, used by
// the in-process transport and the agents (swarm/), the tracker (mpc/, which reads neighbours'
// PredictedTrajectory as they arrive) and the DDS transport, whose IDL and conversions are
// generated from the RIDGELINE_WIRE_FIELDS lists below (wire_fields.hpp). Agents never reach
// into each other's memory: everything they learn about one another arrives as one of these,
// through a Transport, so every field is a plain value. Units: SI (m, s, rad), positions ENU.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/types.hpp"
#include "messages/wire_fields.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::messages {

/// A UAV's MPC prediction, broadcast every 10 ms: positions at stamp + k·step, k = 1..Np.
struct PredictedTrajectory {
  int uav = -1;
  double stamp_s = 0.0;
  double step_s = 0.1;  ///< > 0
  std::vector<Vec3> positions_m;
  /// The sender's intent (swarm/agent.hpp, the separation protocol): where its reference
  /// will be at intent_start_s + k·intent_step_s, k = 0.., beyond the MPC's short horizon —
  /// its separation level and delay included. Empty when the sender publishes none.
  double intent_start_s = 0.0;
  double intent_step_s = 1.0;  ///< > 0
  std::vector<Vec3> intent_m{};
  /// Grows whenever the sender changes its reference (level, delay, detour): a receiver that
  /// yields to it re-plans at once instead of at its next periodic re-plan.
  int intent_revision = 0;
};
RIDGELINE_WIRE_FIELDS(PredictedTrajectory, "PredictedTrajectory", uav, stamp_s, step_s, positions_m,
                      intent_start_s, intent_step_s, intent_m, intent_revision)

/// The predicted position at time t (needs ≥ 1 position): linear between the samples, the
/// nearest segment extended outside them. Inline: a tracker reads each neighbour's at every
/// step of its horizon, and a call each (its division and look-up in one chain) cost as much as
/// the separation rows it feeds.
inline Vec3 predicted_position(const PredictedTrajectory& prediction, double t_s) {
  const std::vector<Vec3>& p = prediction.positions_m;
  const int n = static_cast<int>(p.size());
  if (n == 1) return p.front();
  const double first_time_s = prediction.stamp_s + prediction.step_s;  // k = 1
  const double f = (t_s - first_time_s) / prediction.step_s;
  const int i = segment_index(f, n - 2);  // outside the samples: the nearest segment, extrapolated
  const double a = f - i;
  return p[i] + a * (p[i + 1] - p[i]);
}

/// Where the sender expects to be at t: its MPC prediction while t is inside it, then its
/// intent (linear between samples), then the intent's last segment (or, without an intent,
/// the prediction's mean horizontal velocity at its last altitude) extended.
Vec3 expected_position(const PredictedTrajectory& prediction, double t_s);

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
RIDGELINE_WIRE_FIELDS(ThreatReport, "ThreatReport", reporter, threat_id, stamp_s, centre_m,
                      velocity_m_s, radius_m)

/// A UAV's measured state.
struct StateReport {
  int uav = -1;
  double stamp_s = 0.0;
  vehicle::State state = vehicle::State::Zero();  ///< s = [x, y, z, ψ, v, ω, w] (eq. 1)
};
RIDGELINE_WIRE_FIELDS(StateReport, "State", uav, stamp_s, state)

/// One sample of a reference r(t): where the UAV should be and how it should be moving.
struct ReferencePoint {
  Vec3 position_m = Vec3::Zero();
  double heading_rad = 0.0;
  double speed_m_s = 0.0;        ///< horizontal speed
  double turn_rate_rad_s = 0.0;  ///< ψ̇
  double climb_rate_m_s = 0.0;   ///< ż
};
RIDGELINE_WIRE_FIELDS(ReferencePoint, "ReferencePoint", position_m, heading_rad, speed_m_s,
                      turn_rate_rad_s, climb_rate_m_s)

/// The ground station's reference for one UAV: the time-parametrized reference r_i(t) itself
/// (so an agent tracks exactly what was planned) and its targets in visiting order. A re-plan
/// (re-allocation after a UAV is lost) is a newer version.
struct ReferencePlan {
  int uav = -1;
  int version = 0;  ///< grows with every re-plan
  double stamp_s = 0.0;
  std::vector<double> times_s;         ///< strictly increasing, ≥ 2
  std::vector<ReferencePoint> points;  ///< one per time
  std::vector<int> target_ids;         ///< indices into the scenario's targets
};
RIDGELINE_WIRE_FIELDS(ReferencePlan, "ReferencePlan", uav, version, stamp_s, times_s, points,
                      target_ids)

/// The most samples a received plan may hold (a 600 s plan at 20 ms is 30 000).
inline constexpr std::size_t kMaxPlanSamples = 200000;

/// The reason a plan is rejected (ids, sizes, finite values, increasing times, target ids in
/// [0, num_targets)), or nothing.
std::optional<std::string> check_plan(const ReferencePlan& plan, int num_uavs, int num_targets,
                                      std::size_t max_samples = kMaxPlanSamples);

using Message = std::variant<PredictedTrajectory, ThreatReport, StateReport, ReferencePlan>;

/// A message as delivered: who sent it and when. The message is held by a shared, immutable
/// copy: a broadcast reaches every receiver (and a receiver keeps a neighbour's prediction)
/// without copying its ~2 kB of positions once a receiver.
struct Envelope {
  /// Shares `shared` (not null).
  Envelope(int sender_id, double sent, double delivered, std::shared_ptr<const Message> shared)
      : sender(sender_id), sent_s(sent), delivered_s(delivered), payload(std::move(shared)) {}
  /// Holds its own copy of `message`.
  Envelope(int sender_id, double sent, double delivered, Message message)
      : Envelope(sender_id, sent, delivered, std::make_shared<const Message>(std::move(message))) {}

  const Message& message() const { return *payload; }

  int sender = -1;
  double sent_s = 0.0;
  double delivered_s = 0.0;
  std::shared_ptr<const Message> payload;  ///< never null
};

/// Checks a received message before anyone acts on it: finite numbers, sizes within bounds
/// (`max_points` predicted positions), ids within [0, num_uavs), positive radius and step,
/// times consistent (a plan: check_plan with any non-negative target id). Returns the reason a
/// message is rejected, or nothing when it is acceptable.
std::optional<std::string> check_message(const Message& message, int num_uavs,
                                         std::size_t max_points = 1000);

/// Name of the message type ("PredictedTrajectory", ...), for logs and counters.
const char* message_type_name(const Message& message);

}  // namespace ridgeline::messages
