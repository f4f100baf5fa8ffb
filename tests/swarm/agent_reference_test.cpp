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

void expect_same_point(const mpc::ReferencePoint& a, const mpc::ReferencePoint& b, double t) {
  EXPECT_EQ(a.position_m, b.position_m) << "t " << t;
  EXPECT_EQ(a.heading_rad, b.heading_rad) << "t " << t;
  EXPECT_EQ(a.speed_m_s, b.speed_m_s) << "t " << t;
  EXPECT_EQ(a.turn_rate_rad_s, b.turn_rate_rad_s) << "t " << t;
  EXPECT_EQ(a.climb_rate_m_s, b.climb_rate_m_s) << "t " << t;
}

void expect_sample_equals_at(const AgentReference& r, double t0, double step, int count) {
  std::vector<mpc::ReferencePoint> out(static_cast<std::size_t>(count));
  r.sample(t0, step, out);
  for (int j = 0; j < count; ++j) {
    const double t = t0 + static_cast<double>(j) * step;
    expect_same_point(out[static_cast<std::size_t>(j)], r.at(t), t);
  }
}

// The tracker's samples come from sample(): they must be at()'s bit for bit while the delay
// grows (the plan slowed down) and then holds, while the level moves, and with a detour inside
// the samples' times (at() for each) or outside them (the plan's walk).
TEST(AgentReference, SampleEqualsAtBitForBit) {
  AgentReference r(straight_line());
  expect_sample_equals_at(r, 5.0, 0.1, 41);
  r.set_delay(20.0, 3.0, 0.5);  // δ grows from 0 at 20 s to 3 s at 26 s
  r.set_level(21.0, 12.0, 2.0);  // the level reaches 12 m at 27 s
  for (const double t0 : {18.0, 22.5, 25.9, 30.0}) expect_sample_equals_at(r, t0, 0.1, 41);
  expect_sample_equals_at(r, 19.0, 0.0, 5);
  std::vector<double> t{40.0, 41.0, 42.0};
  std::vector<Vec3> p{Vec3(370, 0, 100), Vec3(380, 20, 100), Vec3(390, 0, 100)};
  r.set_detour(mpc::SampledReference::from_positions(t, p));
  for (const double t0 : {36.5, 37.9, 40.5, 42.0, 42.1, 50.0})
    expect_sample_equals_at(r, t0, 0.1, 41);
}

}  // namespace
}  // namespace ridgeline::swarm
