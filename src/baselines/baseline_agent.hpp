// What the two comparison agents share (issue 6): the mission logic (targets inspected in
// order, finished, missed), the geometric path they follow (the planned reference's
// positions by arc length), the timed reference they are measured against, the neighbours'
// broadcast predictions, the threats they sensed themselves, and the prediction they
// broadcast. Subclasses only compute the command (compute()).
//
// Differences to the proposed agent (swarm/agent.hpp), as the methods define them: no MPC, no
// state observer (the raw fix; neither method differences positions), no ThreatReports sent
// or used (each UAV knows only the threats it senses), no local re-plan of the reference.
#pragma once

#include <map>
#include <memory>
#include <vector>

#include "mpc/reference.hpp"
#include "swarm/uav_agent.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace ridgeline::baselines {

struct BaselineAgentOptions {
  int id = 0;
  int num_uavs = 1;
  vehicle::VehicleParams vehicle;
  std::vector<swarm::AgentTarget> targets;  ///< this UAV's, in visiting order
  /// The plan ends at the UAV's end position: finished only once the reference is flown.
  bool fly_to_end = false;
  double control_period_s = 0.02;
  double missed_after_s = 30.0;
  double threat_forget_s = 10.0;
  double prediction_step_s = 0.1;  ///< of the broadcast prediction
  int prediction_steps = 40;
  double wind_filter_time_s = 0.5;
  /// Command changes per second (the same limits the proposed tracker obeys).
  Vec3 max_command_rate = Vec3(4.0, 1.5, 4.0);
};

/// The planned path by arc length (positions of the timed reference every path_step_m).
class PathGeometry {
 public:
  PathGeometry(const mpc::SampledReference& reference, double path_step_m = 2.0);
  double length_m() const { return s_.back(); }
  Vec3 at(double s_m) const;
  /// Arc length of the point nearest to `p` among s in [s_from, s_from + window_m].
  double project(const Vec3& p_m, double s_from_m, double window_m) const;

 private:
  std::vector<Vec3> points_;
  std::vector<double> s_;
};

class BaselineAgent : public swarm::UavAgent {
 public:
  /// Throws InputError for invalid options (names the field).
  /// `limits`: the mission's h_safe, d_safe, r_safe and band, which the method keeps to.
  BaselineAgent(const BaselineAgentOptions& options, const world::SafetyLimits& limits,
                std::shared_ptr<const mpc::SampledReference> reference,
                std::shared_ptr<const world::Terrain> terrain);

  int id() const override { return options_.id; }
  void receive(const swarm::Envelope& envelope) override;
  void sense(double t_s, std::span<const swarm::ThreatObservation> observations,
             std::vector<swarm::Message>& outbox) override;
  swarm::AgentStep control(double t_s, const vehicle::State& measured_state,
                           const Vec3& measured_wind_m_s) override;
  std::shared_ptr<const swarm::Message> prediction_message() const override { return prediction_; }
  bool finished() const override { return finished_; }
  int targets_inspected() const override { return next_target_; }
  const std::vector<std::string>& missed_targets() const override { return missed_; }
  const swarm::AgentCounters& counters() const override { return counters_; }

 protected:
  struct Neighbour {
    int id = -1;
    swarm::PredictedTrajectory prediction;
    /// Position at time t: the prediction, extrapolated at its mean velocity beyond its end.
    Vec3 at(double t_s) const;
  };
  /// The command for this control period; `prediction` gets the positions the agent expects
  /// at t + k·prediction_step_s, k = 1..prediction_steps.
  virtual vehicle::Input compute(double t_s, const vehicle::State& state, const Vec3& wind_m_s,
                                 std::vector<Vec3>& prediction) = 0;

  /// Positions predicted by holding a command (rate-limited towards `target`) from `state`.
  void rollout(const vehicle::State& state, const vehicle::Input& from,
               const vehicle::Input& target, const Vec3& wind_m_s, double step_s, int steps,
               std::vector<Vec3>& positions) const;

  const BaselineAgentOptions& options() const { return options_; }
  const world::SafetyLimits& limits() const { return limits_; }
  const world::Terrain& terrain() const { return *terrain_; }
  const mpc::SampledReference& reference() const { return *reference_; }
  const PathGeometry& path() const { return path_; }
  double progress_m() const { return progress_m_; }
  const std::vector<world::Threat>& threats() const { return threat_list_; }
  const std::vector<Neighbour>& neighbours() const { return neighbour_list_; }
  const vehicle::Input& last_command() const { return last_command_; }
  swarm::AgentCounters& mutable_counters() { return counters_; }
  /// Clearance z − H − model error at p.
  double clearance_m(const Vec3& p_m) const;

 private:
  void update_mission(double t_s, const Vec3& position_m);

  BaselineAgentOptions options_;
  world::SafetyLimits limits_;
  std::shared_ptr<const mpc::SampledReference> reference_;
  std::shared_ptr<const world::Terrain> terrain_;
  PathGeometry path_;
  double progress_m_ = 0.0;
  std::map<int, std::pair<world::Threat, double>> threats_;  ///< id → (threat, confirmed at)
  std::map<int, Neighbour> neighbours_;
  std::vector<world::Threat> threat_list_;
  std::vector<Neighbour> neighbour_list_;
  vehicle::Input last_command_ = vehicle::Input::Zero();
  Vec3 wind_estimate_ = Vec3::Zero();
  double last_control_s_ = -1.0;
  bool finished_ = false;
  int next_target_ = 0;
  std::vector<std::string> missed_;
  swarm::AgentCounters counters_;
  // The prediction of positions at t_s + k·step, k = 1.., as the message broadcast.
  void publish_prediction(double t_s, std::vector<Vec3> positions);

  std::shared_ptr<const swarm::Message> prediction_;  ///< a PredictedTrajectory, never null
};

}  // namespace ridgeline::baselines
