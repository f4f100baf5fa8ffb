// The ground station's plans over DDS (topic rt/ridgeline/reference_plan, type
// ridgeline::msg::dds_::ReferencePlan_; reliable, transient local, keep last 1 per UAV, so an
// agent that starts late still gets its plan). A PlanMessage carries the time-parametrized
// reference r_i(t) itself — every sample's position, heading, speed, turn and climb rate — so
// an agent in its own process tracks exactly what the planner produced, and the UAV's targets
// in visiting order. A re-plan (re-allocation after a UAV is lost) is a newer version.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mpc/reference.hpp"
#include "transport_dds/dds_participant.hpp"

namespace ridgeline::transport_dds {

struct PlanMessage {
  int uav = -1;
  int version = 0;
  double stamp_s = 0.0;
  std::vector<double> times_s;              ///< strictly increasing, ≥ 2
  std::vector<mpc::ReferencePoint> points;  ///< one per time
  std::vector<int> target_ids;              ///< indices into the scenario's targets
};

/// The reason a plan is rejected (ids, sizes, finite values, increasing times), or nothing.
std::optional<std::string> check_plan(const PlanMessage& plan, int num_uavs, int num_targets,
                                      std::size_t max_samples = 200000);

class PlanLink {
 public:
  /// `num_targets` bounds the target ids accepted. Throws InputError for num_uavs < 1.
  PlanLink(std::shared_ptr<DdsParticipant> participant, int num_uavs, int num_targets,
           bool publisher);
  ~PlanLink();
  PlanLink(const PlanLink&) = delete;
  PlanLink& operator=(const PlanLink&) = delete;

  /// Throws InputError when the plan fails check_plan or this end does not publish.
  void publish(const PlanMessage& plan);
  /// Appends the valid plans received (only `uav`'s when uav ≥ 0); rejects are counted.
  void take(std::vector<PlanMessage>& out, int uav = -1);
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
