// The truth's safety distances of a flight (DESIGN §6), sampled at the message rate: terrain
// clearance per UAV, separation per pair (between samples too: the closest approach of the
// two UAVs moving straight from one sample to the next, which at 100 Hz is within a
// millimetre of the truth's curved motion, so no approach falls between two samples), distance to every threat's surface, the threat
// encounters (sensed, or intruded) and intrusions. One implementation for the in-process
// mission (fly_mission) and the DDS world (nodes::MissionRecorder), so both count alike.
#pragma once

#include <map>
#include <set>
#include <utility>
#include <vector>

#include "mission/mission_metrics.hpp"
#include "mission/threat_escape.hpp"
#include "mission/truth_world.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"

namespace ridgeline::mission {

class SafetyTally {
 public:
  /// Counts against `limits` (d_safe, r_safe) for `num_uavs` UAVs.
  SafetyTally(const world::SafetyLimits& limits, int num_uavs, const world::Terrain& terrain);

  /// UAV `uav` sensed threat `threat` at time t: an encounter. The first time, whether an
  /// escape was still possible is assessed on the truth (threat_escape.hpp).
  void sensed(int uav, int threat, double t, const TruthWorld& world);
  /// The truth's distances at time t.
  void sample(double t, const TruthWorld& world);
  /// Writes the overall distances and counts into `m`, and each UAV's minimum clearance into
  /// m.uavs[i] (m.uavs must hold every UAV). An intrusion counts as an encounter even if it
  /// happened before the UAV sensed the threat; it is unavoidable when its first sensing found
  /// no escape, else (also when never sensed) avoidable.
  void write(MissionMetrics& m) const;

 private:
  const world::Terrain& terrain_;
  double separation_m_, threat_margin_m_;
  std::vector<double> min_clearance_m_;
  std::vector<Vec3> previous_positions_;  ///< at previous_time_s_ (empty before the first sample)
  double previous_time_s_ = 0.0;
  double min_separation_m_, min_threat_m_;
  std::pair<int, int> closest_pair_{-1, -1};
  double closest_time_s_ = 0.0;
  std::set<std::pair<int, int>> encounters_, intrusions_, margin_violations_, close_pairs_;
  std::map<std::pair<int, int>, ThreatEscape> escapes_;  ///< at each pair's first sensing
};

}  // namespace ridgeline::mission
