// The global plan as a file: DIR/plan.json, written by `ridgeline plan` (and `run`).
//
// {"scenario", "status", "solve_time_s", "stage_times_s": {...}, "cost": {...},
//  "frame": {"origin": {"lat_deg", "lon_deg", "alt_amsl_m"} or null, "projection", "z"},
//  "targets": [{"name", "position_m", "priority", "inspection_radius_m"}],
//  "threats": [{"name", "centre_m", "velocity_m_s", "radius_m", "appear_s", "vanish_s"}],
//  "validation": {...},
//  "uavs": [{"id", "targets": [names], "waypoints": [[x,y,z],...],
//            "reference": [[t,x,y,z],...], "length_m", "duration_s", "cruise_speed_m_s", ...}]}
// The reference is sampled at the control period; positions are ENU metres in the scenario's
// frame (io/geo_frame.hpp when "frame.origin" is set: z above mean sea level), times seconds.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "mission/scenario.hpp"
#include "planning/global_planner.hpp"

namespace ridgeline::io {

nlohmann::json plan_to_json(const planning::GlobalPlan& plan, const mission::Scenario& scenario);

/// A few lines a person reads in seconds: per UAV its targets, length, duration and the
/// validated minimum clearance and separation; the planning time.
std::string plan_summary_text(const planning::GlobalPlan& plan, const mission::Scenario& scenario);

}  // namespace ridgeline::io
