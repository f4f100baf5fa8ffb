// Steps several subcommands share, so each command file stays a thin shell.
#pragma once

#include <optional>
#include <string>

#include "io/scenario_file.hpp"
#include "planning/global_planner.hpp"

namespace ridgeline::apps {

/// The scenario at `path`, or the embedded default when `path` is empty.
io::LoadedScenario load_scenario_argument(const std::string& path);

/// Plans the mission; on failure prints one error line, sets exit code 3 and returns nothing.
std::optional<planning::GlobalPlan> plan_or_report(const io::LoadedScenario& loaded);

}  // namespace ridgeline::apps
