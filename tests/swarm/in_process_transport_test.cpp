#include "swarm/in_process_transport.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

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
  EXPECT_EQ(std::get<ThreatReport>(got[0].message()).threat_id, 7);
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
    EXPECT_EQ(std::get<ThreatReport>(a[i].message()).threat_id,
              std::get<ThreatReport>(b[i].message()).threat_id);
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
    out_of_order += std::get<ThreatReport>(got[i].message()).threat_id <
                    std::get<ThreatReport>(got[i - 1].message()).threat_id;
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

// A prediction's positions and intent samples are checked coordinate by coordinate (four at a
// time): a NaN or an infinity in any coordinate of any point is named, for counts on either side
// of the groups of four; the largest finite values, −0 and denormals pass.
TEST(CheckMessage, EveryCoordinateOfAPredictionIsChecked) {
  for (int n = 1; n <= 9; ++n) {
    PredictedTrajectory p;
    p.uav = 0;
    p.stamp_s = 1.0;
    p.positions_m.assign(n, Vec3(1.0, -0.0, std::numeric_limits<double>::max()));
    p.intent_m.assign(n + 2, Vec3(std::numeric_limits<double>::denorm_min(), 2.0, -3.0));
    ASSERT_FALSE(check_message(p, 1).has_value()) << n;
    for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity()}) {
      for (int i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
          PredictedTrajectory q = p;
          q.positions_m[i][c] = bad;
          const auto error = check_message(q, 1);
          ASSERT_TRUE(error.has_value()) << n << " " << i << " " << c;
          EXPECT_NE(error->find("position is not finite"), std::string::npos) << *error;
        }
      }
      for (int i = 0; i < n + 2; ++i) {
        for (int c = 0; c < 3; ++c) {
          PredictedTrajectory q = p;
          q.intent_m[i][c] = bad;
          const auto intent_error = check_message(q, 1);
          ASSERT_TRUE(intent_error.has_value()) << n << " " << i << " " << c;
          EXPECT_NE(intent_error->find("intent sample is not finite"), std::string::npos);
        }
      }
    }
  }
}

Message prediction_at(int uav, double stamp, const Vec3& position) {
  PredictedTrajectory p;
  p.uav = uav;
  p.stamp_s = stamp;
  p.positions_m = {position, position + Vec3(1.0, 0.0, 0.0)};
  return p;
}

// Predictions from sender 0 that `receiver` got, up to now.
int predictions_from_0(InProcessTransport& t, int receiver, double now_s) {
  std::vector<Envelope> got;
  t.receive(receiver, now_s, got);
  int count = 0;
  for (const Envelope& e : got)
    count += e.sender == 0 && std::holds_alternative<PredictedTrajectory>(e.message()) ? 1 : 0;
  return count;
}

TEST(InProcessTransport, EveryReceiverSharesThePublishedCopy) {
  // A broadcast is not copied once a receiver: every envelope holds the published message.
  InProcessTransport t(4, LinkModel{0.01, 0.005, 0.0}, 3);
  const auto published =
      std::make_shared<const Message>(prediction_at(2, 0.5, Vec3(10.0, 20.0, 100.0)));
  t.publish(2, 0.5, published);
  for (int receiver : {0, 1, 3}) {
    std::vector<Envelope> got;
    t.receive(receiver, 1.0, got);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].payload.get(), published.get());
    EXPECT_EQ(std::get<PredictedTrajectory>(got[0].message()).uav, 2);
  }
  // A message the caller keeps is copied once, at publishing.
  Message kept = threat_from(1, 9, 0.6);
  t.publish(1, 0.6, kept);
  std::get<ThreatReport>(kept).threat_id = 10;
  std::vector<Envelope> got;
  t.receive(0, 1.0, got);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(std::get<ThreatReport>(got[0].message()).threat_id, 9);
}

TEST(InProcessTransport, ANullMessageIsRejected) {
  InProcessTransport t(2, LinkModel{}, 1);
  EXPECT_THROW(t.publish(0, 0.0, std::shared_ptr<const Message>{}), InputError);
  EXPECT_EQ(t.stats().published, 0u);
}

TEST(InProcessTransport, PredictionsReachNearAgentsEveryTickAndFarOnesOnlyEveryFarPeriod) {
  // 0 and 1 are 50 m apart, 2 is 1 km away; reach 100 m, far copies every 1 s.
  InProcessTransport t(3, LinkModel{}, 1, PredictionReach{100.0, 1.0});
  const std::vector<Vec3> at = {{0.0, 0.0, 100.0}, {50.0, 0.0, 100.0}, {1000.0, 0.0, 100.0}};
  for (int tick = 0; tick <= 10; ++tick)  // 0.1 s apart: 0 s is sender 0's far copy
    for (int i = 0; i < 3; ++i) t.publish(i, 0.1 * tick, prediction_at(i, 0.1 * tick, at[i]));
  EXPECT_EQ(predictions_from_0(t, 1, 0.95), 10);  // every tick up to 0.9 s
  EXPECT_EQ(predictions_from_0(t, 2, 0.95), 1);   // only the far copy at 0 s
  EXPECT_EQ(predictions_from_0(t, 2, 1.05), 1);   // the next one at 1 s
  EXPECT_EQ(predictions_from_0(t, 1, 1.05), 1);
  // A threat report still reaches everyone.
  t.publish(0, 1.1, threat_from(0, 3, 1.1));
  std::vector<Envelope> got;
  t.receive(2, 1.1, got);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(std::holds_alternative<ThreatReport>(got[0].message()));
  // Once 2 comes within reach it gets every tick.
  for (int tick = 12; tick <= 15; ++tick)
    for (int i = 0; i < 3; ++i)
      t.publish(i, 0.1 * tick, prediction_at(i, 0.1 * tick, i == 2 ? Vec3(20.0, 60.0, 100.0) : at[i]));
  EXPECT_EQ(predictions_from_0(t, 2, 1.55), 3);  // 1.3, 1.4, 1.5 s (1.2 s: the grid's last)
}

TEST(InProcessTransport, FanOutOfASpreadTeamIsTheFarCopiesNotEveryTick) {
  // N agents 1 km apart on a line, reach 300 m: nobody is in anyone's reach, so after the
  // first tick (no positions yet: to everyone) a sender's copies are its far ones, every 0.5 s.
  auto copies_in_one_second = [](int n) {
    InProcessTransport t(n, LinkModel{}, 1, PredictionReach{300.0, 0.5});
    auto tick = [&](int k) {
      for (int i = 0; i < n; ++i)
        t.publish(i, 0.01 * k, prediction_at(i, 0.01 * k, Vec3(1000.0 * i, 0.0, 100.0)));
    };
    tick(0);
    const std::uint64_t first = t.stats().sent;
    for (int k = 1; k <= 100; ++k) tick(k);
    return t.stats().sent - first;
  };
  for (int n : {20, 80}) {
    const std::uint64_t pairs = static_cast<std::uint64_t>(n) * (n - 1);
    const std::uint64_t copies = copies_in_one_second(n);
    EXPECT_GE(copies, pairs);      // every sender reached everyone at least once
    EXPECT_LE(copies, 3 * pairs);  // not 100 × pairs, as without a reach
  }
  // Without a reach every publish is N − 1 copies.
  InProcessTransport all(20, LinkModel{}, 1);
  all.publish(0, 0.0, prediction_at(0, 0.0, Vec3::Zero()));
  EXPECT_EQ(all.stats().sent, 19u);
  EXPECT_THROW(InProcessTransport(2, LinkModel{}, 1, PredictionReach{0.0, 1.0}), InputError);
  EXPECT_THROW(InProcessTransport(2, LinkModel{}, 1, PredictionReach{10.0, 0.0}), InputError);
}

}  // namespace
}  // namespace ridgeline::swarm
