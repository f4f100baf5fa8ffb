#include "io/scenario_summary.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

namespace ridgeline::io {
namespace {

nlohmann::json vec3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

// Terrain relief over the area on a coarse grid (for a summary, not for safety checks).
std::pair<double, double> terrain_range(const world::Terrain& terrain, const mission::Area& area) {
  constexpr int kSamples = 101;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (int i = 0; i < kSamples; ++i) {
    for (int j = 0; j < kSamples; ++j) {
      const double x = area.x_min_m + (area.x_max_m - area.x_min_m) * i / (kSamples - 1);
      const double y = area.y_min_m + (area.y_max_m - area.y_min_m) * j / (kSamples - 1);
      const double h = terrain.height(x, y);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
  }
  return {lo, hi};
}

}  // namespace

nlohmann::json summarize(const LoadedScenario& loaded) {
  const mission::Scenario& s = loaded.scenario;
  const world::Terrain& terrain = *loaded.terrain;
  nlohmann::json j;
  j["scenario"] = s.name;
  j["source"] = loaded.source;
  j["seed"] = s.seed;
  j["area_m"] = {{"x", {s.area.x_min_m, s.area.x_max_m}}, {"y", {s.area.y_min_m, s.area.y_max_m}}};
  const auto [lo, hi] = terrain_range(terrain, s.area);
  std::string kind = s.terrain.included_from.empty() ? "peaks" : "peaks from " + s.terrain.included_from;
  if (s.terrain.kind == mission::TerrainSource::Kind::kDem) {
    kind = s.terrain.dem_model == mission::TerrainSource::DemModel::kRaster ? "dem raster"
                                                                            : "dem fitted peaks";
  }
  j["terrain"] = {{"kind", kind},
                  {"min_height_m", lo},
                  {"max_height_m", hi},
                  {"model_error_m", terrain.model_error_m()}};
  if (s.terrain.kind == mission::TerrainSource::Kind::kPeaks)
    j["terrain"]["peaks"] = s.terrain.peaks.peaks.size();
  else
    j["terrain"]["dem"] = s.terrain.dem_path;
  const TerrainReport& report = loaded.terrain_report;
  j["terrain"]["model"] = report.model;
  j["terrain"]["error_bound_m"] = report.error_bound_m;
  j["terrain"]["vertical_datum"] = report.vertical_datum;
  if (s.terrain.kind == mission::TerrainSource::Kind::kDem) {
    nlohmann::json voids = nlohmann::json::array();
    for (const VoidRegion& v : report.voids)
      voids.push_back({{"cells", v.cells},
                       {"x", {v.x_min, v.x_max}},
                       {"y", {v.y_min, v.y_max}},
                       {"rim_m", {v.rim_min_m, v.rim_max_m}},
                       {"margin_m", v.margin_m}});
    j["terrain"]["voids"] = {{"units", report.void_units},
                             {"regions", voids},
                             {"cells_in_area", report.void_cells_in_area},
                             {"area_cells", report.cells_in_area}};
  }

  for (const mission::UavSpec& u : s.uavs) {
    const double ground = terrain.height(u.start_position_m.x(), u.start_position_m.y());
    j["uavs"].push_back(
        {{"name", u.name},
         {"start_m", vec3(u.start_position_m)},
         {"start_clearance_m", u.start_position_m.z() - ground},
         {"cruise_speed_m_s", u.vehicle.cruise_speed_m_s},
         {"speed_range_m_s", {u.vehicle.min_speed_m_s(), u.vehicle.max_speed_m_s()}},
         {"min_turn_radius_m", u.vehicle.min_turn_radius_m},
         {"sensor_range_m", u.sensor_range_m},
         {"assigned_targets", u.assigned_targets},
         {"end_m", u.end_position_m ? vec3(*u.end_position_m) : nlohmann::json()}});
  }
  for (const mission::InspectionTarget& t : s.targets) {
    const double ground = terrain.height(t.position_m.x(), t.position_m.y());
    j["targets"].push_back({{"name", t.name},
                            {"position_m", vec3(t.position_m)},
                            {"priority", t.priority},
                            {"clearance_m", t.position_m.z() - ground}});
  }
  j["threats"] = nlohmann::json::array();
  for (const world::Threat& t : s.threats) {
    j["threats"].push_back({{"name", t.name},
                            {"radius_m", t.radius_m},
                            {"speed_m_s", t.velocity_m_s.norm()},
                            {"active_s", {t.appear_s, t.vanish_s}}});
  }
  j["wind"] = {{"mean_m_s", vec3(s.wind.mean_m_s)},
               {"mean_speed_m_s", s.wind.mean_m_s.norm()},
               {"gust_std_m_s", s.wind.gust_std_m_s}};
  j["mpc"] = {{"rate_hz", 1.0 / s.mpc.control_period_s},
              {"prediction_step_s", s.mpc.prediction_step_s},
              {"horizon_steps", s.mpc.horizon_steps},
              {"control_horizon_steps", s.mpc.control_horizon_steps}};
  j["safety"] = {{"terrain_clearance_m", s.safety.terrain_clearance_m},
                 {"separation_m", s.safety.separation_m},
                 {"altitude_m", {s.safety.altitude.min_m, s.safety.altitude.max_m}}};
  // Where z is measured from (DESIGN §8): the terrain datum, or mean sea level with an origin.
  if (s.origin) {
    j["frame"] = {
        {"origin",
         {{"lat_deg", s.origin->lat_deg},
          {"lon_deg", s.origin->lon_deg},
          {"alt_amsl_m", s.origin->alt_amsl_m}}},
        {"z", "metres above mean sea level"},
        {"altitude_stated_above", s.altitude_stated_reference == mission::AltitudeReference::kHome
                                      ? "home"
                                      : "mean sea level"}};
  } else {
    j["frame"] = {{"origin", nullptr}, {"z", "metres in the terrain datum"}};
  }
  return j;
}

std::string summary_text(const nlohmann::json& j) {
  std::string out = fmt::format(
      "scenario '{}' ({}), seed {}\n  area {}..{} x {}..{} m, terrain {} {:.0f}..{:.0f} m\n",
      j["scenario"].get<std::string>(), j["source"].get<std::string>(), j["seed"].get<std::uint64_t>(),
      j["area_m"]["x"][0].get<double>(), j["area_m"]["x"][1].get<double>(),
      j["area_m"]["y"][0].get<double>(), j["area_m"]["y"][1].get<double>(),
      j["terrain"]["kind"].get<std::string>(), j["terrain"]["min_height_m"].get<double>(),
      j["terrain"]["max_height_m"].get<double>());
  if (j["terrain"].contains("model")) {
    out += fmt::format("  terrain model: {}; error bound {:.4f} m (added to every clearance)\n",
                       j["terrain"]["model"].get<std::string>(),
                       j["terrain"]["error_bound_m"].get<double>());
    out += fmt::format("  vertical datum: {}\n", j["terrain"]["vertical_datum"].get<std::string>());
  }
  if (j["terrain"].contains("voids")) {
    const auto& v = j["terrain"]["voids"];
    if (v["regions"].empty()) {
      out += "  DEM voids: none near the area\n";
    } else {
      out += fmt::format("  DEM voids filled: {} of {} cells under the area, {} region(s) near it:",
                         v["cells_in_area"].get<int>(), v["area_cells"].get<int>(),
                         v["regions"].size());
      const std::string units = v["units"].get<std::string>();
      for (const auto& r : v["regions"])
        out += fmt::format(" {} cells at x {:.6f}..{:.6f}, y {:.6f}..{:.6f} {} (margin {:.1f} m);",
                           r["cells"].get<int>(), r["x"][0].get<double>(), r["x"][1].get<double>(),
                           r["y"][0].get<double>(), r["y"][1].get<double>(), units,
                           r["margin_m"].get<double>());
      out += "\n";
    }
  }
  out += fmt::format("  {} UAVs:", j["uavs"].size());
  for (const auto& u : j["uavs"])
    out += fmt::format(" {} (clearance {:.0f} m)", u["name"].get<std::string>(),
                       u["start_clearance_m"].get<double>());
  out += fmt::format("\n  {} targets:", j["targets"].size());
  for (const auto& t : j["targets"])
    out += fmt::format(" {} (priority {}, clearance {:.0f} m)", t["name"].get<std::string>(),
                       t["priority"].get<int>(), t["clearance_m"].get<double>());
  out += fmt::format("\n  {} sudden threats, wind {:.1f} m/s mean (gust std {:.1f} m/s)\n",
                     j["threats"].size(), j["wind"]["mean_speed_m_s"].get<double>(),
                     j["wind"]["gust_std_m_s"].get<double>());
  if (j.contains("frame") && j["frame"]["origin"].is_object()) {
    const auto& o = j["frame"]["origin"];
    out += fmt::format(
        "  frame: origin {:.6f}, {:.6f} (home {:.1f} m AMSL), transverse Mercator; z above mean "
        "sea level; altitude band {:.0f}..{:.0f} m AMSL (stated above {})\n",
        o["lat_deg"].get<double>(), o["lon_deg"].get<double>(), o["alt_amsl_m"].get<double>(),
        j["safety"]["altitude_m"][0].get<double>(), j["safety"]["altitude_m"][1].get<double>(),
        j["frame"]["altitude_stated_above"].get<std::string>());
  }
  out += fmt::format("  MPC {:.0f} Hz, horizon {} x {} s, control horizon {}\n",
                     j["mpc"]["rate_hz"].get<double>(), j["mpc"]["horizon_steps"].get<int>(),
                     j["mpc"]["prediction_step_s"].get<double>(),
                     j["mpc"]["control_horizon_steps"].get<int>());
  return out;
}

}  // namespace ridgeline::io
