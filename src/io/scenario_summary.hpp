// Human- and machine-readable summaries of a loaded scenario: what `ridgeline validate` and
// (until the simulation lands) `ridgeline run` report.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "io/scenario_file.hpp"

namespace ridgeline::io {

/// Key facts: team, targets with their terrain clearance, threats, wind, terrain relief.
nlohmann::json summarize(const LoadedScenario& loaded);

/// The same as a short text for a terminal.
std::string summary_text(const nlohmann::json& summary);

}  // namespace ridgeline::io
