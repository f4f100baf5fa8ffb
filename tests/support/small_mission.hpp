// A small closed-loop mission built in code, shared by the sim tests: two UAVs cross a hill
// to two targets 600 m away, optionally with a threat crossing their routes.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "core/types.hpp"
#include "mission/scenario.hpp"
#include "mission/stage_inputs.hpp"
#include "planning/global_planner.hpp"
#include "world/terrain.hpp"

namespace ridgeline::sim::test {

struct Fixture {
  mission::Scenario scenario;
  std::shared_ptr<const world::Terrain> terrain;
  planning::GlobalPlan plan;
};

// Two UAVs cross a hill to two targets 600 m away (wind 1.1 m/s with gusts, 5 % message loss);
// with_threat adds a threat that crosses their routes. Sets `terrain`; the scenario is valid.
inline mission::Scenario small_scenario(std::shared_ptr<const world::Terrain>& terrain,
                                        bool with_threat) {
  world::PeakTerrainConfig peaks;
  peaks.peaks = {{350, 300, 60, 120, 120}};
  terrain = std::make_shared<world::PeakTerrain>(peaks);
  mission::Scenario s;
  s.name = "small";
  s.seed = 7;
  s.area = {0, 800, 0, 800};
  const Vec3 starts[] = {{100, 100, 60}, {100, 150, 60}};
  for (int i = 0; i < 2; ++i) {
    mission::UavSpec u;
    u.name = "u" + std::to_string(i);
    u.start_position_m = starts[i];
    u.start_heading_rad = kPi / 4;
    s.uavs.push_back(u);
  }
  s.targets = {{"a", Vec3(650, 550, 80), 1, 30}, {"b", Vec3(600, 650, 80), 1, 30}};
  if (with_threat) s.threats = {{"t", Vec3(300, 500, 90), Vec3(2.0, -2.0, 0.0), 30.0, 5.0, 300.0}};
  s.wind.mean_m_s = Vec3(1.0, 0.5, 0.0);
  s.wind.gust_std_m_s = 0.5;
  s.simulation.duration_s = 200.0;
  s.simulation.link_drop_rate = 0.05;
  EXPECT_TRUE(validate(s, *terrain).empty());
  return s;
}

// The small scenario with the proposed method's global plan.
inline Fixture small_mission(bool with_threat) {
  Fixture f;
  f.scenario = small_scenario(f.terrain, with_threat);
  f.plan = planning::plan_mission(mission::make_planning_problem(f.scenario, f.terrain),
                                  mission::make_planner_options(f.scenario));
  EXPECT_EQ(f.plan.status, planning::GlobalPlanStatus::kPlanned) << f.plan.message;
  return f;
}

}  // namespace ridgeline::sim::test
