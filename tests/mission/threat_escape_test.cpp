// The escape analysis that splits intrusions into unavoidable and avoidable: its verdict
// "unavoidable" is checked against the truth model flown with every extreme command sequence
// (none keeps out), and obvious cases are classified as they must be.
#include "mission/threat_escape.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/random.hpp"

namespace ridgeline::mission {
namespace {

vehicle::State level_east(double speed_m_s) {
  vehicle::State s = vehicle::State::Zero();
  s[vehicle::kZ] = 100.0;
  s[vehicle::kV] = speed_m_s;
  return s;
}

world::Threat threat_at(const Vec3& centre, const Vec3& velocity, double radius_m) {
  world::Threat t;
  t.centre_m = centre;
  t.velocity_m_s = velocity;
  t.radius_m = radius_m;
  t.appear_s = 0.0;
  t.vanish_s = 600.0;
  return t;
}

// Flies the truth model (RK4, 10 ms) with a command held piecewise, and reports whether the UAV
// is ever inside the threat within `horizon_s`.
bool enters(const vehicle::State& start, const vehicle::VehicleParams& p, const world::Threat& t,
            const std::vector<vehicle::Input>& commands, double hold_s, double horizon_s) {
  vehicle::State s = start;
  const double dt = 0.01;
  for (double time = 0.0; time <= horizon_s; time += dt) {
    if (t.surface_distance(s.head<3>(), time) < 0.0) return true;
    const std::size_t k = std::min(commands.size() - 1, static_cast<std::size_t>(time / hold_s));
    s = vehicle::rk4_step(s, vehicle::clamp_to_limits(commands[k], s, p), Vec3::Zero(), p, dt);
  }
  return false;
}

TEST(ThreatEscape, AThreatThatAppearsOnTheUavIsUnavoidableAtContactZero) {
  const vehicle::VehicleParams p;
  const ThreatEscape e = assess_escape(level_east(10.0), Vec3::Zero(), p,
                                       threat_at(Vec3(20, 0, 100), Vec3::Zero(), 40), 0.0);
  EXPECT_TRUE(e.unavoidable);
  EXPECT_EQ(e.time_to_contact_s, 0.0);
}

TEST(ThreatEscape, AFarHeadOnThreatIsAvoidableWithItsContactTime) {
  const vehicle::VehicleParams p;
  // Surface 1000 − 30 = 970 m ahead, closing at 10 + 10 m/s: contact after 48.5 s.
  const ThreatEscape e = assess_escape(level_east(10.0), Vec3::Zero(), p,
                                       threat_at(Vec3(1000, 0, 100), Vec3(-10, 0, 0), 30), 0.0);
  EXPECT_FALSE(e.unavoidable);
  EXPECT_NEAR(e.time_to_contact_s, 48.5, 0.011);
  // A threat that passes 100 m to the side never touches: no contact.
  const ThreatEscape miss = assess_escape(
      level_east(10.0), Vec3::Zero(), p, threat_at(Vec3(1000, 100, 100), Vec3(-10, 0, 0), 30), 0.0);
  EXPECT_FALSE(miss.unavoidable);
  EXPECT_TRUE(std::isinf(miss.time_to_contact_s));
}

TEST(ThreatEscape, UnavoidableVerdictsHoldForEveryExtremeManoeuvreOfTheTruthModel) {
  // Random close pop-up threats; for every one called unavoidable, 3^3 constant extreme
  // commands (speed min/cruise/max × turn left/none/right × descend/level/climb) and 200
  // random bang-bang sequences all enter the sphere. Counted cases must exist both ways.
  const vehicle::VehicleParams p;
  Rng rng(19);
  int unavoidable = 0, avoidable = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const double radius = rng.uniform(20.0, 60.0);
    const double bearing = rng.uniform(-0.6, 0.6);
    const double distance = radius + rng.uniform(-5.0, 40.0);
    const Vec3 centre(distance * std::cos(bearing), distance * std::sin(bearing),
                      100.0 + rng.uniform(-15.0, 15.0));
    const world::Threat t =
        threat_at(centre, Vec3(rng.uniform(-8, 0), rng.uniform(-3, 3), 0), radius);
    const vehicle::State start = level_east(rng.uniform(6.0, 14.0));
    if (t.surface_distance(start.head<3>(), 0.0) < 0.0) continue;  // inside already: trivial
    const ThreatEscape e = assess_escape(start, Vec3::Zero(), p, t, 0.0);
    if (!e.unavoidable) {
      ++avoidable;
      continue;
    }
    ++unavoidable;
    const double v[] = {p.min_speed_m_s(), p.cruise_speed_m_s, p.max_speed_m_s()};
    const double omega[] = {-1.0, 0.0, 1.0};  // clamped to v/R_min
    const double w[] = {-p.max_climb_rate_m_s, 0.0, p.max_climb_rate_m_s};
    for (const double vc : v)
      for (const double oc : omega)
        for (const double wc : w)
          EXPECT_TRUE(enters(start, p, t, {vehicle::Input(vc, oc, wc)}, 1e9, 30.0))
              << "trial " << trial << " escaped with (" << vc << ", " << oc << ", " << wc << ")";
    for (int seq = 0; seq < 200; ++seq) {
      std::vector<vehicle::Input> commands;
      for (int k = 0; k < 30; ++k)
        commands.emplace_back(v[static_cast<int>(rng.uniform(0, 2.999))],
                              omega[static_cast<int>(rng.uniform(0, 2.999))],
                              w[static_cast<int>(rng.uniform(0, 2.999))]);
      EXPECT_TRUE(enters(start, p, t, commands, 0.5, 15.0)) << "trial " << trial << " seq " << seq;
    }
  }
  EXPECT_GT(unavoidable, 5);
  EXPECT_GT(avoidable, 5);
}

}  // namespace
}  // namespace ridgeline::mission
