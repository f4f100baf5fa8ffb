#include "swarm/agent.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "core/error.hpp"
#include "world/terrain.hpp"

namespace ridgeline::swarm {
namespace {

std::shared_ptr<const mpc::SampledReference> line_east(double y, double z = 100.0) {
  std::vector<double> t;
  std::vector<Vec3> p;
  for (int k = 0; k <= 100; ++k) {
    t.push_back(k);
    p.emplace_back(10.0 * k, y, z);
  }
  return std::make_shared<const mpc::SampledReference>(mpc::SampledReference::from_positions(t, p));
}

std::shared_ptr<const world::Terrain> flat() {
  return std::make_shared<world::PeakTerrain>(world::PeakTerrainConfig{});
}

AgentOptions options(int id, int n) {
  AgentOptions o;
  o.id = id;
  o.num_uavs = n;
  o.targets = {{"end", Vec3(1000.0, 0.0, 100.0), 30.0, 30.0}};
  return o;
}

vehicle::State state_at(const Vec3& p) {
  vehicle::State s = vehicle::State::Zero();
  s.head<3>() = p;
  s[vehicle::kV] = 10.0;
  return s;
}

TEST(Agent, InvalidOptionsNameTheField) {
  AgentOptions o = options(3, 2);
  try {
    Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "id");
  }
}

TEST(Agent, MalformedAndForeignMessagesAreRejectedAndCounted) {
  Agent a(options(0, 3), world::SafetyLimits{}, line_east(0.0), flat());
  PredictedTrajectory bad;
  bad.uav = 1;
  bad.stamp_s = 1.0;
  bad.positions_m = {Vec3(std::nan(""), 0, 0)};
  a.receive(Envelope{1, 1.0, 1.0, bad});
  PredictedTrajectory impostor;  // says it is UAV 2 but comes from 1
  impostor.uav = 2;
  impostor.positions_m = {Vec3(0, 0, 100)};
  a.receive(Envelope{1, 1.0, 1.0, impostor});
  ThreatReport negative{1, 0, 1.0, Vec3(0, 0, 0), Vec3::Zero(), -5.0};
  a.receive(Envelope{1, 1.0, 1.0, negative});
  a.receive(Envelope{7, 1.0, 1.0, StateReport{}});  // sender out of range
  EXPECT_EQ(a.counters().messages_received, 4u);
  EXPECT_EQ(a.counters().messages_rejected, 4u);
  EXPECT_TRUE(a.known_threats().empty());
}

TEST(Agent, ThreatReportsAreLearnedAndOlderOnesIgnored) {
  Agent a(options(0, 2), world::SafetyLimits{}, line_east(0.0), flat());
  a.receive(
      Envelope{1, 5.0, 5.01, ThreatReport{1, 4, 5.0, Vec3(500, 0, 100), Vec3(1, 0, 0), 30.0}});
  a.receive(Envelope{1, 4.0, 5.02, ThreatReport{1, 4, 4.0, Vec3(0, 0, 0), Vec3::Zero(), 30.0}});
  const std::vector<world::Threat> known = a.known_threats();
  ASSERT_EQ(known.size(), 1u);
  EXPECT_DOUBLE_EQ(known[0].centre_m.x(), 500.0);  // the late, older report did not win
  EXPECT_DOUBLE_EQ(known[0].appear_s, 5.0);
  // Forgotten when nobody confirms it for threat_forget_s.
  a.control(5.0 + a.counters().messages_received * 0.0 + 11.0, state_at(Vec3(160, 0, 100)),
            Vec3::Zero());
  EXPECT_TRUE(a.known_threats().empty());
}

TEST(Agent, OwnSensingIsReportedOncePerPeriod) {
  AgentOptions o = options(0, 2);
  o.threat_report_period_s = 1.0;
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  std::vector<Message> outbox;
  const std::vector<ThreatObservation> seen{{2, Vec3(400, 50, 100), Vec3(0, -2, 0), 40.0}};
  for (int k = 0; k < 100; ++k) a.sense(k * 0.02, seen, outbox);  // 2 s at 50 Hz
  ASSERT_EQ(outbox.size(), 2u);
  const auto& first = std::get<ThreatReport>(outbox[0]);
  EXPECT_EQ(first.reporter, 0);
  EXPECT_EQ(first.threat_id, 2);
  EXPECT_FALSE(check_message(outbox[0], 2).has_value());
  EXPECT_EQ(a.counters().threat_reports_sent, 2u);
}

// The prediction to broadcast is one shared message a control step: the transport's every tick
// between two control steps sends the same copy, and the next control step makes a new one.
TEST(Agent, ThePredictionMessageIsOneSharedCopyAControlStep) {
  Agent a(options(2, 3), world::SafetyLimits{}, line_east(0.0), flat());
  const std::shared_ptr<const Message> before = a.prediction_message();
  ASSERT_NE(before, nullptr);
  EXPECT_EQ(a.prediction().uav, 2);
  EXPECT_TRUE(a.prediction().positions_m.empty());  // nothing flown yet
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  const std::shared_ptr<const Message> first = a.prediction_message();
  EXPECT_NE(first.get(), before.get());
  EXPECT_EQ(a.prediction_message().get(), first.get());
  EXPECT_FALSE(check_message(*first, 3).has_value());
  EXPECT_EQ(std::get<PredictedTrajectory>(*first).positions_m.size(), 40u);
  a.control(0.02, state_at(Vec3(0.4, 0, 100)), Vec3::Zero());
  EXPECT_NE(a.prediction_message().get(), first.get());
  // What was broadcast before stays as it was (a receiver may still hold it).
  EXPECT_TRUE(std::get<PredictedTrajectory>(*before).positions_m.empty());
  EXPECT_EQ(std::get<PredictedTrajectory>(*first).uav, 2);
}

// A threat sits on the line ahead: the agent's next control step re-plans a detour, and the
// reference it tracks keeps away from the threat.
TEST(Agent, KnownThreatOnTheReferenceTriggersADetour) {
  Agent a(options(0, 1), world::SafetyLimits{}, line_east(0.0), flat());
  std::vector<Message> outbox;
  const std::vector<ThreatObservation> seen{{0, Vec3(300, 0, 100), Vec3::Zero(), 40.0}};
  a.sense(0.0, seen, outbox);
  const AgentStep step = a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(step.mode, AgentMode::kTracking);
  EXPECT_EQ(a.counters().replans, 1u);
  EXPECT_TRUE(a.reference().has_detour());
  const Vec3 beside = a.reference().at(30.0).position_m;
  EXPECT_GE(std::hypot(beside.x() - 300.0, beside.y()), 40.0 + 10.0 + 15.0 - 1.0);
  EXPECT_EQ(a.prediction().uav, 0);
  EXPECT_EQ(a.prediction().positions_m.size(), 40u);
}

// With optimizer_replan the conflict is re-planned by the local optimizer: the new reference
// keeps R + r_safe from the (stationary) threat all along its window (checked every 0.05 s; the
// reference is linear between 0.02 s samples, 0.05 m tolerance) and re-joins the plan at the
// window's end.
TEST(Agent, OptimizerReplanAvoidsAKnownThreatAndRejoinsThePlan) {
  AgentOptions o = options(0, 1);
  o.optimizer_replan = true;
  o.local_replan.time_budget_s = 30.0;  // independent of the machine's load
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  std::vector<Message> outbox;
  const std::vector<ThreatObservation> seen{{0, Vec3(300, 0, 100), Vec3::Zero(), 40.0}};
  a.sense(0.0, seen, outbox);
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(a.counters().replans, 1u);
  EXPECT_EQ(a.counters().optimizer_replans, 1u);
  EXPECT_EQ(a.counters().optimizer_fallbacks, 0u);
  ASSERT_TRUE(a.reference().has_detour());
  const double window = o.detour.lookahead_s;
  for (double t = 0.0; t <= window; t += 0.05) {
    const Vec3 q = a.reference().at(t).position_m;
    EXPECT_GE((q - Vec3(300, 0, 100)).norm(), 40.0 + world::SafetyLimits{}.threat_margin_m - 0.05)
        << "t = " << t;
  }
  EXPECT_LT((a.reference().at(window).position_m - a.reference().plan_at(window).position_m).norm(),
            1e-6);
}

// An optimizer that finds no window (here: no time at all) hands over to the geometric detour.
TEST(Agent, OptimizerFailureFallsBackToTheDetour) {
  AgentOptions o = options(0, 1);
  o.optimizer_replan = true;
  o.local_replan.time_budget_s = 1e-12;
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  std::vector<Message> outbox;
  const std::vector<ThreatObservation> seen{{0, Vec3(300, 0, 100), Vec3::Zero(), 40.0}};
  a.sense(0.0, seen, outbox);
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(a.counters().optimizer_fallbacks, 1u);
  EXPECT_EQ(a.counters().optimizer_replans, 0u);
  EXPECT_EQ(a.counters().replans, 1u);
  EXPECT_TRUE(a.reference().has_detour());
}

// A neighbour's broadcast: positions every 0.1 s over 4 s from `start` at `velocity`.
PredictedTrajectory broadcast(int uav, double t_s, const Vec3& start, const Vec3& velocity) {
  PredictedTrajectory p{uav, t_s, 0.1, {}};
  for (int k = 1; k <= 40; ++k) p.positions_m.push_back(start + velocity * (0.1 * k));
  return p;
}

TEST(Agent, TheHigherIdYieldsToAHeadOnNeighbourByALevel) {
  // Head-on at 10 m/s each from 150 m apart: they would meet at t = 7.5 s near x = 75.
  const PredictedTrajectory head_on = broadcast(0, 0.0, Vec3(150, 0, 100), Vec3(-10, 0, 0));
  Agent yielding(options(1, 2), world::SafetyLimits{}, line_east(0.0), flat());
  yielding.receive(Envelope{0, 0.0, 0.0, head_on});
  yielding.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  // The nearest free level (up first), reached before the meeting: a level apart, the
  // crossing needs no horizontal detour.
  EXPECT_EQ(yielding.counters().level_changes, 1u);
  EXPECT_DOUBLE_EQ(yielding.reference().level_target_m(), 15.0);
  EXPECT_FALSE(yielding.reference().has_detour());
  EXPECT_GE(yielding.reference().at(7.5).position_m.z() - 100.0, 15.0 - 1e-9);
  // Its intent tells the others where it will be beyond its prediction: a level up.
  EXPECT_GT(yielding.prediction().intent_m.at(7).z(), 100.0 + 14.0);

  // The lower id keeps its plan: the other one gives way.
  Agent keeping(options(0, 2), world::SafetyLimits{}, line_east(0.0), flat());
  PredictedTrajectory from_one = head_on;
  from_one.uav = 1;
  keeping.receive(Envelope{1, 0.0, 0.0, from_one});
  keeping.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(keeping.counters().level_changes, 0u);
  EXPECT_EQ(keeping.counters().neighbour_conflicts, 0u);
  EXPECT_FALSE(keeping.reference().has_detour());
}

TEST(Agent, WithoutLevelsTheHigherIdYieldsWithADetour) {
  const PredictedTrajectory head_on = broadcast(0, 0.0, Vec3(150, 0, 100), Vec3(-10, 0, 0));
  AgentOptions o = options(1, 2);
  o.max_levels = 0;
  o.max_delay_s = 0.0;
  Agent yielding(o, world::SafetyLimits{}, line_east(0.0), flat());
  yielding.receive(Envelope{0, 0.0, 0.0, head_on});
  yielding.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(yielding.counters().level_changes, 0u);
  EXPECT_EQ(yielding.counters().neighbour_conflicts, 1u);
  ASSERT_TRUE(yielding.reference().has_detour());
  // At the meeting time the detour keeps d_safe + r_safe + clearance sideways of the neighbour.
  const Vec3 at_meeting = yielding.reference().at(7.5).position_m;
  EXPECT_GE(std::hypot(at_meeting.x() - 75.0, at_meeting.y()), 10.0 + 10.0 + 15.0 - 1.0);
}

TEST(Agent, AHoveringNeighbourOnThePathIsAvoidedWhateverTheIds) {
  // With levels: passed a level above (a delay cannot help against a UAV that stays).
  Agent a(options(0, 2), world::SafetyLimits{}, line_east(0.0), flat());
  a.receive(Envelope{1, 0.0, 0.0, broadcast(1, 0.0, Vec3(60, 0, 100), Vec3::Zero())});
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  // The climb to +15 m takes 5.8 s and the neighbour's zone starts 4 s ahead: a short delay
  // lets the level be reached first.
  EXPECT_EQ(a.counters().level_changes, 1u);
  EXPECT_LE(a.reference().delay_target_s(), 4.0);
  for (double t = 0.0; t <= 20.0; t += 0.1)
    EXPECT_GE((a.reference().at(t).position_m - Vec3(60, 0, 100)).norm(), 15.0 - 1e-9) << t;
  // Without levels and delays: a detour around it.
  AgentOptions o = options(0, 2);
  o.max_levels = 0;
  o.max_delay_s = 0.0;
  Agent b(o, world::SafetyLimits{}, line_east(0.0), flat());
  b.receive(Envelope{1, 0.0, 0.0, broadcast(1, 0.0, Vec3(60, 0, 100), Vec3::Zero())});
  b.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(b.counters().neighbour_conflicts, 1u);
  ASSERT_TRUE(b.reference().has_detour());
  const Vec3 passing = b.reference().at(6.0).position_m;
  EXPECT_GE(std::hypot(passing.x() - 60.0, passing.y()), 10.0 + 10.0 + 15.0 - 1.0);
}

// A UAV with an end position finishes there, not merely when the plan's time is up: one held
// back (a detour, the separation guard) flies on to it.
TEST(Agent, AnEndPositionIsReachedNotOnlyTimedOut) {
  AgentOptions o = options(0, 1);
  o.targets.clear();
  o.fly_to_end = true;
  o.end_radius_m = 30.0;
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  a.control(100.5, state_at(Vec3(900, 0, 100)), Vec3::Zero());  // 100 m short at the end time
  EXPECT_FALSE(a.finished());
  // (It re-joined its plan near where it is: the plan now ends later.)
  const double end_s = a.reference().plan_end_time_s();
  a.control(end_s + 0.5, state_at(Vec3(965, 0, 100)), Vec3::Zero());  // still 35 m short
  EXPECT_FALSE(a.finished());
  a.control(end_s + 1.0, state_at(Vec3(975, 0, 100)), Vec3::Zero());  // within 30 m of (1000, 0)
  EXPECT_TRUE(a.finished());
}

// Issue 19 part 5: a target blocked at the pass is approached again. A neighbour hovers on
// the target (which counts within 8 m) until t = 30 s, so the first pass keeps d_safe and
// more from it (the whole flight does) and misses the target; the reference is rewound, the UAV turns back, and the
// second approach, after the neighbour has left, inspects it.
TEST(Agent, ABlockedTargetIsApproachedAgain) {
  AgentOptions o = options(1, 2);
  o.targets.insert(o.targets.begin(), AgentTarget{"blocked", Vec3(200.0, 0.0, 100.0), 8.0, 10.0});
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  vehicle::State s = state_at(Vec3(0, 0, 100));
  const double dt = o.tracker.control_period_s;
  double closest = 1e9;
  for (int k = 0; k < static_cast<int>(100.0 / dt) && !a.finished(); ++k) {
    const double t = k * dt;
    // It leaves to the south, away from the side the first pass detours to (north).
    const Vec3 neighbour = t < 30.0 ? Vec3(200, 0, 100) : Vec3(200, -10.0 * (t - 30.0), 100);
    const Vec3 velocity = t < 30.0 ? Vec3::Zero() : Vec3(0, -10, 0);
    a.receive(Envelope{0, t, t, broadcast(0, t, neighbour, velocity)});
    const AgentStep step = a.control(t, s, Vec3::Zero());
    s = vehicle::rk4_step(s, step.command, Vec3::Zero(), o.tracker.vehicle, dt);
    closest = std::min(closest, (s.head<3>() - neighbour).norm());
  }
  EXPECT_GE(closest, 10.0);
  EXPECT_GE(a.counters().reapproaches, 1u);
  EXPECT_GE(a.targets_inspected(), 1);
  EXPECT_TRUE(a.missed_targets().empty() || a.missed_targets().front() != "blocked");
}

TEST(Agent, AUavBehindItsReferenceFliesOnToItsTargetInsteadOfTurningBack) {
  // The reference passed the target (x = 100 m at 10 s) long ago, but the UAV, 150 m behind
  // it after an avoidance, has not: no loop; it re-joins the plan short of the target.
  AgentOptions o = options(1, 2);
  o.targets.insert(o.targets.begin(), AgentTarget{"ahead", Vec3(100.0, 0.0, 100.0), 8.0, 10.0});
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  a.control(20.0, state_at(Vec3(50, 0, 100)), Vec3::Zero());
  EXPECT_EQ(a.counters().reapproaches, 0u);
  EXPECT_EQ(a.counters().rejoins, 1u);
  EXPECT_NEAR(a.reference().at(20.0).position_m.x(), 50.0, 1.5);
}

TEST(Agent, ASlotNeverLiftsTheUavOutOfATargetsAltitudeBand) {
  // The same crossing, over a target at the crossing point whose band is ±5 m: a level would
  // miss the inspection, so the UAV keeps the plan's altitude and takes a delay.
  PredictedTrajectory crossing = broadcast(0, 0.0, Vec3(100, -100, 100), Vec3(0, 10, 0));
  for (int k = 0; k <= 42; ++k)
    crossing.intent_m.push_back(Vec3(100, -100, 100) + Vec3(0, 10, 0) * k);
  AgentOptions o = options(1, 2);
  o.targets.insert(o.targets.begin(), AgentTarget{"bridge", Vec3(100.0, 0.0, 100.0), 30.0, 10.0});
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  a.receive(Envelope{0, 0.0, 0.0, crossing});
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_DOUBLE_EQ(a.reference().level_target_m(), 0.0);
  EXPECT_GT(a.reference().delay_target_s(), 0.0);
  // Without the target the cheaper slot is a level.
  Agent b(options(1, 2), world::SafetyLimits{}, line_east(0.0), flat());
  b.receive(Envelope{0, 0.0, 0.0, crossing});
  b.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_NE(b.reference().level_target_m(), 0.0);
}

TEST(Agent, ACrossingNeighbourOfHigherPriorityIsLetThroughFirstWhenNoLevelIsFree) {
  // A neighbour crosses the path at right angles at x = 100 m at t = 10 s. Levels are off:
  // the yielding UAV takes a delay and passes the crossing after the neighbour.
  PredictedTrajectory crossing = broadcast(0, 0.0, Vec3(100, -100, 100), Vec3(0, 10, 0));
  for (int k = 0; k <= 32; ++k)
    crossing.intent_m.push_back(Vec3(100, -100, 100) + Vec3(0, 10, 0) * k);
  AgentOptions o = options(1, 2);
  o.max_levels = 0;
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  a.receive(Envelope{0, 0.0, 0.0, crossing});
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(a.counters().delay_changes, 1u);
  EXPECT_GT(a.reference().delay_target_s(), 0.0);
  EXPECT_FALSE(a.reference().has_detour());
  // The reference keeps d_safe + the conflict margin from the neighbour's intent throughout,
  // and is flown above v_min meanwhile.
  for (double t = 0.0; t <= 30.0; t += 0.1) {
    const mpc::ReferencePoint r = a.reference().at(t);
    EXPECT_GE((r.position_m - messages::expected_position(crossing, t)).norm(), 19.0) << t;
    EXPECT_GE(r.speed_m_s, 5.0) << t;
  }
  // Its intent says so: where it will be at t = 10 s is short of the crossing.
  const PredictedTrajectory mine = a.prediction();
  ASSERT_GE(mine.intent_m.size(), 31u);
  EXPECT_LT(mine.intent_m[10].x(), 100.0 - 20.0);
}

TEST(Agent, ANeighbourOnAParallelTrackIsNoConflict) {
  Agent a(options(1, 2), world::SafetyLimits{}, line_east(0.0), flat());
  a.receive(Envelope{0, 0.0, 0.0, broadcast(0, 0.0, Vec3(0, 40, 100), Vec3(10, 0, 0))});
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_EQ(a.counters().neighbour_conflicts, 0u);
  EXPECT_FALSE(a.reference().has_detour());
}

TEST(Agent, PassingTheLastTargetFinishesAndHolds) {
  Agent a(options(0, 1), world::SafetyLimits{}, line_east(0.0), flat());
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  EXPECT_FALSE(a.finished());
  const AgentStep step = a.control(0.02, state_at(Vec3(990, 5, 100)), Vec3::Zero());
  EXPECT_EQ(step.mode, AgentMode::kFinished);
  EXPECT_EQ(a.targets_inspected(), 1);
  EXPECT_TRUE(a.missed_targets().empty());
  // A finished agent broadcasts that it holds where it is.
  const PredictedTrajectory p = a.prediction();
  ASSERT_FALSE(p.positions_m.empty());
  EXPECT_NEAR(p.positions_m.back().x(), 990.0, 1.0);
}

// A hovering UAV cannot dodge: with a known threat about to cross its last target, the agent
// keeps tracking (and detouring) instead of holding there, and holds once the threat is gone.
TEST(Agent, ALastTargetUnderAnApproachingThreatIsHeldOnlyAfterTheThreatHasPassed) {
  Agent a(options(0, 1), world::SafetyLimits{}, line_east(0.0), flat());
  a.control(0.0, state_at(Vec3(0, 0, 100)), Vec3::Zero());
  std::vector<Message> outbox;
  // 200 m north of the target, coming south at 5 m/s: over the target in 40 s (< 60 s guard).
  const ThreatObservation coming{7, Vec3(990, 200, 100), Vec3(0, -5, 0), 30.0};
  a.sense(0.02, std::span(&coming, 1), outbox);
  const AgentStep step = a.control(0.02, state_at(Vec3(990, 5, 100)), Vec3::Zero());
  EXPECT_EQ(a.targets_inspected(), 1);
  EXPECT_NE(step.mode, AgentMode::kFinished);
  // Later the threat is 340 m south of the UAV and moving away: nothing threatens the hold.
  const ThreatObservation gone{7, Vec3(990, -300, 100), Vec3(0, -5, 0), 30.0};
  a.sense(100.0, std::span(&gone, 1), outbox);
  EXPECT_EQ(a.control(100.0, state_at(Vec3(1000, 40, 100)), Vec3::Zero()).mode,
            AgentMode::kFinished);
  // Without the threat the same pass finishes at once (PassingTheLastTargetFinishesAndHolds).
}

TEST(Agent, TargetsStillOpenLongAfterThePlanEndAreReportedMissed) {
  AgentOptions o = options(0, 1);
  o.targets = {{"far", Vec3(0.0, 900.0, 100.0), 30.0, 30.0}};
  o.missed_after_s = 5.0;
  Agent a(o, world::SafetyLimits{}, line_east(0.0), flat());
  a.control(106.0, state_at(Vec3(1000, 0, 100)), Vec3::Zero());
  EXPECT_TRUE(a.finished());
  ASSERT_EQ(a.missed_targets().size(), 1u);
  EXPECT_EQ(a.missed_targets()[0], "far");
}

}  // namespace
}  // namespace ridgeline::swarm
