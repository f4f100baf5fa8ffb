// The ground station's plans over DDS (topic rt/ridgeline/reference_plan, topics.hpp: reliable,
// transient local, keep last 1 per UAV, so an agent that starts late still gets its plan). A
// plan carries the time-parametrized reference r_i(t) itself — every sample's position,
// heading, speed, turn and climb rate — so an agent in its own process tracks exactly what the
// planner produced, and the UAV's targets in visiting order. A re-plan (re-allocation after a
// UAV is lost) is a newer version.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "messages/messages.hpp"
#include "transport_dds/dds_participant.hpp"

namespace ridgeline::transport_dds {

class PlanLink {
 public:
  /// `num_targets` bounds the target ids accepted. Throws InputError for num_uavs < 1.
  PlanLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, int num_targets,
           bool publisher);
  ~PlanLink();
  PlanLink(const PlanLink&) = delete;
  PlanLink& operator=(const PlanLink&) = delete;

  /// Throws InputError when the plan fails check_plan or this end does not publish.
  void publish(const messages::ReferencePlan& plan);
  /// Appends the valid plans received (only `uav`'s when uav ≥ 0); rejects are counted.
  void take(std::vector<messages::ReferencePlan>& out, int uav = -1);
  int matched_readers() const;

  std::uint64_t rejected() const { return rejected_; }
  const std::string& last_rejection() const { return last_rejection_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int num_uavs_;
  int num_targets_;
  std::uint64_t rejected_ = 0;
  std::string last_rejection_;
};

}  // namespace ridgeline::transport_dds
