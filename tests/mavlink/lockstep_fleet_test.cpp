// The lock-step team link (src/mavlink/lockstep_fleet.*) against simulated vehicles served over
// real UDP sockets on loopback (each vehicle in a thread of the test, on a port the system
// chose), with datagrams dropped at random in both directions. The check is exact bookkeeping:
// after N steps every vehicle has stepped exactly N times (a resent setpoint never steps it
// twice, a lost answer never skips a step), so its state equals a twin vehicle driven directly,
// without UDP, with the same commands; and a vehicle that stops answering is a clear error
// naming its UAV, within the step timeout, never a hang.
#include "mavlink/lockstep_fleet.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <thread>

#include "core/error.hpp"
#include "mavlink/messages.hpp"
#include "mavlink/ned_frame.hpp"
#include "mavlink/simulated_vehicle.hpp"
#include "mavlink/stream_parser.hpp"

namespace ridgeline::mavlink {
namespace {

constexpr double kPeriodS = 0.02;
constexpr double kHomeAltitudeM = 800.0;

SimulatedVehicleOptions vehicle_options(const Vec3& start_m) {
  SimulatedVehicleOptions o;
  o.params.tau_v_s *= 1.2;  // the truth's model mismatch
  o.initial_state = vehicle::State::Zero();
  o.initial_state.head<3>() = start_m;
  o.initial_state[vehicle::kPsi] = 0.4;
  world::WindConfig wind;
  wind.mean_m_s = Vec3(1.6, 1.2, 0.0);
  wind.gust_std_m_s = 0.8;
  o.wind = wind;
  o.offboard_entry_speed_m_s = 10.0;
  o.home_altitude_m = kHomeAltitudeM;
  return o;
}

/// A lock-step vehicle on 127.0.0.1:<free port> in its own thread, dropping each datagram in
/// and each answer out with probability `loss`; it stops answering after `answer_steps`
/// steps (< 0: never).
class LossyVehicleServer {
 public:
  LossyVehicleServer(const SimulatedVehicleOptions& o, double loss, std::uint64_t seed,
                     long long answer_steps = -1)
      : vehicle_(o),
        link_(UdpLink::listen("127.0.0.1", 0)),
        loss_(loss),
        seed_(seed),
        answer_steps_(answer_steps) {
    thread_ = std::thread([this] { run(); });
  }
  ~LossyVehicleServer() { stop(); }
  void stop() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  std::uint16_t port() const { return port_; }
  /// Only after stop().
  const SimulatedVehicle& vehicle() const { return vehicle_; }

 private:
  void run() {
    std::mt19937_64 rng(seed_);
    std::bernoulli_distribution lose(loss_);
    StreamParser parser;
    std::vector<EncodedFrame> out;
    std::vector<std::uint8_t> datagram;
    while (!stop_.load()) {
      const std::vector<std::uint8_t> in = link_.receive(0.02);
      if (in.empty() || lose(rng)) continue;
      parser.push(in, [&](const Frame& f) {
        if (const std::optional<Message> m = decode_message(f))
          vehicle_.handle_lockstep(*m, kPeriodS);
      });
      if (answer_steps_ >= 0 &&
          static_cast<long long>(vehicle_.stats().lockstep_steps) >= answer_steps_)
        continue;
      vehicle_.lockstep_reply(out);
      datagram.clear();
      for (const EncodedFrame& f : out)
        datagram.insert(datagram.end(), f.view().begin(), f.view().end());
      out.clear();
      if (!lose(rng)) link_.send(datagram);
    }
  }

  SimulatedVehicle vehicle_;
  UdpLink link_;
  std::uint16_t port_ = link_.local_port();
  double loss_;
  std::uint64_t seed_;
  long long answer_steps_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

LockstepFleetOptions fleet_options() {
  LockstepFleetOptions o;
  o.period_s = kPeriodS;
  o.home_altitude_m = kHomeAltitudeM;
  o.resend_after_s = 0.01;  // loopback answers in well under a millisecond when not lost
  o.start_timeout_s = 10.0;
  o.step_timeout_s = 10.0;
  return o;
}

/// Drives a twin vehicle directly (no UDP, no loss) through the same handshake and setpoints
/// as the fleet sends: the reference the fleet's vehicles must match.
struct Twin {
  SimulatedVehicle v;
  explicit Twin(const SimulatedVehicleOptions& o) : v(o) {
    CommandLong arm;
    arm.command = kMavCmdComponentArmDisarm;
    arm.param1 = 1.0f;
    arm.target_system = 1;
    v.handle_lockstep(
        hold_setpoint(start(), kHomeAltitudeM, SimulatedVehicle::kKeepAliveStamp, 1, 1), kPeriodS);
    v.handle_lockstep(arm, kPeriodS);
    CommandLong mode;
    mode.command = kMavCmdDoSetMode;
    mode.param1 = static_cast<float>(kModeFlagCustomModeEnabled);
    mode.param2 = static_cast<float>(kPx4MainModeOffboard);
    mode.target_system = 1;
    v.handle_lockstep(mode, kPeriodS);
  }
  Vec3 start() const { return v.state().head<3>(); }
  /// The heading as the fleet knows it: from the float ATTITUDE report.
  double reported_heading() const {
    return ned_yaw_to_enu_heading(report_state(v.state(), Vec3::Zero(), 0).attitude.yaw);
  }
  void step(std::uint64_t k, const FleetCommand& c) {
    const std::uint32_t stamp = SimulatedVehicle::lockstep_stamp_ms(k, kPeriodS);
    const Vec3 at = ned_position_to_enu(
        enu_position_to_ned(v.state().head<3>(), kHomeAltitudeM).cast<float>().cast<double>(),
        kHomeAltitudeM);
    v.handle_lockstep(c.hold ? hold_setpoint(at, kHomeAltitudeM, stamp, 1, 1)
                             : velocity_setpoint(c.command, reported_heading(), stamp, 1, 1),
                      kPeriodS);
  }
};

FleetCommand command_at(int vehicle, std::uint64_t k) {
  const double t = static_cast<double>(k) * kPeriodS;
  if (vehicle == 1 && t >= 5.0) return {vehicle::Input::Zero(), true};  // holds from 5 s on
  return {vehicle::Input(10.0 + 2.0 * std::sin(0.5 * t), 0.3 * std::sin(0.3 * t + vehicle),
                         1.0 * std::cos(0.2 * t)),
          false};
}

// 20 % of the datagrams lost each way over 400 steps (8 s): some steps need several resends,
// yet each vehicle steps exactly 400 times and ends where its lossless twin does.
TEST(LockstepFleet, LossyUdpNeitherSkipsNorRepeatsAStepAndHomeAltitudeIsApplied) {
  const Vec3 starts[] = {{100.0, 100.0, 950.0}, {150.0, 80.0, 900.0}};
  LossyVehicleServer a(vehicle_options(starts[0]), 0.2, 11), b(vehicle_options(starts[1]), 0.2, 12);
  std::vector<UdpLink> links;
  links.push_back(UdpLink::connect("127.0.0.1", a.port()));
  links.push_back(UdpLink::connect("127.0.0.1", b.port()));
  LockstepFleet fleet(fleet_options(), {"uavA (UAV 0)", "uavB (UAV 1)"}, std::move(links));
  std::vector<FleetReport> reports;
  fleet.start(reports);
  ASSERT_EQ(reports.size(), 2u);
  // Our z is AMSL; the vehicles' NED is about a home at 800 m: the fleet reads 950 m back.
  for (int i = 0; i < 2; ++i) EXPECT_LT((reports[i].position_m - starts[i]).norm(), 1e-3) << i;
  // Offboard started at cruise: ground velocity = 10 m/s along ψ + the wind.
  EXPECT_GT(reports[0].ground_velocity_m_s.head<2>().norm(), 7.0);

  Twin twins[] = {Twin(vehicle_options(starts[0])), Twin(vehicle_options(starts[1]))};
  constexpr std::uint64_t kSteps = 400;
  for (std::uint64_t k = 0; k < kSteps; ++k) {
    const std::vector<FleetCommand> commands = {command_at(0, k), command_at(1, k)};
    fleet.step(k, commands, reports);
    for (int i = 0; i < 2; ++i) twins[i].step(k, commands[static_cast<std::size_t>(i)]);
  }
  a.stop();
  b.stop();
  const LossyVehicleServer* servers[] = {&a, &b};
  for (int i = 0; i < 2; ++i) {
    const SimulatedVehicle& v = servers[i]->vehicle();
    EXPECT_EQ(v.stats().lockstep_steps, kSteps) << i;
    EXPECT_EQ(v.stats().lockstep_out_of_step, 0u) << i << ": " << v.stats().last_error;
    EXPECT_EQ(v.stats().setpoints_rejected, 0u) << v.stats().last_error;
    // A doubled or skipped step would put it v·Δt ≈ 0.2 m off; float rounding of the
    // setpoints and reports stays far below 1 mm over 8 s.
    EXPECT_LT((v.state().head<3>() - twins[i].v.state().head<3>()).norm(), 1e-3) << i;
    EXPECT_LT((reports[static_cast<std::size_t>(i)].position_m - v.state().head<3>()).norm(), 1e-3);
    const FleetVehicleStats s = fleet.stats(i);
    EXPECT_EQ(s.steps, kSteps);
    EXPECT_EQ(s.round_trip_us.size(), kSteps);
    // 20 % loss each way: about a third of the steps lose something (0.36 of 400 ≈ 144).
    EXPECT_GT(s.resends, 60u) << i;
    EXPECT_GT(v.stats().lockstep_duplicates, 20u) << i;  // answers lost, setpoint resent
    EXPECT_EQ(s.parser.rejected(), 0u);
  }
  EXPECT_TRUE(a.vehicle().holding() == false);
  EXPECT_TRUE(b.vehicle().holding());  // told to hold from 5 s on
  EXPECT_EQ(b.vehicle().stats().holds, 1u);
}

TEST(LockstepFleet, AVehicleThatStopsAnsweringIsATimeoutNamingItsUav) {
  LossyVehicleServer a(vehicle_options({0, 0, 900}), 0.0, 1),
      b(vehicle_options({50, 0, 900}), 0.0, 2, /*answer_steps=*/20);
  std::vector<UdpLink> links;
  links.push_back(UdpLink::connect("127.0.0.1", a.port()));
  links.push_back(UdpLink::connect("127.0.0.1", b.port()));
  LockstepFleetOptions o = fleet_options();
  o.step_timeout_s = 0.5;
  LockstepFleet fleet(o, {"uavA (UAV 0)", "uavB (UAV 1)"}, std::move(links));
  std::vector<FleetReport> reports;
  fleet.start(reports);
  std::uint64_t k = 0;
  try {
    for (; k < 100; ++k) fleet.step(k, {command_at(0, k), command_at(0, k)}, reports);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(k, 19u);  // its answer to step 19 (stamped 20) is the one that never comes
    EXPECT_EQ(what.rfind("uavB (UAV 1): the MAVLink vehicle at 127.0.0.1:", 0), 0u) << what;
    EXPECT_NE(what.find("did not answer step 19 (t = 0.38 s) within 0.5 s"), std::string::npos)
        << what;
  }
}

TEST(LockstepFleet, NobodyAtTheAddressIsAStartTimeoutNamingTheUav) {
  // A bound socket that never reads: nothing answers there, and no other test can take it.
  UdpLink silent = UdpLink::listen("127.0.0.1", 0);
  std::vector<UdpLink> links;
  links.push_back(UdpLink::connect("127.0.0.1", silent.local_port()));
  LockstepFleetOptions o = fleet_options();
  o.start_timeout_s = 0.3;
  LockstepFleet fleet(o, {"uav1 (UAV 0)"}, std::move(links));
  std::vector<FleetReport> reports;
  try {
    fleet.start(reports);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("uav1 (UAV 0): the MAVLink vehicle at 127.0.0.1:", 0), 0u) << what;
    EXPECT_NE(what.find("did not start a lock-step offboard flight within 0.3 s (no state "
                        "reported; 0 frames received"),
              std::string::npos)
        << what;
  }
}

TEST(LockstepFleet, BadOptionsNameTheOption) {
  LockstepFleetOptions o;
  o.period_s = 0.0;
  EXPECT_THROW(LockstepFleet(o, {}, {}), InputError);
  o = LockstepFleetOptions();
  o.resend_after_s = std::nan("");
  try {
    LockstepFleet f(o, {}, {});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "resend_after_s");
  }
}

}  // namespace
}  // namespace ridgeline::mavlink
