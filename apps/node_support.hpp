// What the swarm's process commands (world, agent, ground, launch) share: the DDS options on
// the command line and the JSON of their results.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "nodes/ground_node.hpp"
#include "nodes/world_node.hpp"
#include "transport_dds/dds_participant.hpp"

namespace ridgeline::apps {

struct DdsArgs {
  int domain_id = 42;
  std::string partition;
};

/// --domain-id and --partition.
void add_dds_options(CLI::App* command, DdsArgs& args);
transport_dds::DdsOptions dds_options(const DdsArgs& args);

/// metrics.json's "distributed" block: mode, per-agent deadline statistics, lost UAVs.
nlohmann::json to_json(const nodes::WorldNodeResult& world);
nlohmann::json to_json(const nodes::GroundNodeResult& ground);

}  // namespace ridgeline::apps
