// `ridgeline plan` as a user runs it, and an independent re-check of the plan.json it writes:
// the file's references are checked against the scenario's terrain with no planner code.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <array>

#include "io/scenario_file.hpp"

namespace ridgeline {
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

class PlanCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing_support::fresh_test_dir();
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(PlanCommand, DefaultPlanKeepsEveryHardConstraintWhenReCheckedFromTheFile) {
  ASSERT_EQ(run_cli("plan --out " + (dir_ / "out").string(), dir_ / "log.txt"), 0)
      << slurp(dir_ / "log.txt");
  const nlohmann::json plan = nlohmann::json::parse(slurp(dir_ / "out" / "plan.json"));
  const io::LoadedScenario loaded = io::load_default_scenario();
  const mission::Scenario& s = loaded.scenario;
  const world::Terrain& terrain = *loaded.terrain;

  ASSERT_EQ(plan["uavs"].size(), s.uavs.size());
  std::vector<std::vector<std::array<double, 4>>> refs;
  std::set<std::string> visited;
  for (const auto& uav : plan["uavs"]) {
    refs.push_back(uav["reference"].get<std::vector<std::array<double, 4>>>());
    const auto& ref = refs.back();
    ASSERT_GT(ref.size(), 100u);
    for (std::size_t k = 0; k < ref.size(); ++k) {
      const auto& [t, x, y, z] = ref[k];
      // Samples every 20 ms at ≤ 15 m/s are ≤ 0.3 m apart: the check is far denser than 5 m.
      ASSERT_GE(z - terrain.height(x, y), s.safety.terrain_clearance_m - 1e-6)
          << uav["id"] << " at t = " << t;
      ASSERT_GE(z, s.safety.altitude.min_m - 1e-6);
      ASSERT_LE(z, s.safety.altitude.max_m + 1e-6);
      if (k > 0) {
        // Samples every control period; the last one is at the end time, possibly sooner.
        if (k + 1 < ref.size()) {
          EXPECT_NEAR(t - ref[k - 1][0], s.mpc.control_period_s, 1e-6);
        } else {
          EXPECT_LE(t - ref[k - 1][0], s.mpc.control_period_s + 1e-6);
        }
        const double step = std::hypot(x - ref[k - 1][1], y - ref[k - 1][2]);
        ASSERT_LE(step, s.uavs[0].vehicle.max_speed_m_s() * s.mpc.control_period_s + 1e-6);
      }
    }
    for (const auto& name : uav["targets"]) {
      const auto target = std::find_if(s.targets.begin(), s.targets.end(),
                                       [&](const auto& tg) { return tg.name == name; });
      ASSERT_NE(target, s.targets.end());
      double closest = 1e9;
      for (const auto& [t, x, y, z] : ref)
        closest = std::min(closest, (Vec3(x, y, z) - target->position_m).norm());
      EXPECT_LE(closest, target->inspection_radius_m) << name;
      visited.insert(name.get<std::string>());
    }
  }
  EXPECT_EQ(visited.size(), s.targets.size());  // every target is assigned to someone

  // Separation at equal times; a UAV that has finished holds at its last point.
  std::size_t longest = 0;
  for (const auto& r : refs) longest = std::max(longest, r.size());
  double min_separation = 1e9;
  for (std::size_t k = 0; k < longest; ++k) {
    for (std::size_t i = 0; i < refs.size(); ++i) {
      for (std::size_t j = i + 1; j < refs.size(); ++j) {
        const auto& a = refs[i][std::min(k, refs[i].size() - 1)];
        const auto& b = refs[j][std::min(k, refs[j].size() - 1)];
        min_separation = std::min(min_separation, std::hypot(a[1] - b[1], a[2] - b[2], a[3] - b[3]));
      }
    }
  }
  EXPECT_GE(min_separation, s.safety.separation_m);
}

TEST_F(PlanCommand, UnreachableTargetFailsAndWritesNothing) {
  std::string yaml = slurp(fs::path(RIDGELINE_SOURCE_DIR) / "scenarios" / "default.yaml");
  // A ring of 700 m peaks (above the 500 m ceiling) around the hut.
  std::string ring;
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * kPi * k / 12;
    ring += "    - {x_m: " + std::to_string(1700 + 120 * std::cos(a)) + ", y_m: " +
            std::to_string(1700 + 120 * std::sin(a)) +
            ", height_m: 700, sigma_x_m: 50, sigma_y_m: 50}\n";
  }
  const std::string anchor = "    - {x_m: 1800, y_m: 300";
  ASSERT_NE(yaml.find(anchor), std::string::npos);
  yaml.insert(yaml.find(anchor), ring);
  const std::string hut = "position_m: [1850, 1850, 80]";
  ASSERT_NE(yaml.find(hut), std::string::npos);
  yaml.replace(yaml.find(hut), hut.size(), "position_m: [1700, 1700, 80]");
  std::ofstream(dir_ / "ring.yaml") << yaml;
  const int code = run_cli("plan --scenario " + (dir_ / "ring.yaml").string() + " --out " +
                               (dir_ / "out").string(),
                           dir_ / "log.txt");
  EXPECT_NE(code, 0);
  EXPECT_THAT(slurp(dir_ / "log.txt"), ::testing::HasSubstr("hut"));
  EXPECT_FALSE(fs::exists(dir_ / "out" / "plan.json"));
}

}  // namespace
}  // namespace ridgeline
