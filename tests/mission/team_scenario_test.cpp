// The team scenario generator (issue 20): take-off grid, targets and threats, and its errors.
#include "mission/team_scenario.hpp"

#include <gtest/gtest.h>

#include <memory>

#include "world/terrain.hpp"

namespace ridgeline::mission {
namespace {

struct Base {
  Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain;
};

Base default_like() {
  Base b;
  world::PeakTerrainConfig peaks;
  peaks.peaks = {{600, 700, 220, 180, 150},  {1100, 450, 160, 150, 200},
                 {900, 1250, 300, 200, 170}, {1500, 1000, 250, 170, 220},
                 {400, 1500, 120, 150, 150}, {1400, 1600, 180, 160, 140},
                 {1800, 300, 80, 120, 120}};
  b.terrain = std::make_shared<world::PeakTerrain>(peaks);
  UavSpec u;
  u.name = "uav1";
  u.start_position_m = Vec3(100, 130, 60);
  b.scenario.uavs.push_back(u);
  b.scenario.targets.push_back({"mast", Vec3(1700, 1300, 90), 2, 30.0});
  return b;
}

TEST(TeamScenario, ThirtyUavsMakeAValidScenarioOnAGridWithTheRequiredSpacing) {
  const Base base = default_like();
  const Scenario s = make_team_scenario(base.scenario, *base.terrain, {30, 60, 7});
  ASSERT_EQ(s.uavs.size(), 30u);
  ASSERT_EQ(s.targets.size(), 60u);
  EXPECT_EQ(s.threats.size(), 3u);  // the default density on 4 km²
  EXPECT_EQ(s.seed, 7u);
  const double spacing = takeoff_spacing_m(s.safety);
  EXPECT_GE(spacing, s.safety.separation_m + 5.0);
  for (std::size_t i = 0; i < s.uavs.size(); ++i)
    for (std::size_t j = i + 1; j < s.uavs.size(); ++j)
      EXPECT_GE((s.uavs[i].start_position_m - s.uavs[j].start_position_m).head<2>().norm(),
                spacing - 1e-9);
  // Targets spread over the area, not bunched: both halves of each axis hold some.
  int east = 0, north = 0;
  for (const InspectionTarget& t : s.targets) {
    east += t.position_m.x() > 1000.0;
    north += t.position_m.y() > 1000.0;
  }
  EXPECT_GT(east, 10);
  EXPECT_GT(north, 10);
  EXPECT_TRUE(validate(s, *base.terrain).empty()) << validate(s, *base.terrain).front().what();
}

TEST(TeamScenario, TheSeedDecidesTargetsAndThreats) {
  const Base base = default_like();
  const Scenario a = make_team_scenario(base.scenario, *base.terrain, {5, 8, 1});
  const Scenario b = make_team_scenario(base.scenario, *base.terrain, {5, 8, 1});
  const Scenario c = make_team_scenario(base.scenario, *base.terrain, {5, 8, 2});
  EXPECT_EQ(a.targets[3].position_m, b.targets[3].position_m);
  EXPECT_NE(a.targets[3].position_m, c.targets[3].position_m);
  EXPECT_EQ(a.uavs[4].start_position_m, c.uavs[4].start_position_m);  // the grid is fixed
}

TEST(TeamScenario, HundredUavsAndAGivenThreatCountAreValid) {
  const Base base = default_like();
  TeamScenarioOptions o{100, 100, 3};
  o.threats = 6;
  const Scenario s = make_team_scenario(base.scenario, *base.terrain, o);
  EXPECT_EQ(s.threats.size(), 6u);
  const auto problems = validate(s, *base.terrain);
  EXPECT_TRUE(problems.empty()) << problems.front().what();
}

TEST(TeamScenario, BadCountsNameTheirField) {
  const Base base = default_like();
  auto field_of = [&](TeamScenarioOptions o) {
    try {
      make_team_scenario(base.scenario, *base.terrain, o);
    } catch (const InputError& e) {
      return e.field();
    }
    return std::string("no error");
  };
  EXPECT_EQ(field_of({0, 3, 1}), "uavs");
  EXPECT_EQ(field_of({3, 0, 1}), "targets");
  EXPECT_EQ(field_of({5000, 3, 1}), "uavs");  // 64 x 64 fit at 30 m in 1.9 km
  TeamScenarioOptions narrow{4, 3, 1};
  Base small = default_like();
  small.scenario.area = {0, 120, 0, 2000};  // one column of 30 m in 20 m of width
  EXPECT_EQ(field_of(narrow), "no error");
  try {
    make_team_scenario(small.scenario, *small.terrain, {200, 3, 1});
    ADD_FAILURE() << "200 UAVs in a 120 m wide strip";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "uavs");
  }
}

}  // namespace
}  // namespace ridgeline::mission
