// Ridgeline's topics read and written by another DDS implementation: ridgeline-fastdds-peer
// (tests/fastdds/fastdds_peer.cpp, eProsima Fast DDS, which ROS 2 and PX4's uXRCE-DDS agent use)
// subscribes to our predicted-trajectory and threat topics and publishes a PX4-style
// TrajectorySetpoint, with types fastddsgen made from the IDL we generate. Every field must
// cross both ways unchanged: this is the independent check of "ROS 2 tools see the swarm" and
// of the px4_msgs wire format (XCDR1, field order and types, type and topic names, QoS).
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "support/temp_dir.hpp"
#include "transport_dds/dds_transport.hpp"
#include "transport_dds/px4_link.hpp"

namespace ridgeline::transport_dds {
namespace {

constexpr int kDomain = 214;  // a domain of these tests; the partition keeps runs apart

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(FastDdsCrosscheck, FastDdsReadsOurPredictionsAndThreatsAndWeReadItsPx4Setpoint) {
  const std::filesystem::path dir = testing_support::fresh_test_dir();
  DdsOptions options;
  options.domain_id = kDomain;
  options.partition = "ridgeline-fastdds-" + std::to_string(::getpid());
  auto participant = std::make_shared<DdsParticipant>(options);
  DdsTransportOptions to;
  to.participant_id = 1;
  to.num_uavs = 3;
  DdsTransport transport(participant, to);
  Px4Link vehicle(participant, Px4Side::kVehicle, {"uav_1"});

  // Values with every bit of their mantissas in use, so a narrowing anywhere shows.
  messages::PredictedTrajectory prediction;
  prediction.uav = 1;
  prediction.stamp_s = 12.345678901234567;
  prediction.step_s = 0.1;
  prediction.positions_m = {Vec3(100.0 / 3.0, -2.0 / 7.0, 55.5), Vec3(1e-300, 6.02e23, -0.0)};
  messages::ThreatReport threat;
  threat.reporter = 1;
  threat.threat_id = 7;
  threat.stamp_s = 99.125;
  threat.centre_m = Vec3(1200.0 / 7.0, 800.25, 90.0);
  threat.velocity_m_s = Vec3(-4.0 / 3.0, 2.5, 0.0);
  threat.radius_m = 45.0 + 1.0 / 3.0;
  px4::TrajectorySetpoint expected;
  expected.timestamp = 1234567890123ull;
  expected.position = {1.5f, -2.25f, 1.0f / 3.0f};
  expected.velocity = {10.0f / 3.0f, -0.1f, 2.0f};
  expected.acceleration = {0.5f, 0.25f, -9.81f};
  expected.jerk = {-1.0f, 2.0f, -3.0f};
  expected.yaw = 1.2345678f;
  expected.yawspeed = -0.0625f;

  std::vector<std::string> args = {RIDGELINE_FASTDDS_PEER_PATH, std::to_string(kDomain),
                                   options.partition, std::to_string(expected.timestamp)};
  for (const auto* v :
       {&expected.position, &expected.velocity, &expected.acceleration, &expected.jerk})
    for (const float x : *v) args.push_back(fmt::format("{:.9g}", x));
  args.push_back(fmt::format("{:.9g}", expected.yaw));
  args.push_back(fmt::format("{:.9g}", expected.yawspeed));
  const std::filesystem::path log = dir / "peer.log";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ASSERT_GT(pid, 0);

  // Publish until the peer exits (it does once it has printed both kinds, or after 20 s).
  std::vector<Px4Received> got;
  int status = 0;
  double now_s = 0.0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    transport.publish(1, now_s, prediction);
    transport.publish(1, now_s, threat);
    now_s += 0.05;
    vehicle.wait(0.05);
    vehicle.take(got);
  }
  vehicle.take(got);
  const std::string peer = slurp(log);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << peer;

  // What Fast DDS received, field by field (printed with 17 significant digits).
  EXPECT_NE(peer.find(fmt::format(
                "PredictedTrajectory uav=1 stamp_s={:.17g} step_s={:.17g} positions_m=[({:.17g}, "
                "{:.17g}, {:.17g}), ({:.17g}, {:.17g}, {:.17g})]",
                prediction.stamp_s, prediction.step_s, prediction.positions_m[0].x(),
                prediction.positions_m[0].y(), prediction.positions_m[0].z(),
                prediction.positions_m[1].x(), prediction.positions_m[1].y(),
                prediction.positions_m[1].z())),
            std::string::npos)
      << peer;
  EXPECT_NE(peer.find(fmt::format(
                "ThreatReport reporter=1 threat_id=7 stamp_s={:.17g} centre_m=({:.17g}, {:.17g}, "
                "{:.17g}) velocity_m_s=({:.17g}, {:.17g}, {:.17g}) radius_m={:.17g}",
                threat.stamp_s, threat.centre_m.x(), threat.centre_m.y(), threat.centre_m.z(),
                threat.velocity_m_s.x(), threat.velocity_m_s.y(), threat.velocity_m_s.z(),
                threat.radius_m)),
            std::string::npos)
      << peer;

  // What we received of Fast DDS's setpoint, field by field.
  ASSERT_FALSE(got.empty()) << "no TrajectorySetpoint from Fast DDS; peer:\n" << peer;
  for (const Px4Received& r : got) {
    EXPECT_EQ(r.vehicle, 0);
    const auto* t = std::get_if<px4::TrajectorySetpoint>(&r.message);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->timestamp, expected.timestamp);
    EXPECT_EQ(t->position, expected.position);
    EXPECT_EQ(t->velocity, expected.velocity);
    EXPECT_EQ(t->acceleration, expected.acceleration);
    EXPECT_EQ(t->jerk, expected.jerk);
    EXPECT_EQ(t->yaw, expected.yaw);
    EXPECT_EQ(t->yawspeed, expected.yawspeed);
  }
}

}  // namespace
}  // namespace ridgeline::transport_dds
