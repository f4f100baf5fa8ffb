// `ridgeline run` as a user runs it: the default mission is flown, and its trajectories.csv is
// re-checked against the scenario's terrain and threat motion computed here from the YAML
// file itself (eq. 12 and 13), with no simulator or library code.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

int run_cli(const std::string& args, const fs::path& log) {
  const std::string cmd =
      std::string(RIDGELINE_CLI_PATH) + " " + args + " >" + log.string() + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

struct Row {
  double t, x, y, z, rx, ry, rz, v, psi, w;
  std::string uav;
};

std::vector<Row> read_csv(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t,uav,x,y,z,ref_x,ref_y,ref_z,v,psi,w");
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string cell;
    std::vector<std::string> c;
    while (std::getline(ss, cell, ',')) c.push_back(cell);
    if (c.size() != 11) {
      ADD_FAILURE() << "bad row: " << line;
      continue;
    }
    Row r{};
    r.t = std::stod(c[0]);
    r.uav = c[1];
    double* f[] = {&r.x, &r.y, &r.z, &r.rx, &r.ry, &r.rz, &r.v, &r.psi, &r.w};
    for (int k = 0; k < 9; ++k) *f[k] = std::stod(c[static_cast<std::size_t>(k + 2)]);
    rows.push_back(r);
  }
  return rows;
}

// Eq. 12 with `max` combination, as the default scenario states it.
double terrain_height(const YAML::Node& terrain, double x, double y) {
  double h = 0.0;
  for (const auto& p : terrain["peaks"]) {
    const double dx = (x - p["x_m"].as<double>()) / p["sigma_x_m"].as<double>();
    const double dy = (y - p["y_m"].as<double>()) / p["sigma_y_m"].as<double>();
    h = std::max(h, p["height_m"].as<double>() * std::exp(-dx * dx - dy * dy));
  }
  return terrain["base_elevation_m"].as<double>() + h;
}

class RunCommand : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = ridgeline::testing_support::fresh_test_dir(); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(RunCommand, DefaultMissionIsFlownSafelyWhenReCheckedFromTheTrajectoryFile) {
  const fs::path out = dir_ / "out";
  ASSERT_EQ(run_cli("run --quiet --out " + out.string(), dir_ / "log.txt"), 0)
      << slurp(dir_ / "log.txt");
  const YAML::Node s =
      YAML::LoadFile(std::string(RIDGELINE_SOURCE_DIR) + "/scenarios/default.yaml");
  ASSERT_EQ(s["terrain"]["combination"].as<std::string>(), "max");
  const double h_safe = s["safety"]["terrain_clearance_m"].as<double>();
  const double d_safe = s["safety"]["separation_m"].as<double>();
  const double r_safe = s["safety"]["threat_margin_m"].as<double>();
  const double z_min = s["altitude"]["min_m"].as<double>();
  const double z_max = s["altitude"]["max_m"].as<double>();

  const std::vector<Row> rows = read_csv(out / "trajectories.csv");
  ASSERT_GT(rows.size(), 3u * 50u * 100u);  // three UAVs, well over 100 s at 50 Hz
  std::map<long long, std::vector<const Row*>> by_time;
  double min_clearance = 1e9, min_threat = 1e9, min_separation = 1e9;
  for (const Row& r : rows) {
    by_time[std::llround(r.t * 100.0)].push_back(&r);
    const double clearance = r.z - terrain_height(s["terrain"], r.x, r.y);
    min_clearance = std::min(min_clearance, clearance);
    EXPECT_GE(r.z, z_min) << r.uav << " at t " << r.t;
    EXPECT_LE(r.z, z_max) << r.uav << " at t " << r.t;
    for (const auto& th : s["threats"]) {
      const double appear = th["appear_s"].as<double>(), vanish = th["vanish_s"].as<double>();
      if (r.t < appear || r.t > vanish) continue;
      const auto c = th["centre_m"].as<std::array<double, 3>>();
      const auto v = th["velocity_m_s"].as<std::array<double, 3>>();
      const double dt = r.t - appear;
      const double d = std::hypot(r.x - c[0] - v[0] * dt, r.y - c[1] - v[1] * dt,
                                  r.z - c[2] - v[2] * dt) -
                       th["radius_m"].as<double>();
      min_threat = std::min(min_threat, d);
    }
  }
  for (const auto& [t, at] : by_time) {
    for (std::size_t i = 0; i < at.size(); ++i)
      for (std::size_t j = i + 1; j < at.size(); ++j)
        min_separation = std::min(min_separation, std::hypot(at[i]->x - at[j]->x,
                                                             at[i]->y - at[j]->y,
                                                             at[i]->z - at[j]->z));
  }
  EXPECT_GE(min_clearance, h_safe);      // no terrain collision, and h_safe kept
  EXPECT_GE(min_threat, r_safe);         // no intrusion, and the margin kept
  EXPECT_GE(min_separation, d_safe);

  const nlohmann::json m = nlohmann::json::parse(slurp(out / "metrics.json"));
  EXPECT_TRUE(m["mission_complete"].get<bool>());
  EXPECT_EQ(m["terrain_collisions"].get<int>(), 0);
  EXPECT_EQ(m["threat_intrusions"].get<int>(), 0);
  EXPECT_GT(m["threat_encounters"].get<int>(), 0);  // the default threats do cross the routes
  EXPECT_DOUBLE_EQ(m["avoidance_success_rate"].get<double>(), 1.0);
  for (const auto& [kind, count] : m["constraint_violations"].items())
    EXPECT_EQ(count.get<int>(), 0) << kind;
  // The simulator's own figures agree with the file's (the file is sampled at 50 Hz, the
  // metrics at 100 Hz, so the metrics may only be smaller).
  EXPECT_LE(m["min_separation_m"].get<double>(), min_separation + 1e-3);
  EXPECT_NEAR(m["min_separation_m"].get<double>(), min_separation, 1.0);
  for (const char* key : {"global_plan_s", "sim_time_s", "wall_time_s", "min_threat_distance_m"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_GT(m["mpc_solve_us"]["median"].get<double>(), 0.0);
  int inspected = 0;
  for (const auto& u : m["uavs"]) {
    EXPECT_GT(u["path_length_m"].get<double>(), 1000.0);
    EXPECT_LT(u["tracking_rmse_m"].get<double>(), 10.0);
    EXPECT_NEAR(u["tracking_mse_m2"].get<double>(),
                std::pow(u["tracking_rmse_m"].get<double>(), 2), 1e-9);
    inspected += u["targets_inspected"].get<int>();
  }
  EXPECT_EQ(inspected, static_cast<int>(s["targets"].size()));
  EXPECT_TRUE(fs::exists(out / "plan.json"));
  EXPECT_TRUE(fs::exists(out / "summary.json"));
}

TEST_F(RunCommand, BadLinkSettingNamesTheFieldAndWritesNothing) {
  std::string yaml = slurp(std::string(RIDGELINE_SOURCE_DIR) + "/scenarios/default.yaml");
  const std::string from = "drop_rate: 0.01";
  ASSERT_NE(yaml.find(from), std::string::npos);
  yaml.replace(yaml.find(from), from.size(), "drop_rate: 1.5");
  std::ofstream(dir_ / "bad.yaml") << yaml;
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run_cli("run --quiet --scenario " + (dir_ / "bad.yaml").string() + " --out " +
                        out.string(),
                    dir_ / "log.txt"),
            2);
  EXPECT_NE(slurp(dir_ / "log.txt").find("simulation.link.drop_rate"), std::string::npos)
      << slurp(dir_ / "log.txt");
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
