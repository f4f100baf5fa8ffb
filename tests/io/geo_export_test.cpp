// Exports in WGS 84 (io/geo_export.hpp) read back by GDAL/OGR's own GeoJSON, KML and CSV
// drivers: feature counts, kinds and every coordinate, converted back into the local frame,
// against the plan they came from. The QGroundControl .plan is checked as JSON against the
// keys of QGroundControl's documented file format.
#include "io/geo_export.hpp"

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/random.hpp"
#include "io/atomic_file.hpp"
#include "io/geo_frame.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const mission::GeodeticOrigin kOrigin{-33.85, 151.2, 120.0};  // southern and eastern hemispheres

// A plan.json as io/plan_file.hpp writes it (the keys exports read), with random waypoints and
// a reference through them.
json synthetic_plan(std::uint64_t seed, bool with_origin) {
  Rng rng(seed);
  json plan;
  plan["scenario"] = "synthetic";
  if (with_origin) {
    plan["frame"] = {{"origin",
                      {{"lat_deg", kOrigin.lat_deg},
                       {"lon_deg", kOrigin.lon_deg},
                       {"alt_amsl_m", kOrigin.alt_amsl_m}}}};
  } else {
    plan["frame"] = {{"origin", nullptr}};
  }
  plan["uavs"] = json::array();
  for (int u = 0; u < 3; ++u) {
    json uj;
    uj["id"] = "uav" + std::to_string(u + 1);
    uj["cruise_speed_m_s"] = 10.0;
    uj["waypoints"] = json::array();
    uj["reference"] = json::array();
    Vec3 p(rng.uniform(-2000, 2000), rng.uniform(-2000, 2000), rng.uniform(150, 600));
    double t = 0.0;
    for (int k = 0; k < 12; ++k) {
      uj["waypoints"].push_back({p.x(), p.y(), p.z()});
      const Vec3 q = p + Vec3(rng.uniform(50, 200), rng.uniform(-150, 150), rng.uniform(-20, 20));
      for (int s = 0; s < 10; ++s) {  // samples from p towards q
        const Vec3 r = p + (q - p) * (s / 10.0);
        uj["reference"].push_back({t, r.x(), r.y(), r.z()});
        t += 1.0;
      }
      p = q;
    }
    plan["uavs"].push_back(uj);
  }
  plan["targets"] = {{{"name", "mast"},
                      {"position_m", {1200.0, 900.0, 300.0}},
                      {"priority", 2},
                      {"inspection_radius_m", 30.0}},
                     {{"name", "hut"}, {"position_m", {-800.0, 1500.0, 250.0}}}};
  plan["threats"] = {{{"name", "t1"},
                      {"centre_m", {0.0, 0.0, 200.0}},
                      {"velocity_m_s", {4.0, -3.0, 0.0}},
                      {"radius_m", 40.0},
                      {"appear_s", 20.0},
                      {"vanish_s", 80.0}}};
  return plan;
}

struct Feature {
  std::string kind, name;
  std::vector<Vec3> points;  // lon, lat, alt
};

// Every feature of every layer, as OGR reads the file.
std::vector<Feature> read_with_ogr(const fs::path& file,
                                   const char* const* open_options = nullptr) {
  GDALAllRegister();
  GDALDataset* ds = static_cast<GDALDataset*>(
      GDALOpenEx(file.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY, nullptr, open_options, nullptr));
  EXPECT_NE(ds, nullptr) << file;
  std::vector<Feature> out;
  if (ds == nullptr) return out;
  for (OGRLayer* layer : ds->GetLayers()) {
    for (const auto& f : *layer) {
      Feature feature;
      const int kind = f->GetFieldIndex("kind");
      const int name = f->GetFieldIndex("name");
      if (kind >= 0) feature.kind = f->GetFieldAsString(kind);
      if (name >= 0) feature.name = f->GetFieldAsString(name);
      const OGRGeometry* g = f->GetGeometryRef();
      if (g != nullptr && wkbFlatten(g->getGeometryType()) == wkbLineString) {
        const OGRLineString* line = g->toLineString();
        for (int i = 0; i < line->getNumPoints(); ++i)
          feature.points.emplace_back(line->getX(i), line->getY(i), line->getZ(i));
      } else if (g != nullptr && wkbFlatten(g->getGeometryType()) == wkbPoint) {
        const OGRPoint* p = g->toPoint();
        feature.points.emplace_back(p->getX(), p->getY(), p->getZ());
      }
      out.push_back(std::move(feature));
    }
  }
  GDALClose(ds);
  return out;
}

class GeoExport : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing_support::fresh_test_dir(); }
  void TearDown() override { fs::remove_all(dir_); }

  // Each feature, placed back in the local frame, against the plan: UAV paths vertex by
  // vertex, targets, and threat tracks from the threat's motion (eq. 13).
  void expect_features_match_plan(const std::vector<Feature>& features, const json& plan,
                                  double tol_m, bool kinds_known = true) {
    const GeoFrame frame(kOrigin);
    ASSERT_EQ(features.size(), 3u + 2u + 1u);  // one per UAV path, target and threat
    std::map<std::string, const Feature*> by_name;
    for (const Feature& f : features) by_name[f.name] = &f;
    for (const json& u : plan["uavs"]) {
      const Feature* f = by_name.at(u["id"].get<std::string>());
      if (kinds_known) {
        EXPECT_EQ(f->kind, "uav_path");
      }
      ASSERT_EQ(f->points.size(), u["waypoints"].size());
      for (std::size_t k = 0; k < f->points.size(); ++k) {
        const Vec3 local = frame.to_local({f->points[k].y(), f->points[k].x(), f->points[k].z()});
        const json& w = u["waypoints"][k];
        ASSERT_LT((local - Vec3(w[0], w[1], w[2])).norm(), tol_m) << f->name << " " << k;
      }
    }
    for (const json& t : plan["targets"]) {
      const Feature* f = by_name.at(t["name"].get<std::string>());
      if (kinds_known) {
        EXPECT_EQ(f->kind, "target");
      }
      ASSERT_EQ(f->points.size(), 1u);
      const Vec3 local = frame.to_local({f->points[0].y(), f->points[0].x(), f->points[0].z()});
      const json& p = t["position_m"];
      EXPECT_LT((local - Vec3(p[0], p[1], p[2])).norm(), tol_m);
    }
    const Feature* threat = by_name.at("t1");
    if (kinds_known) {
      EXPECT_EQ(threat->kind, "threat_path");
    }
    ASSERT_EQ(threat->points.size(), 2u);
    // Appears at (0, 0, 200) at 20 s, moves (4, -3, 0) m/s until it vanishes at 80 s.
    const Vec3 start =
        frame.to_local({threat->points[0].y(), threat->points[0].x(), threat->points[0].z()});
    const Vec3 end =
        frame.to_local({threat->points[1].y(), threat->points[1].x(), threat->points[1].z()});
    EXPECT_LT((start - Vec3(0, 0, 200)).norm(), tol_m);
    EXPECT_LT((end - Vec3(240, -180, 200)).norm(), tol_m);
  }
  fs::path dir_;
};

TEST_F(GeoExport, GeoJsonReadByOgrHasEveryFeatureAtThePlansCoordinates) {
  const json plan = synthetic_plan(1, true);
  const MissionGeometry m = mission_from_plan_json(plan, "plan.json", std::nullopt);
  write_file_atomically(dir_ / "m.geojson", to_geojson(m));
  const std::vector<Feature> features = read_with_ogr(dir_ / "m.geojson");
  // GeoJSON keeps full double precision: well under a millimetre.
  expect_features_match_plan(features, plan, 1e-3);
  // The times at the waypoints come from the reference: 10 samples of 1 s per leg.
  const json doc = json::parse(to_geojson(m));
  const json& times = doc["features"][0]["properties"]["times_s"];
  ASSERT_EQ(times.size(), 12u);
  for (std::size_t k = 0; k < 12; ++k) EXPECT_DOUBLE_EQ(times[k].get<double>(), 10.0 * k);
  EXPECT_EQ(doc["features"][5]["properties"]["appear_s"], 20.0);
  EXPECT_EQ(doc["features"][5]["properties"]["vanish_s"], 80.0);
}

TEST_F(GeoExport, KmlReadByOgrHasEveryFeatureWithAbsoluteAltitudes) {
  const json plan = synthetic_plan(2, true);
  const MissionGeometry m = mission_from_plan_json(plan, "plan.json", std::nullopt);
  const std::string kml = to_kml(m);
  write_file_atomically(dir_ / "m.kml", kml);
  // Six placemarks, every one absolute (AMSL), none clamped to the ground.
  std::size_t absolute = 0;
  for (std::size_t at = kml.find("<altitudeMode>absolute</altitudeMode>"); at != std::string::npos;
       at = kml.find("<altitudeMode>absolute</altitudeMode>", at + 1))
    ++absolute;
  EXPECT_EQ(absolute, 6u);
  // 1e-9 degrees is 0.1 mm; altitudes have 1 mm.
  expect_features_match_plan(read_with_ogr(dir_ / "m.kml"), plan, 2e-3, false);
}

TEST_F(GeoExport, CsvReadByOgrHasOneRowPerVertex) {
  const json plan = synthetic_plan(3, true);
  const MissionGeometry m = mission_from_plan_json(plan, "plan.json", std::nullopt);
  write_file_atomically(dir_ / "m.csv", to_csv(m));
  const char* const options[] = {"X_POSSIBLE_NAMES=lon_deg", "Y_POSSIBLE_NAMES=lat_deg",
                                 "Z_POSSIBLE_NAMES=alt_amsl_m", nullptr};
  const std::vector<Feature> rows = read_with_ogr(dir_ / "m.csv", options);
  ASSERT_EQ(rows.size(), 3u * 12u + 2u + 2u);
  // Regroup the rows into one feature per name, in order, and compare as above.
  std::vector<Feature> grouped;
  for (const Feature& r : rows) {
    if (grouped.empty() || grouped.back().name != r.name) grouped.push_back({r.kind, r.name, {}});
    ASSERT_EQ(r.points.size(), 1u);
    grouped.back().points.push_back(r.points[0]);
  }
  expect_features_match_plan(grouped, plan, 2e-3);
}

TEST_F(GeoExport, QgcPlanHasTheDocumentedKeysAndOneWaypointItemPerWaypoint) {
  const json plan = synthetic_plan(4, true);
  const MissionGeometry m = mission_from_plan_json(plan, "plan.json", std::nullopt);
  const GeoFrame frame(kOrigin);
  for (std::size_t u = 0; u < 3; ++u) {
    const json q = json::parse(to_qgc_plan(m, u).dump());
    EXPECT_EQ(q["fileType"], "Plan");
    EXPECT_EQ(q["version"], 1);
    EXPECT_TRUE(q["groundStation"].is_string());
    EXPECT_TRUE(q["geoFence"].is_object());
    EXPECT_TRUE(q["rallyPoints"].is_object());
    const json& mission = q["mission"];
    EXPECT_EQ(mission["version"], 2);
    for (const char* key : {"firmwareType", "vehicleType", "cruiseSpeed", "hoverSpeed"})
      EXPECT_TRUE(mission[key].is_number()) << key;
    ASSERT_EQ(mission["plannedHomePosition"].size(), 3u);
    EXPECT_DOUBLE_EQ(mission["plannedHomePosition"][2].get<double>(), kOrigin.alt_amsl_m);
    const json& items = mission["items"];
    const json& waypoints = plan["uavs"][u]["waypoints"];
    ASSERT_EQ(items.size(), waypoints.size());
    for (std::size_t k = 0; k < items.size(); ++k) {
      const json& it = items[k];
      EXPECT_EQ(it["type"], "SimpleItem");
      EXPECT_EQ(it["command"], 16);      // MAV_CMD_NAV_WAYPOINT
      EXPECT_EQ(it["frame"], 0);         // MAV_FRAME_GLOBAL: AMSL
      EXPECT_EQ(it["AltitudeMode"], 2);  // absolute
      EXPECT_EQ(it["doJumpId"], k + 1);
      ASSERT_EQ(it["params"].size(), 7u);
      const Vec3 local =
          frame.to_local({it["params"][4].get<double>(), it["params"][5].get<double>(),
                          it["params"][6].get<double>()});
      EXPECT_LT((local - Vec3(waypoints[k][0], waypoints[k][1], waypoints[k][2])).norm(), 1e-3);
      EXPECT_DOUBLE_EQ(it["Altitude"].get<double>(), it["params"][6].get<double>());
    }
  }
}

TEST_F(GeoExport, APlanWithoutOriginNeedsOneAndMalformedPlansNameTheField) {
  const json plan = synthetic_plan(5, false);
  try {
    (void)mission_from_plan_json(plan, "out/plan.json", std::nullopt);
    FAIL() << "a plan without an origin was exported";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("geodetic origin"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--origin"), std::string::npos) << e.what();
  }
  // An explicit origin places it, exactly as if the plan had named it.
  const MissionGeometry given = mission_from_plan_json(plan, "out/plan.json", kOrigin);
  const MissionGeometry named = mission_from_plan_json(synthetic_plan(5, true), "p", std::nullopt);
  EXPECT_EQ(to_geojson(given), to_geojson(named));

  json bad = synthetic_plan(6, true);
  bad["uavs"][1]["waypoints"][3] = {1.0, "x", 3.0};
  try {
    (void)mission_from_plan_json(bad, "p.json", std::nullopt);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "p.json: uavs[1].waypoints[3].p");
  }
  bad = synthetic_plan(6, true);
  bad["frame"]["origin"]["lat_deg"] = 95.0;
  EXPECT_THROW((void)mission_from_plan_json(bad, "p.json", std::nullopt), InputError);
}

TEST_F(GeoExport, FlightTracksAreSampledAndEndWhereTheUavWasLastSeen) {
  mission::Scenario s;
  s.name = "flight";
  s.origin = kOrigin;
  s.uavs.resize(2);
  s.uavs[0].name = "a";
  s.uavs[1].name = "b";
  std::vector<mission::TrajectoryRow> rows;
  for (int k = 0; k <= 251; ++k) {  // 50 Hz for 5.02 s
    for (int u = 0; u < 2; ++u) {
      mission::TrajectoryRow r;
      r.t_s = 0.02 * k;
      r.uav = u;
      r.position_m = Vec3(10.0 * r.t_s, 100.0 * u, 300.0);
      rows.push_back(r);
    }
  }
  const MissionGeometry m = mission_from_flight(s, rows, 1.0);
  ASSERT_EQ(m.paths.size(), 2u);
  for (const ExportPath& p : m.paths) {
    ASSERT_EQ(p.times_s.size(), 7u);  // 0, 1, ..., 5 s and the last row at 5.02 s
    EXPECT_NEAR(p.times_s.back(), 5.02, 1e-9);
    EXPECT_NEAR(p.points_m.back().x(), 50.2, 1e-9);
  }
  s.origin.reset();
  EXPECT_THROW((void)mission_from_flight(s, rows, 1.0), InputError);
}

}  // namespace
}  // namespace ridgeline::io
