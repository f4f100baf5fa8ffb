// The DDS transport, plan link and world link over loopback between participants of one
// process (every participant has its own DDS stack: discovery, sockets, serialization).
// Each test uses a partition of its own (process id and test name), so parallel ctest runs
// and other users of the domain never see each other's samples.
#include "transport_dds/dds_transport.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "core/error.hpp"
#include "transport_dds/plan_link.hpp"
#include "transport_dds/sim_link.hpp"

namespace ridgeline::transport_dds {
namespace {

constexpr int kDomain = 211;  // a domain of these tests; partitions keep runs apart
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::shared_ptr<DdsParticipant> participant() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  DdsOptions o;
  o.domain_id = kDomain;
  o.partition = std::string("ridgeline-test-") + std::to_string(::getpid()) + "-" + info->name();
  return std::make_shared<DdsParticipant>(o);
}

/// Polls `receive` until `done` or 10 s (discovery on loopback takes ~10–100 ms; the bound
/// only keeps a broken build from hanging).
template <typename Poll, typename Done>
bool poll_until(Poll&& poll, Done&& done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < until) {
    poll();
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

DdsTransportOptions transport_options(int id, int num_uavs) {
  DdsTransportOptions o;
  o.participant_id = id;
  o.num_uavs = num_uavs;
  return o;
}

/// Publishes `message` from `a` until `b` has received something (the first samples may go
/// out before discovery has matched the two), and returns what b received.
std::vector<swarm::Envelope> send_until_received(DdsTransport& a, int sender, DdsTransport& b,
                                                 int receiver, const swarm::Message& message) {
  std::vector<swarm::Envelope> got;
  poll_until(
      [&] {
        a.publish(sender, 0.0, message);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        b.receive(receiver, 1.0, got);
      },
      [&] { return !got.empty(); });
  return got;
}

TEST(DdsTransport, PredictedTrajectoryRoundTripsBitExactly) {
  auto pa = participant();
  auto pb = participant();
  DdsTransport a(pa, transport_options(0, 3));
  DdsTransport b(pb, transport_options(1, 3));
  swarm::PredictedTrajectory p;
  p.uav = 0;
  p.stamp_s = 12.34;
  p.step_s = 0.1;
  for (int k = 0; k < 40; ++k) p.positions_m.push_back(Vec3(k * 1.1, -k / 3.0, 100.0 + k * 1e-9));
  const auto got = send_until_received(a, 0, b, 1, p);
  ASSERT_FALSE(got.empty());
  const auto* q = std::get_if<swarm::PredictedTrajectory>(&got.back().message());
  ASSERT_NE(q, nullptr);
  EXPECT_EQ(got.back().sender, 0);
  EXPECT_EQ(got.back().sent_s, 12.34);
  EXPECT_EQ(q->uav, 0);
  EXPECT_EQ(q->stamp_s, p.stamp_s);
  EXPECT_EQ(q->step_s, p.step_s);
  ASSERT_EQ(q->positions_m.size(), p.positions_m.size());
  for (std::size_t k = 0; k < p.positions_m.size(); ++k)
    EXPECT_EQ(q->positions_m[k], p.positions_m[k]) << k;  // doubles travel bit-exactly
  EXPECT_EQ(b.stats().rejected, 0u);
}

TEST(DdsTransport, ThreatStateAndPlanRoundTrip) {
  auto pa = participant();
  auto pb = participant();
  DdsTransport a(pa, transport_options(2, 3));
  DdsTransport ground(pb, transport_options(3, 3));  // the ground station: id num_uavs

  swarm::ThreatReport r{2, 7, 3.5, Vec3(1, 2, 3), Vec3(-4, 5, 0.25), 42.0};
  auto got = send_until_received(a, 2, ground, 3, r);
  ASSERT_FALSE(got.empty());
  const auto* rr = std::get_if<swarm::ThreatReport>(&got.back().message());
  ASSERT_NE(rr, nullptr);
  EXPECT_EQ(rr->reporter, 2);
  EXPECT_EQ(rr->threat_id, 7);
  EXPECT_EQ(rr->stamp_s, 3.5);
  EXPECT_EQ(rr->centre_m, r.centre_m);
  EXPECT_EQ(rr->velocity_m_s, r.velocity_m_s);
  EXPECT_EQ(rr->radius_m, 42.0);

  swarm::StateReport s;
  s.uav = 2;
  s.stamp_s = 9.0;
  s.state << 1, 2, 3, 0.5, 10, -0.1, 0.7;
  got = send_until_received(a, 2, ground, 3, s);
  ASSERT_FALSE(got.empty());
  const auto* ss = std::get_if<swarm::StateReport>(&got.back().message());
  ASSERT_NE(ss, nullptr);
  EXPECT_EQ(ss->uav, 2);
  EXPECT_EQ(ss->state, s.state);

  swarm::ReferencePlan plan;
  plan.uav = 1;
  plan.version = 3;
  plan.stamp_s = 0.5;
  plan.points = {{Vec3(0, 0, 50), 0.1, 10.0, 0.0, 1.0},
                 {Vec3(100, 0, 60), 0.2, 11.0, 0.01, 0.0},
                 {Vec3(200, 50, 70), 0.3, 12.0, -0.01, -1.0}};
  plan.times_s = {0.0, 10.0, 21.0};
  plan.target_ids = {2, 0};
  got = send_until_received(ground, 3, a, 2, plan);
  ASSERT_FALSE(got.empty());
  const auto* pp = std::get_if<swarm::ReferencePlan>(&got.back().message());
  ASSERT_NE(pp, nullptr);
  EXPECT_EQ(got.back().sender, 3);  // the ground station
  EXPECT_EQ(pp->uav, 1);
  EXPECT_EQ(pp->version, 3);
  EXPECT_EQ(pp->times_s, plan.times_s);
  ASSERT_EQ(pp->points.size(), plan.points.size());
  for (std::size_t k = 0; k < plan.points.size(); ++k) {
    EXPECT_EQ(pp->points[k].position_m, plan.points[k].position_m);
    EXPECT_EQ(pp->points[k].heading_rad, plan.points[k].heading_rad);
    EXPECT_EQ(pp->points[k].climb_rate_m_s, plan.points[k].climb_rate_m_s);
  }
  EXPECT_EQ(pp->target_ids, plan.target_ids);
}

TEST(DdsTransport, OwnMessagesAreNotDeliveredBack) {
  auto pa = participant();
  auto pb = participant();
  DdsTransport a(pa, transport_options(0, 2));
  DdsTransport b(pb, transport_options(1, 2));
  const swarm::ThreatReport r{0, 1, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0};
  ASSERT_FALSE(send_until_received(a, 0, b, 1, r).empty());
  std::vector<swarm::Envelope> own;
  a.receive(0, 1.0, own);
  EXPECT_TRUE(own.empty());
}

TEST(DdsTransport, MalformedAndOutOfRangeMessagesAreRejectedAndCounted) {
  auto pa = participant();
  auto pb = participant();
  DdsTransport a(pa, transport_options(0, 2));
  DdsTransport b(pb, transport_options(1, 2));
  // Wait for discovery with a valid message first.
  const swarm::ThreatReport good{0, 1, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0};
  ASSERT_FALSE(send_until_received(a, 0, b, 1, good).empty());

  std::vector<swarm::Message> bad;
  bad.push_back(swarm::ThreatReport{0, 2, 1.0, Vec3(kNaN, 0, 0), Vec3(1, 0, 0), 30.0});
  bad.push_back(swarm::ThreatReport{0, 3, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), -5.0});
  bad.push_back(swarm::ThreatReport{5, 4, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0});  // no UAV 5
  bad.push_back(swarm::ThreatReport{0, -1, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0});
  bad.push_back(swarm::ThreatReport{0, 5, -3.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0});
  swarm::ReferencePlan backwards;
  backwards.uav = 1;
  backwards.points.resize(2);
  backwards.times_s = {2.0, 1.0};
  bad.push_back(backwards);
  // Reliable topics deliver all of them; predictions are best effort and keep only the latest
  // per UAV, so they are sent one at a time below.
  for (const swarm::Message& m : bad) a.publish(0, 0.0, m);
  std::vector<swarm::Envelope> got;
  poll_until([&] { b.receive(1, 1.0, got); }, [&] { return b.stats().rejected >= bad.size(); });
  EXPECT_EQ(b.stats().rejected, bad.size()) << b.last_rejection();
  EXPECT_TRUE(got.empty());

  swarm::PredictedTrajectory huge;
  huge.uav = 0;
  huge.stamp_s = 1.0;
  huge.positions_m.assign(1001, Vec3(0, 0, 50));  // max_points is 1000
  swarm::PredictedTrajectory nan = huge;
  nan.positions_m.assign(10, Vec3(0, kNaN, 50));
  std::string rejection_of_huge;
  for (const swarm::PredictedTrajectory* q : {&huge, &nan}) {
    const swarm::PredictedTrajectory& p = *q;
    const std::uint64_t before = b.stats().rejected;
    poll_until(
        [&] {
          a.publish(0, 0.0, p);
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
          b.receive(1, 1.0, got);
        },
        [&] { return b.stats().rejected > before; });
    EXPECT_GT(b.stats().rejected, before);
    if (&p == &huge) rejection_of_huge = b.last_rejection();
  }
  EXPECT_TRUE(got.empty());
  EXPECT_NE(b.last_rejection().find("PredictedTrajectory"), std::string::npos);
  // The oversized one was refused by its length, naming the field, before it was copied.
  EXPECT_EQ(rejection_of_huge.find("PredictedTrajectory: positions_m: 1001 elements"), 0u)
      << rejection_of_huge;
}

TEST(DdsTransport, EmulatedLinkDelaysAndDropsAtTheConfiguredRate) {
  auto pa = participant();
  auto pb = participant();
  DdsTransport a(pa, transport_options(0, 2));
  DdsTransportOptions ob = transport_options(1, 2);
  ob.emulated_link = swarm::LinkModel{0.05, 0.0, 0.2};
  ob.seed = 99;
  DdsTransport b(pb, ob);
  // Discovery first (this copy may be dropped: poll until one arrives or is dropped).
  swarm::ThreatReport r{0, 1, 1.0, Vec3(0, 0, 0), Vec3(1, 0, 0), 30.0};
  std::vector<swarm::Envelope> got;
  poll_until(
      [&] {
        a.publish(0, 0.0, r);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        b.receive(1, 0.0, got);
      },
      [&] { return b.stats().dropped + b.stats().delivered > 0 || got.size() > 0; });
  b.receive(1, 1e6, got);  // flush
  got.clear();
  const swarm::TransportStats start = b.stats();

  // 1000 reports stamped t = 10 s in batches of 10 (the reader keeps 16), each batch received
  // at t: nothing may be delivered before t + 50 ms, and every kept copy at t + 50 ms.
  constexpr int kBatches = 100;
  r.stamp_s = 10.0;
  int delivered = 0;
  for (int batch = 0; batch < kBatches; ++batch) {
    for (int k = 0; k < 10; ++k) a.publish(0, 0.0, r);
    const std::uint64_t seen_before = b.stats().dropped + b.stats().delivered;
    poll_until([&] { b.receive(1, 10.0, got); },
               [&] {
                 return b.stats().dropped + b.stats().delivered + b.pending_count() - seen_before >=
                        10;
               });
    EXPECT_TRUE(got.empty()) << "delivered before its 50 ms latency";
    b.receive(1, 10.049, got);
    EXPECT_TRUE(got.empty());
    b.receive(1, 10.05, got);
    delivered += static_cast<int>(got.size());
    got.clear();
    EXPECT_EQ(b.pending_count(), 0u);
  }
  const double dropped = static_cast<double>(b.stats().dropped - start.dropped);
  EXPECT_EQ(dropped + delivered, 10.0 * kBatches);
  // Binomial(1000, 0.2): mean 200, σ = 12.6; ±5σ.
  EXPECT_NEAR(dropped, 200.0, 63.0);
}

TEST(PlanLink, FullReferenceRoundTripsAndReachesALateJoiner) {
  auto pg = participant();
  PlanLink ground(pg, 3, 5, true);
  messages::ReferencePlan plan;
  plan.uav = 2;
  plan.version = 1;
  plan.stamp_s = 0.0;
  for (int k = 0; k < 3000; ++k) {
    plan.times_s.push_back(0.02 * k);
    plan.points.push_back({Vec3(k * 0.2, std::sin(k * 0.01), 80.0), 0.001 * k, 10.0, 0.01, -0.5});
  }
  plan.target_ids = {4, 0};
  ground.publish(plan);
  // The agent's participant appears after the plan was published (transient local).
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  auto pa = participant();
  PlanLink agent(pa, 3, 5, false);
  std::vector<messages::ReferencePlan> got;
  ASSERT_TRUE(poll_until([&] { agent.take(got, 2); }, [&] { return !got.empty(); }));
  const messages::ReferencePlan& q = got.back();
  EXPECT_EQ(q.uav, 2);
  EXPECT_EQ(q.version, 1);
  EXPECT_EQ(q.times_s, plan.times_s);
  ASSERT_EQ(q.points.size(), plan.points.size());
  for (std::size_t k = 0; k < q.points.size(); ++k) {
    EXPECT_EQ(q.points[k].position_m, plan.points[k].position_m);
    EXPECT_EQ(q.points[k].heading_rad, plan.points[k].heading_rad);
    EXPECT_EQ(q.points[k].speed_m_s, plan.points[k].speed_m_s);
    EXPECT_EQ(q.points[k].turn_rate_rad_s, plan.points[k].turn_rate_rad_s);
    EXPECT_EQ(q.points[k].climb_rate_m_s, plan.points[k].climb_rate_m_s);
  }
  EXPECT_EQ(q.target_ids, plan.target_ids);
  // Another UAV's reader gets nothing for uav 1.
  std::vector<messages::ReferencePlan> other;
  agent.take(other, 1);
  EXPECT_TRUE(other.empty());
}

TEST(PlanLink, InvalidPlansAreRefusedBeforeSending) {
  auto pg = participant();
  PlanLink ground(pg, 3, 5, true);
  messages::ReferencePlan plan;
  plan.uav = 0;
  plan.times_s = {0.0, 1.0};
  plan.points.resize(2);
  plan.target_ids = {5};  // only 0..4
  EXPECT_THROW(ground.publish(plan), InputError);
  plan.target_ids = {};
  plan.times_s = {1.0, 1.0};
  EXPECT_THROW(ground.publish(plan), InputError);
  plan.times_s = {0.0, 1.0};
  plan.points[1].speed_m_s = kNaN;
  EXPECT_NE(messages::check_plan(plan, 3, 5)->find("not finite"), std::string::npos);
}

TEST(SimLink, ClockMeasurementAndCommandRoundTrip) {
  auto pw = participant();
  auto pa = participant();
  SimLink world(pw, 3, world_role());
  SimLink agent(pa, 3, agent_role());
  ClockTick clock{17, 0.34, true, true, {1}, {0, 2}, {5, 7}, {0.32, 0.3}};
  Measurement m;
  m.uav = 2;
  m.tick = 17;
  m.t_s = 0.34;
  m.state << 10, 20, 30, 0.1, 9.5, 0.01, -0.2;
  m.wind_m_s = Vec3(1.5, -0.5, 0.1);
  m.threats.push_back({3, Vec3(100, 200, 80), Vec3(-2, 1, 0), 45.0});
  std::vector<ClockTick> clocks;
  std::vector<Measurement> measurements;
  ASSERT_TRUE(poll_until(
      [&] {
        world.publish(clock);
        world.publish(m);
        agent.wait(0.01);
        agent.take(clocks);
        agent.take(measurements, 2);
      },
      [&] { return !clocks.empty() && !measurements.empty(); }));
  EXPECT_EQ(clocks.back().tick, 17u);
  EXPECT_EQ(clocks.back().t_s, 0.34);
  EXPECT_EQ(clocks.back().lost, std::vector<int>{1});
  EXPECT_EQ(clocks.back().answered, clock.answered);
  EXPECT_EQ(clocks.back().reports_sent, clock.reports_sent);
  EXPECT_EQ(clocks.back().prediction_stamps, clock.prediction_stamps);
  const Measurement& mm = measurements.back();
  EXPECT_EQ(mm.uav, 2);
  EXPECT_EQ(mm.state, m.state);
  EXPECT_EQ(mm.wind_m_s, m.wind_m_s);
  ASSERT_EQ(mm.threats.size(), 1u);
  EXPECT_EQ(mm.threats[0].threat_id, 3);
  EXPECT_EQ(mm.threats[0].centre_m, m.threats[0].centre_m);
  EXPECT_EQ(mm.threats[0].radius_m, 45.0);

  CommandReport c;
  c.uav = 2;
  c.tick = 17;
  c.t_s = 0.34;
  c.command = vehicle::Input(10.5, -0.02, 0.3);
  c.mode = swarm::AgentMode::kFallback;
  c.reference_m = Vec3(1, 2, 3);
  c.has_tracker = true;
  c.mpc_step_us = 412.0;
  c.qp_iterations = 3;
  c.plan_version = 2;
  c.targets_assigned = 2;
  c.targets_inspected = 1;
  c.missed_targets = {"north-ridge"};
  c.counters.replans = 4;
  c.counters.threat_reports_sent = 9;
  c.loop_period_s = 0.0201;
  c.compute_s = 0.0005;
  std::vector<CommandReport> commands;
  ASSERT_TRUE(poll_until(
      [&] {
        agent.publish(c);
        world.wait(0.01);
        world.take(commands);
      },
      [&] { return !commands.empty(); }));
  const CommandReport& cc = commands.back();
  EXPECT_EQ(cc.uav, 2);
  EXPECT_EQ(cc.command, c.command);
  EXPECT_EQ(cc.mode, swarm::AgentMode::kFallback);
  EXPECT_EQ(cc.missed_targets, c.missed_targets);
  EXPECT_EQ(cc.counters.replans, 4u);
  EXPECT_EQ(cc.counters.threat_reports_sent, 9u);
  EXPECT_EQ(cc.loop_period_s, 0.0201);
  EXPECT_EQ(cc.targets_inspected, 1);

  // A command with a NaN or an impossible target count is rejected and counted.
  const std::uint64_t before = world.stats().rejected;
  CommandReport bad = c;
  bad.command[1] = kNaN;
  CommandReport bad2 = c;
  bad2.targets_inspected = 3;
  CommandReport bad3 = c;
  bad3.mode = static_cast<swarm::AgentMode>(7);
  agent.publish(bad);
  agent.publish(bad2);
  agent.publish(bad3);
  poll_until([&] { world.take(commands); }, [&] { return world.stats().rejected >= before + 3; });
  EXPECT_EQ(world.stats().rejected, before + 3) << world.stats().last_rejection;
  EXPECT_NE(world.stats().last_rejection.find("Command: mode 7"), std::string::npos)
      << world.stats().last_rejection;
  EXPECT_EQ(commands.size(), 1u);
}

TEST(DdsParticipant, RejectsDomainIdsOutsideTheUsableRange) {
  DdsOptions o;
  o.domain_id = 231;
  EXPECT_THROW(DdsParticipant{o}, InputError);
  o.domain_id = -1;
  EXPECT_THROW(DdsParticipant{o}, InputError);
}

}  // namespace
}  // namespace ridgeline::transport_dds
