// The --scenario argument every command takes: a YAML file, or the embedded default.
#pragma once

#include <string>

#include "io/scenario_file.hpp"

namespace ridgeline::apps {

/// The scenario at `path`, or the embedded default when `path` is empty.
io::LoadedScenario load_scenario_argument(const std::string& path);

}  // namespace ridgeline::apps
