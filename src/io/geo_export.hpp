// Exports of a mission in geographic coordinates (DESIGN §8): QGroundControl .plan files,
// GeoJSON, KML and CSV, all in WGS 84 with altitudes above mean sea level.
//
// A MissionGeometry holds what every format shows: one path per UAV (the planned waypoints, or
// the flown track), the inspection targets and the threats, in the local frame of a geodetic
// origin (io/geo_frame.hpp). It is made from a plan.json (`ridgeline export`) or from a flight
// (`ridgeline run` writes DIR/flight.geojson). Threat paths run from the threat's appearance
// to its vanishing, cut at the end of the mission's last path.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/types.hpp"
#include "mission/mission_metrics.hpp"
#include "mission/scenario.hpp"
#include "world/threat.hpp"

namespace ridgeline::io {

struct ExportPath {
  std::string name;               ///< the UAV's id
  std::vector<Vec3> points_m;     ///< local ENU, z above mean sea level
  std::vector<double> times_s;    ///< time at each point, or empty when not timed
  double cruise_speed_m_s = 0.0;  ///< for QGroundControl's mission settings; 0 when unknown
};

struct MissionGeometry {
  std::string name;
  mission::GeodeticOrigin origin;
  std::string path_kind;  ///< "planned waypoints" or "flown track"
  std::vector<ExportPath> paths;
  std::vector<mission::InspectionTarget> targets;
  std::vector<world::Threat> threats;
};

/// The geometry of a plan.json (io/plan_file.hpp): waypoints per UAV (timed by the reference
/// where a waypoint coincides with a reference sample), targets and threats. The origin is
/// `origin_override` when given, else the plan's frame.origin. Throws InputError naming
/// `source` and the field when the plan has no origin and none is given (its positions cannot
/// be placed on the Earth), or when a field is missing or malformed.
MissionGeometry mission_from_plan_json(
    const nlohmann::json& plan, const std::string& source,
    const std::optional<mission::GeodeticOrigin>& origin_override);

/// The flown tracks of a flight (one point every `sample_period_s` per UAV), with the
/// scenario's targets and threats. Throws InputError when the scenario has no origin.
MissionGeometry mission_from_flight(const mission::Scenario& scenario,
                                    const std::vector<mission::TrajectoryRow>& rows,
                                    double sample_period_s = 1.0);

/// GeoJSON (RFC 7946) FeatureCollection: a LineString [lon, lat, alt AMSL] per UAV
/// (properties kind "uav_path", name, times_s when timed), a Point per target (kind
/// "target"), a LineString per threat from its appearance to its vanishing (kind
/// "threat_path", appear_s, vanish_s, start_s, end_s, radius_m, speed_m_s).
std::string to_geojson(const MissionGeometry& mission);

/// KML 2.2 with the same features as Placemarks, altitudeMode absolute (AMSL).
std::string to_kml(const MissionGeometry& mission);

/// CSV, one row per vertex: kind,name,seq,t_s,lat_deg,lon_deg,alt_amsl_m,x_m,y_m,z_m (t_s
/// empty when not timed; a target is one row).
std::string to_csv(const MissionGeometry& mission);

/// QGroundControl .plan (JSON, file version 1, mission version 2) for path `uav`: one
/// MAV_CMD_NAV_WAYPOINT (16) SimpleItem per waypoint in frame 0 (MAV_FRAME_GLOBAL: altitude
/// above mean sea level) with AltitudeMode 2 (absolute); the planned home position is the
/// first waypoint's latitude/longitude at the origin's altitude (the home altitude).
nlohmann::json to_qgc_plan(const MissionGeometry& mission, std::size_t uav);

}  // namespace ridgeline::io
