#include "swarm/in_process_transport.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"

namespace ridgeline::swarm {
namespace {

Message threat_from(int reporter, int id, double stamp) {
  ThreatReport r;
  r.reporter = reporter;
  r.threat_id = id;
  r.stamp_s = stamp;
  r.radius_m = 30.0;
  return r;
}

TEST(InProcessTransport, BroadcastReachesEveryoneButTheSenderAfterTheLatency) {
  InProcessTransport t(3, LinkModel{0.05, 0.0, 0.0}, 1);
  t.publish(0, 1.0, threat_from(0, 7, 1.0));
  std::vector<Envelope> got;
  t.receive(1, 1.049, got);
  EXPECT_TRUE(got.empty());
  t.receive(1, 1.05, got);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].sender, 0);
  EXPECT_DOUBLE_EQ(got[0].delivered_s, 1.05);
  EXPECT_EQ(std::get<ThreatReport>(got[0].message).threat_id, 7);
  got.clear();
  t.receive(0, 5.0, got);
  EXPECT_TRUE(got.empty());  // no echo to the sender
  t.receive(2, 5.0, got);
  EXPECT_EQ(got.size(), 1u);
  EXPECT_EQ(t.stats().sent, 2u);
  EXPECT_EQ(t.stats().delivered, 2u);
}

TEST(InProcessTransport, DropRateMatchesAndIsDeterministicForASeed) {
  auto run = [](std::uint64_t seed) {
    InProcessTransport t(2, LinkModel{0.0, 0.0, 0.2}, seed);
    for (int i = 0; i < 20000; ++i) t.publish(0, i * 0.01, threat_from(0, i, i * 0.01));
    std::vector<Envelope> got;
    t.receive(1, 1e9, got);
    return got;
  };
  const auto a = run(5), b = run(5);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(std::get<ThreatReport>(a[i].message).threat_id,
              std::get<ThreatReport>(b[i].message).threat_id);
  // Binomial(20000, 0.8): std ≈ 57 messages; five standard deviations.
  EXPECT_NEAR(static_cast<double>(a.size()), 16000.0, 285.0);
  EXPECT_NE(a.size(), run(6).size());
}

TEST(InProcessTransport, JitterLargerThanThePeriodReordersButDeliversInTimeOrder) {
  InProcessTransport t(2, LinkModel{0.05, 0.05, 0.0}, 3);
  for (int i = 0; i < 200; ++i) t.publish(0, i * 0.01, threat_from(0, i, i * 0.01));
  std::vector<Envelope> got;
  t.receive(1, 100.0, got);
  ASSERT_EQ(got.size(), 200u);
  int out_of_order = 0;
  for (std::size_t i = 1; i < got.size(); ++i) {
    EXPECT_GE(got[i].delivered_s, got[i - 1].delivered_s);
    out_of_order += std::get<ThreatReport>(got[i].message).threat_id <
                    std::get<ThreatReport>(got[i - 1].message).threat_id;
  }
  EXPECT_GT(out_of_order, 10);
  for (const Envelope& e : got) {
    EXPECT_GE(e.delivered_s - e.sent_s, 0.05 - 1e-12);
    EXPECT_LE(e.delivered_s - e.sent_s, 0.10 + 1e-12);
  }
}

TEST(InProcessTransport, BadLinkModelIsRejected) {
  EXPECT_THROW(InProcessTransport(2, LinkModel{-1.0, 0.0, 0.0}, 1), InputError);
  EXPECT_THROW(InProcessTransport(2, LinkModel{0.0, NAN, 0.0}, 1), InputError);
  EXPECT_THROW(InProcessTransport(2, LinkModel{0.0, 0.0, 1.5}, 1), InputError);
}

TEST(Messages, MalformedMessagesAreRejectedWithAReason) {
  PredictedTrajectory p;
  p.uav = 1;
  p.stamp_s = 2.0;
  p.positions_m = {Vec3(1, 2, 3)};
  EXPECT_FALSE(check_message(p, 3).has_value());
  p.uav = 3;
  EXPECT_NE(check_message(p, 3)->find("not a UAV"), std::string::npos);
  p.uav = 1;
  p.positions_m[0].x() = NAN;
  EXPECT_TRUE(check_message(p, 3).has_value());
  ThreatReport r;
  r.reporter = 0;
  r.threat_id = 1;
  r.radius_m = -4.0;
  EXPECT_NE(check_message(r, 2)->find("radius"), std::string::npos);
  ReferencePlan plan;
  plan.uav = 0;
  plan.points.resize(2);
  plan.times_s = {1.0, 1.0};
  EXPECT_NE(check_message(plan, 1)->find("not increasing"), std::string::npos);
  plan.times_s = {1.0, 2.0};
  EXPECT_FALSE(check_message(plan, 1).has_value());
  plan.target_ids = {-1};
  EXPECT_NE(check_message(plan, 1)->find("target -1"), std::string::npos);
  StateReport s;
  s.uav = 0;
  s.stamp_s = -1.0;
  EXPECT_TRUE(check_message(s, 1).has_value());
  EXPECT_STREQ(message_type_name(s), "StateReport");
}

}  // namespace
}  // namespace ridgeline::swarm
