#include "io/geo_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "io/geo_frame.hpp"
#include "io/markup_escape.hpp"

namespace ridgeline::io {

namespace {

using nlohmann::json;

// Reads a finite number at `j[key]`, naming source and path on failure.
double number(const json& j, const std::string& key, const std::string& where) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) {
    throw InputError(where + "." + key, "missing or not a number");
  }
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw InputError(where + "." + key, "is not finite");
  return v;
}

Vec3 vec3(const json& j, const std::string& key, const std::string& where) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_array() || j[key].size() != 3) {
    throw InputError(where + "." + key, "missing or not a list of 3 numbers");
  }
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    const json& e = j[key][static_cast<std::size_t>(i)];
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      throw InputError(where + "." + key, "holds a value that is not a finite number");
    v[i] = e.get<double>();
  }
  return v;
}

std::string text(const json& j, const std::string& key, const std::string& where) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string())
    throw InputError(where + "." + key, "missing or not a string");
  return j[key].get<std::string>();
}

const json& list(const json& j, const std::string& key, const std::string& where) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_array())
    throw InputError(where + "." + key, "missing or not a list");
  return j[key];
}

double mission_end_s(const MissionGeometry& m) {
  double end = 0.0;
  for (const ExportPath& p : m.paths)
    if (!p.times_s.empty()) end = std::max(end, p.times_s.back());
  return end;
}

// A threat's straight track from its appearance to min(vanishing, end of the mission); a
// threat appearing after the mission ends is shown over one second at its appearance.
struct ThreatTrack {
  double start_s, end_s;
  Vec3 from_m, to_m;
};
ThreatTrack threat_track(const world::Threat& t, double mission_end) {
  ThreatTrack k;
  k.start_s = t.appear_s;
  k.end_s = std::min(t.vanish_s, std::max(mission_end, t.appear_s + 1.0));
  k.from_m = t.centre_at(k.start_s);
  k.to_m = t.centre_at(k.end_s);
  return k;
}

json lon_lat_alt(const GeoFrame& frame, const Vec3& p) {
  const GeoPoint g = frame.to_geodetic(p);
  return json::array({g.lon_deg, g.lat_deg, g.alt_amsl_m});
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string kml_coordinates(const GeoFrame& frame, const std::vector<Vec3>& points) {
  std::string out;
  for (const Vec3& p : points) {
    const GeoPoint g = frame.to_geodetic(p);
    out += fmt::format("{:.9f},{:.9f},{:.3f} ", g.lon_deg, g.lat_deg, g.alt_amsl_m);
  }
  if (!out.empty()) out.pop_back();
  return out;
}

std::string kml_data(const std::vector<std::pair<std::string, std::string>>& fields) {
  std::string out = "<ExtendedData>";
  for (const auto& [k, v] : fields)
    out += fmt::format("<Data name=\"{}\"><value>{}</value></Data>", escape_markup(k),
                       escape_markup(v));
  return out + "</ExtendedData>";
}

}  // namespace

MissionGeometry mission_from_plan_json(
    const json& plan, const std::string& source,
    const std::optional<mission::GeodeticOrigin>& origin_override) {
  if (!plan.is_object()) throw InputError(source, "a plan must be a JSON object");
  MissionGeometry m;
  m.name = plan.contains("scenario") && plan["scenario"].is_string()
               ? plan["scenario"].get<std::string>()
               : std::string("plan");
  m.path_kind = "planned waypoints";
  if (origin_override) {
    m.origin = *origin_override;
  } else {
    const bool has_origin = plan.contains("frame") && plan["frame"].is_object() &&
                            plan["frame"].contains("origin") && plan["frame"]["origin"].is_object();
    if (!has_origin) {
      throw InputError(source + ": frame.origin",
                       "the plan has no geodetic origin (its scenario names none), so its local "
                       "positions cannot be placed on the Earth; add 'origin: {lat_deg, lon_deg, "
                       "alt_amsl_m}' to the scenario and plan again, or give --origin LAT,LON,ALT");
    }
    const json& o = plan["frame"]["origin"];
    const std::string where = source + ": frame.origin";
    m.origin = {number(o, "lat_deg", where), number(o, "lon_deg", where),
                number(o, "alt_amsl_m", where)};
  }
  (void)GeoFrame(m.origin);  // validates the origin, naming its field

  const json& uavs = list(plan, "uavs", source);
  for (std::size_t i = 0; i < uavs.size(); ++i) {
    const std::string where = fmt::format("{}: uavs[{}]", source, i);
    const json& u = uavs[i];
    ExportPath path;
    path.name = text(u, "id", where);
    if (u.contains("cruise_speed_m_s") && u["cruise_speed_m_s"].is_number())
      path.cruise_speed_m_s = u["cruise_speed_m_s"].get<double>();
    const json& waypoints = list(u, "waypoints", where);
    if (waypoints.empty()) throw InputError(where + ".waypoints", "is empty");
    for (std::size_t k = 0; k < waypoints.size(); ++k) {
      const json holder = {{"p", waypoints[k]}};
      path.points_m.push_back(vec3(holder, "p", fmt::format("{}.waypoints[{}]", where, k)));
    }
    // Time at each waypoint: the first reference sample within 1 mm of it, in order (the
    // reference passes through every waypoint of the validated polyline).
    if (u.contains("reference") && u["reference"].is_array()) {
      const json& ref = u["reference"];
      std::size_t next = 0;
      for (const Vec3& w : path.points_m) {
        double best_d = 1e300, best_t = 0.0;
        std::size_t best_k = next;
        for (std::size_t k = next; k < ref.size(); ++k) {
          const json& r = ref[k];
          if (!r.is_array() || r.size() != 4)
            throw InputError(where + ".reference", "rows must be [t, x, y, z]");
          const double d =
              (Vec3(r[1].get<double>(), r[2].get<double>(), r[3].get<double>()) - w).norm();
          if (d < best_d) {
            best_d = d;
            best_t = r[0].get<double>();
            best_k = k;
          }
          if (d > best_d + 50.0) break;  // moving away from the waypoint again
        }
        path.times_s.push_back(best_t);
        next = best_k;
      }
      // Times must be usable as times: fall back to none if the reference does not pass the
      // waypoints in order.
      if (!std::is_sorted(path.times_s.begin(), path.times_s.end())) path.times_s.clear();
    }
    m.paths.push_back(std::move(path));
  }
  if (plan.contains("targets")) {
    const json& targets = list(plan, "targets", source);
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const std::string where = fmt::format("{}: targets[{}]", source, i);
      mission::InspectionTarget t;
      t.name = text(targets[i], "name", where);
      t.position_m = vec3(targets[i], "position_m", where);
      if (targets[i].contains("priority"))
        t.priority = static_cast<int>(number(targets[i], "priority", where));
      if (targets[i].contains("inspection_radius_m"))
        t.inspection_radius_m = number(targets[i], "inspection_radius_m", where);
      m.targets.push_back(std::move(t));
    }
  }
  if (plan.contains("threats")) {
    const json& threats = list(plan, "threats", source);
    for (std::size_t i = 0; i < threats.size(); ++i) {
      const std::string where = fmt::format("{}: threats[{}]", source, i);
      world::Threat t;
      t.name = text(threats[i], "name", where);
      t.centre_m = vec3(threats[i], "centre_m", where);
      t.velocity_m_s = vec3(threats[i], "velocity_m_s", where);
      t.radius_m = number(threats[i], "radius_m", where);
      t.appear_s = number(threats[i], "appear_s", where);
      t.vanish_s = number(threats[i], "vanish_s", where);
      m.threats.push_back(std::move(t));
    }
  }
  return m;
}

MissionGeometry mission_from_flight(const mission::Scenario& scenario,
                                    const std::vector<mission::TrajectoryRow>& rows,
                                    double sample_period_s) {
  if (!scenario.origin) {
    throw InputError("origin",
                     "the scenario has no geodetic origin, so the flight cannot be "
                     "placed on the Earth");
  }
  MissionGeometry m;
  m.name = scenario.name;
  m.origin = *scenario.origin;
  m.path_kind = "flown track";
  m.targets = scenario.targets;
  m.threats = scenario.threats;
  m.paths.resize(scenario.uavs.size());
  std::vector<double> next_t(scenario.uavs.size(), -1e300);
  std::vector<const mission::TrajectoryRow*> last(scenario.uavs.size(), nullptr);
  for (std::size_t i = 0; i < scenario.uavs.size(); ++i) {
    m.paths[i].name = scenario.uavs[i].name;
    m.paths[i].cruise_speed_m_s = scenario.uavs[i].vehicle.cruise_speed_m_s;
  }
  for (const mission::TrajectoryRow& r : rows) {
    if (r.uav < 0 || static_cast<std::size_t>(r.uav) >= m.paths.size()) continue;
    const std::size_t i = static_cast<std::size_t>(r.uav);
    last[i] = &r;
    if (r.t_s + 1e-9 < next_t[i]) continue;
    m.paths[i].points_m.push_back(r.position_m);
    m.paths[i].times_s.push_back(r.t_s);
    next_t[i] = r.t_s + sample_period_s;
  }
  // Each track ends where the UAV was last seen.
  for (std::size_t i = 0; i < m.paths.size(); ++i) {
    if (last[i] != nullptr && !m.paths[i].times_s.empty() &&
        m.paths[i].times_s.back() < last[i]->t_s) {
      m.paths[i].points_m.push_back(last[i]->position_m);
      m.paths[i].times_s.push_back(last[i]->t_s);
    }
  }
  return m;
}

std::string to_geojson(const MissionGeometry& m) {
  const GeoFrame frame(m.origin);
  json features = json::array();
  for (const ExportPath& p : m.paths) {
    json coords = json::array();
    for (const Vec3& v : p.points_m) coords.push_back(lon_lat_alt(frame, v));
    json props = {{"kind", "uav_path"}, {"name", p.name}, {"path", m.path_kind}};
    if (!p.times_s.empty()) props["times_s"] = p.times_s;
    features.push_back({{"type", "Feature"},
                        {"properties", props},
                        {"geometry", {{"type", "LineString"}, {"coordinates", coords}}}});
  }
  for (const mission::InspectionTarget& t : m.targets) {
    features.push_back(
        {{"type", "Feature"},
         {"properties",
          {{"kind", "target"},
           {"name", t.name},
           {"priority", t.priority},
           {"inspection_radius_m", t.inspection_radius_m}}},
         {"geometry", {{"type", "Point"}, {"coordinates", lon_lat_alt(frame, t.position_m)}}}});
  }
  const double end = mission_end_s(m);
  for (const world::Threat& t : m.threats) {
    const ThreatTrack k = threat_track(t, end);
    features.push_back(
        {{"type", "Feature"},
         {"properties",
          {{"kind", "threat_path"},
           {"name", t.name},
           {"appear_s", t.appear_s},
           {"vanish_s", t.vanish_s},
           {"start_s", k.start_s},
           {"end_s", k.end_s},
           {"times_s", {k.start_s, k.end_s}},
           {"radius_m", t.radius_m},
           {"speed_m_s", t.velocity_m_s.norm()}}},
         {"geometry",
          {{"type", "LineString"},
           {"coordinates", {lon_lat_alt(frame, k.from_m), lon_lat_alt(frame, k.to_m)}}}}});
  }
  const json doc = {{"type", "FeatureCollection"},
                    {"name", m.name},
                    {"origin",
                     {{"lat_deg", m.origin.lat_deg},
                      {"lon_deg", m.origin.lon_deg},
                      {"alt_amsl_m", m.origin.alt_amsl_m}}},
                    {"features", features}};
  return doc.dump(1) + "\n";
}

std::string to_kml(const MissionGeometry& m) {
  const GeoFrame frame(m.origin);
  std::string out =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n";
  out += fmt::format("<name>{}</name>\n", escape_markup(m.name));
  out += fmt::format(
      "<description>Ridgeline mission: {} per UAV, inspection targets and threat tracks; WGS 84, "
      "altitudes above mean sea level (altitudeMode absolute).</description>\n",
      escape_markup(m.path_kind));
  for (const ExportPath& p : m.paths) {
    std::vector<std::pair<std::string, std::string>> data = {{"kind", "uav_path"}};
    if (!p.times_s.empty())
      data.emplace_back("time_span_s",
                        fmt::format("{:.2f}..{:.2f}", p.times_s.front(), p.times_s.back()));
    out += fmt::format(
        "<Placemark><name>{}</name>{}<LineString><altitudeMode>absolute</altitudeMode>"
        "<coordinates>{}</coordinates></LineString></Placemark>\n",
        escape_markup(p.name), kml_data(data), kml_coordinates(frame, p.points_m));
  }
  for (const mission::InspectionTarget& t : m.targets) {
    out += fmt::format(
        "<Placemark><name>{}</name>{}<Point><altitudeMode>absolute</altitudeMode>"
        "<coordinates>{}</coordinates></Point></Placemark>\n",
        escape_markup(t.name),
        kml_data({{"kind", "target"}, {"priority", std::to_string(t.priority)}}),
        kml_coordinates(frame, {t.position_m}));
  }
  const double end = mission_end_s(m);
  for (const world::Threat& t : m.threats) {
    const ThreatTrack k = threat_track(t, end);
    out += fmt::format(
        "<Placemark><name>{}</name>{}<LineString><altitudeMode>absolute</altitudeMode>"
        "<coordinates>{}</coordinates></LineString></Placemark>\n",
        escape_markup(t.name),
        kml_data({{"kind", "threat_path"},
                  {"appear_s", fmt::format("{}", t.appear_s)},
                  {"vanish_s", fmt::format("{}", t.vanish_s)},
                  {"start_s", fmt::format("{}", k.start_s)},
                  {"end_s", fmt::format("{}", k.end_s)},
                  {"radius_m", fmt::format("{}", t.radius_m)}}),
        kml_coordinates(frame, {k.from_m, k.to_m}));
  }
  out += "</Document>\n</kml>\n";
  return out;
}

std::string to_csv(const MissionGeometry& m) {
  const GeoFrame frame(m.origin);
  std::string out = "kind,name,seq,t_s,lat_deg,lon_deg,alt_amsl_m,x_m,y_m,z_m\n";
  auto row = [&](const std::string& kind, const std::string& name, std::size_t seq,
                 std::optional<double> t, const Vec3& p) {
    const GeoPoint g = frame.to_geodetic(p);
    out += fmt::format("{},{},{},{},{:.9f},{:.9f},{:.3f},{:.3f},{:.3f},{:.3f}\n", kind,
                       csv_field(name), seq, t ? fmt::format("{:.3f}", *t) : std::string(),
                       g.lat_deg, g.lon_deg, g.alt_amsl_m, p.x(), p.y(), p.z());
  };
  for (const ExportPath& p : m.paths) {
    for (std::size_t k = 0; k < p.points_m.size(); ++k) {
      row("uav_path", p.name, k,
          p.times_s.empty() ? std::nullopt : std::optional<double>(p.times_s[k]), p.points_m[k]);
    }
  }
  for (const mission::InspectionTarget& t : m.targets)
    row("target", t.name, 0, std::nullopt, t.position_m);
  const double end = mission_end_s(m);
  for (const world::Threat& t : m.threats) {
    const ThreatTrack k = threat_track(t, end);
    row("threat_path", t.name, 0, k.start_s, k.from_m);
    row("threat_path", t.name, 1, k.end_s, k.to_m);
  }
  return out;
}

json to_qgc_plan(const MissionGeometry& m, std::size_t uav) {
  if (uav >= m.paths.size()) throw InputError("uav", fmt::format("no path {} in the mission", uav));
  const GeoFrame frame(m.origin);
  const ExportPath& p = m.paths[uav];
  json items = json::array();
  for (std::size_t k = 0; k < p.points_m.size(); ++k) {
    const GeoPoint g = frame.to_geodetic(p.points_m[k]);
    items.push_back(
        {{"type", "SimpleItem"},
         {"command", 16},      // MAV_CMD_NAV_WAYPOINT
         {"frame", 0},         // MAV_FRAME_GLOBAL: altitude above mean sea level
         {"AltitudeMode", 2},  // QGroundControl: absolute (AMSL)
         {"Altitude", g.alt_amsl_m},
         {"AMSLAltAboveTerrain", nullptr},
         {"autoContinue", true},
         {"doJumpId", k + 1},
         // hold s, acceptance radius m, pass radius m, yaw (NaN: unchanged), lat, lon, alt
         {"params", {0, 0, 0, nullptr, g.lat_deg, g.lon_deg, g.alt_amsl_m}}});
  }
  const GeoPoint home = frame.to_geodetic(p.points_m.front());
  const double cruise = p.cruise_speed_m_s > 0.0 ? p.cruise_speed_m_s : 10.0;
  return {{"fileType", "Plan"},
          {"version", 1},
          {"groundStation", "Ridgeline"},
          {"mission",
           {{"version", 2},
            {"firmwareType", 12},  // MAV_AUTOPILOT_PX4
            {"vehicleType", 2},    // MAV_TYPE_QUADROTOR: QGroundControl's multirotor class
            {"cruiseSpeed", cruise},
            {"hoverSpeed", cruise},
            {"globalPlanAltitudeMode", 2},
            {"plannedHomePosition", {home.lat_deg, home.lon_deg, m.origin.alt_amsl_m}},
            {"items", items}}},
          {"geoFence", {{"version", 2}, {"circles", json::array()}, {"polygons", json::array()}}},
          {"rallyPoints", {{"version", 2}, {"points", json::array()}}}};
}

}  // namespace ridgeline::io
