#include "swarm/agent_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "world/terrain.hpp"

namespace ridgeline::swarm {
namespace {

// A straight line east at 10 m/s and 100 m altitude, t = 0..200 s.
std::shared_ptr<const mpc::SampledReference> straight_line() {
  std::vector<double> t;
  std::vector<Vec3> p;
  for (int k = 0; k <= 200; ++k) {
    t.push_back(k);
    p.emplace_back(10.0 * k, 0.0, 100.0);
  }
  return std::make_shared<const mpc::SampledReference>(mpc::SampledReference::from_positions(t, p));
}

world::PeakTerrain flat(double height) {
  world::PeakTerrainConfig c;
  c.base_elevation_m = height;
  return world::PeakTerrain(c);
}

double min_horizontal_distance(const mpc::ReferenceTrajectory& r, const world::Threat& th,
                               double t0, double t1) {
  double best = 1e9;
  for (double t = t0; t <= t1; t += 0.05) {
    const Vec3 d = r.at(t).position_m - th.centre_at(t);
    best = std::min(best, std::hypot(d.x(), d.y()));
  }
  return best;
}

TEST(PlanDetour, NoThreatNearTheReferenceMeansNoConflict) {
  const auto plan = straight_line();
  world::Threat far{"far", Vec3(500.0, 400.0, 100.0), Vec3::Zero(), 30.0, 0.0, 1e9};
  const auto terrain = flat(0.0);
  const std::vector<world::Threat> threats{far};
  const DetourResult r =
      plan_detour(*plan, 10.0, threats, terrain, world::SafetyLimits{}, DetourOptions{});
  EXPECT_EQ(r.status, DetourResult::Status::kNoConflict);
  EXPECT_FALSE(r.reference.has_value());
}

// A threat moving north across the line: the detour keeps R + r_safe + clearance away from the
// centre at every time of the window, starts on the reference and ends on it.
TEST(PlanDetour, CrossingThreatIsAvoidedWithTheRequiredClearance) {
  const auto plan = straight_line();
  const world::Threat crossing{"x", Vec3(300.0, -100.0, 100.0), Vec3(0.0, 4.0, 0.0), 40.0, 0.0,
                               1e9};
  const auto terrain = flat(0.0);
  const std::vector<world::Threat> threats{crossing};
  DetourOptions o;
  o.lookahead_s = 60.0;  // the encounter and both ramps fit in the window
  const DetourResult r = plan_detour(*plan, 0.0, threats, terrain, world::SafetyLimits{}, o);
  ASSERT_EQ(r.status, DetourResult::Status::kPlanned) << r.message;
  ASSERT_TRUE(r.reference.has_value());
  // Without the detour the line passes through the threat.
  EXPECT_LT(min_horizontal_distance(*plan, crossing, 0.0, o.lookahead_s), crossing.radius_m);
  // Samples are 0.5 s apart: between them the chord may cut in by a little.
  EXPECT_GE(min_horizontal_distance(*r.reference, crossing, 0.0, o.lookahead_s),
            crossing.radius_m + world::SafetyLimits{}.threat_margin_m + o.clearance_m - 1.0);
  EXPECT_LT((r.reference->at(0.0).position_m - plan->at(0.0).position_m).norm(), 1e-6);
  const double t_end = r.reference->end_time_s();
  EXPECT_LT((r.reference->at(t_end).position_m - plan->at(t_end).position_m).norm(), 1e-6);
  // The lateral offset ramps: consecutive samples move sideways by about rate·Δt at most (the
  // push direction also turns with the moving threat: a factor 2 covers it).
  for (double t = 0.0; t + 0.5 <= t_end; t += 0.5) {
    const double y0 = r.reference->at(t).position_m.y(), y1 = r.reference->at(t + 0.5).position_m.y();
    EXPECT_LE(std::abs(y1 - y0), 2.0 * o.lateral_rate_m_s * 0.5);
  }
}

TEST(PlanDetour, DetourIsRaisedOverTerrainAndFailsAboveTheCeiling) {
  const auto plan = straight_line();
  const world::Threat sitting{"s", Vec3(300.0, 10.0, 100.0), Vec3::Zero(), 40.0, 0.0, 1e9};
  const std::vector<world::Threat> threats{sitting};
  DetourOptions o;
  // Terrain at 90 m: the reference itself (100 m) is below h_safe, so the detour climbs.
  const auto high = flat(90.0);
  const DetourResult raised = plan_detour(*plan, 0.0, threats, high, world::SafetyLimits{}, o);
  ASSERT_EQ(raised.status, DetourResult::Status::kPlanned) << raised.message;
  for (double t = 0.0; t <= o.lookahead_s; t += 0.5)
    EXPECT_GE(raised.reference->at(t).position_m.z(),
              90.0 + world::SafetyLimits{}.terrain_clearance_m);
  // Terrain at 490 m with a ceiling of 500 m: no valid detour, and it says why.
  const auto too_high = flat(490.0);
  const DetourResult failed = plan_detour(*plan, 0.0, threats, too_high, world::SafetyLimits{}, o);
  EXPECT_EQ(failed.status, DetourResult::Status::kFailed);
  EXPECT_NE(failed.message.find("altitude limit"), std::string::npos) << failed.message;
}

TEST(AgentReference, RejoinDelaysThePlanToTheNearestPoint) {
  AgentReference r(straight_line());
  EXPECT_DOUBLE_EQ(r.delay_at(0.0), 0.0);
  // At t = 50 s the UAV is at x = 300 m (20 s behind): the plan is delayed by 20 s.
  const double delay = r.rejoin(50.0, Vec3(300.0, 5.0, 100.0), 120.0, 30.0);
  EXPECT_NEAR(delay, 20.0, 0.11);
  EXPECT_NEAR(r.at(50.0).position_m.x(), 300.0, 1.1);
  EXPECT_NEAR(r.plan_end_time_s(), 200.0 + delay, 1e-9);
}

TEST(AgentReference, DetourAppliesOnlyInsideItsWindow) {
  AgentReference r(straight_line());
  std::vector<double> t{10.0, 11.0, 12.0};
  std::vector<Vec3> p{Vec3(100, 0, 100), Vec3(110, 20, 100), Vec3(120, 0, 100)};
  r.set_detour(mpc::SampledReference::from_positions(t, p));
  EXPECT_TRUE(r.has_detour());
  EXPECT_NEAR(r.at(11.0).position_m.y(), 20.0, 1e-9);
  EXPECT_NEAR(r.at(13.0).position_m.y(), 0.0, 1e-9);
  EXPECT_NEAR(r.at(9.0).position_m.x(), 90.0, 1e-9);
}

}  // namespace
}  // namespace ridgeline::swarm
