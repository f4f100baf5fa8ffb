// The YAML of a generated team scenario (`ridgeline scenario team`, mission/team_scenario.hpp):
// the base scenario's text with its top-level sections `name`, `seed`, `uavs`, `targets` and
// `threats` (and `area` and `terrain` when the terrain is a DEM) replaced by the generated
// values, so every other field keeps the base's value and its comment.
#pragma once

#include <string>
#include <string_view>

#include "mission/scenario.hpp"

namespace ridgeline::io {

/// `base_yaml` (a scenario file's text whose top-level keys start at column 0, like the
/// default's) with the team's sections written in. `how_made` is the header comment's command
/// line. With `dem_path` non-empty the terrain section becomes `dem: {path, model: raster}` and
/// the area section the scenario's area. Throws InputError ("base") when a section to replace is
/// missing from the base text.
std::string team_scenario_yaml(std::string_view base_yaml, const mission::Scenario& team,
                               const std::string& how_made, const std::string& dem_path = "");

}  // namespace ridgeline::io
