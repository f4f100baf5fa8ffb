#include "apps/node_support.hpp"

namespace ridgeline::apps {

void add_dds_options(CLI::App* command, DdsArgs& args) {
  command->add_option("--domain-id", args.domain_id, "DDS domain id (0..230)")
      ->capture_default_str();
  command->add_option("--partition", args.partition,
                      "DDS partition (empty: the default partition, as ROS 2 uses)");
}

transport_dds::DdsOptions dds_options(const DdsArgs& args) {
  transport_dds::DdsOptions o;
  o.domain_id = args.domain_id;
  o.partition = args.partition;
  return o;
}

nlohmann::json to_json(const nodes::WorldNodeResult& world) {
  nlohmann::json agents = nlohmann::json::array();
  for (const nodes::AgentDeadlineStats& a : world.agents) {
    agents.push_back({{"uav", a.name},
                      {"answers", a.answers},
                      {"loop_period_mean_s", a.loop_period_mean_s},
                      {"loop_period_jitter_s", a.loop_period_jitter_s},
                      {"loop_period_max_deviation_s", a.loop_period_max_dev_s},
                      {"compute_p50_s", a.compute_p50_s},
                      {"compute_p99_s", a.compute_p99_s},
                      {"compute_max_s", a.compute_max_s},
                      {"answer_latency_p99_s", a.latency_p99_s},
                      {"missed_deadlines", a.missed_deadlines},
                      {"turn_setpoints_limited", a.turn_setpoints_limited},
                      {"started_s", a.started_s},
                      {"lost_s", a.lost_s}});
  }
  nlohmann::json lost = nlohmann::json::array();
  for (const int i : world.lost) lost.push_back(world.agents[static_cast<std::size_t>(i)].name);
  int inspected = 0;
  for (const mission::UavMetrics& u : world.mission.metrics.uavs) inspected += u.targets_inspected;
  return {{"mode", world.lock_step ? "lock-step" : "real-time"},
          {"deadline_rule", world.lock_step ? "missed = agent compute time above one control period"
                                            : "missed = no answer before the next control tick"},
          {"agents", agents},
          {"lost_uavs", lost},
          {"targets_inspected_by_team", inspected},
          {"world_messages_rejected", world.messages_rejected},
          {"world_last_rejection", world.last_rejection},
          {"wall_time_s", world.wall_time_s}};
}

nlohmann::json to_json(const nodes::GroundNodeResult& ground) {
  nlohmann::json reallocations = nlohmann::json::array();
  for (const nodes::Reallocation& r : ground.reallocations) {
    nlohmann::json assignment = nlohmann::json::object();
    for (const auto& [uav, targets] : r.assignment) assignment[uav] = targets;
    reallocations.push_back({{"t_s", r.t_s},
                             {"lost_uav", r.lost_uav},
                             {"open_targets", r.open_targets},
                             {"status", r.status},
                             {"assignment", assignment},
                             {"plan_time_s", r.plan_time_s}});
  }
  return {{"reallocations", reallocations},
          {"messages_rejected", ground.rejected},
          {"world_stopped", ground.world_stopped},
          {"message", ground.message}};
}

}  // namespace ridgeline::apps
