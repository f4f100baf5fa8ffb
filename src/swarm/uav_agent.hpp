// The on-board agent as the mission loop sees it (DESIGN §1): whatever flies a UAV — the
// proposed MPC agent (agent.hpp) or a comparison method (src/baselines/) — receives messages,
// senses threats, computes one command per control period and broadcasts a prediction. The
// truth simulator, the transport, the metrics and the outputs are shared by every method;
// only what is behind this interface differs.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "messages/wire_fields.hpp"
#include "mpc/uav_tracker.hpp"
#include "swarm/messages.hpp"
#include "vehicle/vehicle_model.hpp"

namespace ridgeline::swarm {

struct AgentTarget {
  std::string name;
  Vec3 position_m = Vec3::Zero();
  double radius_m = 30.0;         ///< 3-D distance of a pass that counts
  double altitude_band_m = 30.0;  ///< |z − z_target| of a pass that counts
};

/// What the agent's own sensor reports of a threat (centre at the time of sensing).
struct ThreatObservation {
  int threat_id = -1;
  Vec3 centre_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  double radius_m = 0.0;
};
RIDGELINE_WIRE_FIELDS(ThreatObservation, "SensedThreat", threat_id, centre_m, velocity_m_s,
                      radius_m)

enum class AgentMode { kTracking, kFallback, kFinished };
const char* to_string(AgentMode mode);

struct AgentCounters {
  std::uint64_t messages_received = 0;
  std::uint64_t messages_rejected = 0;
  std::uint64_t stale_neighbour_steps = 0;  ///< control steps that used a stale prediction
  std::uint64_t replans = 0;                ///< detours planned (baselines: avoidance steps)
  std::uint64_t neighbour_conflicts = 0;    ///< re-plans that yielded to a neighbour
  std::uint64_t replan_failures = 0;
  std::uint64_t optimizer_replans = 0;    ///< of `replans`, made by the local optimizer
  std::uint64_t optimizer_fallbacks = 0;  ///< optimizer failures handed to the detour
  std::uint64_t rejoins = 0;
  std::uint64_t level_changes = 0;  ///< separation levels chosen (agent.hpp)
  std::uint64_t delay_changes = 0;  ///< separation delays chosen (agent.hpp)
  std::uint64_t reapproaches = 0;   ///< blocked targets approached again (agent.hpp)
  std::uint64_t fallback_steps = 0;
  std::uint64_t guard_steps = 0;  ///< steps flown on the separation guard's escape (agent.hpp)
  std::uint64_t qp_failures = 0;
  std::uint64_t threat_reports_sent = 0;
};
RIDGELINE_WIRE_FIELDS(AgentCounters, "AgentCounters", messages_received, messages_rejected,
                      stale_neighbour_steps, replans, neighbour_conflicts, replan_failures,
                      optimizer_replans, optimizer_fallbacks, rejoins, level_changes, delay_changes, reapproaches, fallback_steps, guard_steps, qp_failures,
                      threat_reports_sent)

struct AgentStep {
  vehicle::Input command = vehicle::Input::Zero();
  AgentMode mode = AgentMode::kTracking;
  Vec3 reference_m = Vec3::Zero();                 ///< r(t) the agent tracked at this step
  const mpc::UavTrackerResult* tracker = nullptr;  ///< valid until the next control()
  double max_slack_m = 0.0;
  /// Computation time of this step (µs) for agents without an MPC tracker; < 0: not measured.
  double step_time_us = -1.0;
};

/// One UAV's on-board agent, whatever its method.
class UavAgent {
 public:
  virtual ~UavAgent() = default;

  virtual int id() const = 0;
  /// A message from the transport. Invalid ones are counted and ignored.
  virtual void receive(const Envelope& envelope) = 0;
  /// The agent's own sensing at t; appends the messages to broadcast to `outbox`.
  virtual void sense(double t_s, std::span<const ThreatObservation> observations,
                     std::vector<Message>& outbox) = 0;
  /// One control period at t with the measured state and wind.
  virtual AgentStep control(double t_s, const vehicle::State& measured_state,
                            const Vec3& measured_wind_m_s) = 0;
  /// The latest prediction as the message to broadcast, shared with the transport (it holds a
  /// PredictedTrajectory; empty positions before the first control()). Never null.
  virtual std::shared_ptr<const Message> prediction_message() const = 0;
  /// The same prediction, read (valid until the next control()).
  const PredictedTrajectory& prediction() const {
    return std::get<PredictedTrajectory>(*prediction_message());
  }

  virtual bool finished() const = 0;
  virtual int targets_inspected() const = 0;
  /// Names of targets declared missed.
  virtual const std::vector<std::string>& missed_targets() const = 0;
  virtual const AgentCounters& counters() const = 0;
};

}  // namespace ridgeline::swarm
