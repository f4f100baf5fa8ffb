// `ridgeline vehicle-sim --px4-dds` and `ridgeline fly --px4-dds` as a user runs them: two
// processes on PX4's own DDS topics (px4_msgs over uXRCE-DDS, rt/uav_1/fmu/...) in real time.
// The companion plans the default mission, streams offboard_control_mode, arms the simulated
// vehicle and switches it to offboard by vehicle_command, and flies UAV 0's reference for 15 s
// by trajectory_setpoint (velocity + yawspeed at 50 Hz); the vehicle (RK4, lags 20 % slower than
// the tracker's model) must follow it. A vehicle that never reports, one on another namespace
// and bad options are one error each (exit 2), nothing written.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/cli_run.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using ridgeline::testing_support::read_json;
using ridgeline::testing_support::run_cli;
using ridgeline::testing_support::slurp;

/// DDS options of this test run: PX4's domain would mix with other runs, so a partition of its
/// own (and a domain of these tests).
std::string dds_args(const std::string& name) {
  return "--domain-id 215 --partition ridgeline-fly-test-" + std::to_string(::getpid()) + "-" +
         name;
}

/// Starts `ridgeline ARGS` (split at spaces) in the background with its output in `log`.
pid_t spawn_cli(const std::string& args, const fs::path& log) {
  std::vector<std::string> words;
  for (std::size_t at = 0; at < args.size();) {
    const std::size_t end = std::min(args.find(' ', at), args.size());
    if (end > at) words.push_back(args.substr(at, end - at));
    at = end + 1;
  }
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(RIDGELINE_CLI_PATH));
    for (std::string& w : words) argv.push_back(w.data());
    argv.push_back(nullptr);
    ::execv(RIDGELINE_CLI_PATH, argv.data());
    ::_exit(127);
  }
  return pid;
}

/// Stops a spawned vehicle (SIGTERM: it prints its summary) and returns whether it exited 0.
bool stop(pid_t pid) {
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

TEST(FlyPx4Dds, FliesUav0ThroughARealTimeVehicleOnPx4TopicsAndFollowsTheReference) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const std::string dds = dds_args("flight");
  // The vehicle runs at most 120 s whatever happens, so a failed test leaves no process behind.
  const pid_t vehicle =
      spawn_cli("vehicle-sim --px4-dds --uav 0 --duration 120 " + dds, dir / "vehicle.log");
  ASSERT_GT(vehicle, 0);
  // A generous start timeout: on a loaded machine the vehicle may still be loading the scenario
  // when the companion has planned.
  const int fly_rc = run_cli("fly --px4-dds --uav 0 --duration 15 --start-timeout 60 " + dds +
                                 " --out " + (dir / "flight.json").string(),
                             dir / "fly.log");
  const bool vehicle_ok = stop(vehicle);
  const std::string fly_log = slurp(dir / "fly.log");
  const std::string vehicle_log = slurp(dir / "vehicle.log");
  std::printf("%s%s", fly_log.c_str(), vehicle_log.c_str());
  ASSERT_EQ(fly_rc, 0) << fly_log;
  EXPECT_TRUE(vehicle_ok) << vehicle_log;

  const nlohmann::json f = read_json(dir / "flight.json");
  EXPECT_TRUE(f["finished"].get<bool>()) << f["phase"];
  EXPECT_NEAR(f["flown_time_s"].get<double>(), 15.0, 0.1);
  // 50 Hz for 15 s, less what a loaded 2-core machine loses to scheduling.
  EXPECT_GT(f["steps"].get<int>(), 600);
  EXPECT_LT(f["stale_steps"].get<int>(), 10);
  // As over MAVLink (fly_command_test.cpp): the vehicle starts hovering while the reference
  // moves at cruise speed, falls ≈ v·τ_v behind and is caught up; real time adds jitter.
  EXPECT_LT(f["tracking_max_m"].get<double>(), 10.0);
  EXPECT_LT(f["tracking_rmse_m"].get<double>(), 4.0);
  EXPECT_GT(f["path_length_m"].get<double>(), 0.7 * 10.0 * 15.0);
  const nlohmann::json& p = f["px4_dds"];
  EXPECT_EQ(p["namespace"], "uav_1");
  EXPECT_EQ(p["odometry_rejected"].get<int>(), 0);
  EXPECT_GT(p["odometry_received"].get<int>(), 600);
  EXPECT_GT(p["status_received"].get<int>(), 0);
  // The vehicle got the offboard stream, the setpoints and the commands, and refused nothing.
  EXPECT_NE(vehicle_log.find("on PX4's DDS topics rt/uav_1/fmu/ (domain 215"), std::string::npos)
      << vehicle_log;
  EXPECT_NE(vehicle_log.find("in real time"), std::string::npos) << vehicle_log;
  EXPECT_NE(vehicle_log.find("trajectory_setpoint (0 rejected)"), std::string::npos) << vehicle_log;
  EXPECT_NE(vehicle_log.find("(0 refused, 0 refused by the vehicle)"), std::string::npos)
      << vehicle_log;
  EXPECT_NE(vehicle_log.find("; 0 lock-step steps"), std::string::npos) << vehicle_log;
}

TEST(FlyPx4Dds, AVehicleThatNeverReportsIsOneErrorNamingTheUavTheTopicAndWhatWasAwaited) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  // Nobody serves uav_1 in this partition.
  const fs::path out = dir / "flight.json";
  EXPECT_EQ(run_cli("fly --px4-dds --uav 0 --start-timeout 1 " + dds_args("silent") + " --out " +
                        out.string(),
                    dir / "a.log"),
            2);
  const std::string log = slurp(dir / "a.log");
  EXPECT_NE(log.find("error: uav1 (UAV 0): the PX4 vehicle did not start an offboard flight "
                     "within 1 s (stuck waiting for the vehicle's state); waited for "
                     "rt/uav_1/fmu/out/vehicle_odometry: no usable odometry (0 received, 0 "
                     "rejected)"),
            std::string::npos)
      << log;
  EXPECT_FALSE(fs::exists(out));
}

TEST(FlyPx4Dds, AVehicleOnAnotherNamespaceIsNotFlownAndTheErrorNamesTheTopicAwaited) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const std::string dds = dds_args("namespace");
  const pid_t vehicle = spawn_cli(
      "vehicle-sim --px4-dds --uav 1 --px4-namespace uav_2 "
      "--duration 120 " +
          dds,
      dir / "vehicle.log");
  ASSERT_GT(vehicle, 0);
  // UAV 1 (uav2) asked for on uav_3: its vehicle (on uav_2) is never flown.
  EXPECT_EQ(run_cli("fly --px4-dds --uav 1 --px4-namespace uav_3 --start-timeout 3 " + dds,
                    dir / "a.log"),
            2);
  EXPECT_TRUE(stop(vehicle));
  const std::string log = slurp(dir / "a.log");
  EXPECT_NE(log.find("error: uav2 (UAV 1): the PX4 vehicle did not start an offboard flight "
                     "within 3 s (stuck waiting for the vehicle's state); waited for "
                     "rt/uav_3/fmu/out/vehicle_odometry: no usable odometry (0 received"),
            std::string::npos)
      << log;
  const std::string vehicle_log = slurp(dir / "vehicle.log");
  EXPECT_NE(vehicle_log.find("received 0 offboard_control_mode, 0 trajectory_setpoint"),
            std::string::npos)
      << vehicle_log;
}

// PX4 obeys a vehicle_command only when it targets its own system id (MAV_SYS_ID): commands
// for another system are ignored, and the error says what the vehicle never did.
TEST(FlyPx4Dds, CommandsForAnotherSystemAreIgnoredAndTheErrorSaysTheVehicleNeverArmed) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const std::string dds = dds_args("system");
  const pid_t vehicle =
      spawn_cli("vehicle-sim --px4-dds --uav 0 --duration 120 " + dds, dir / "vehicle.log");
  ASSERT_GT(vehicle, 0);
  EXPECT_EQ(
      run_cli("fly --px4-dds --uav 0 --target-system 2 --start-timeout 4 " + dds, dir / "a.log"),
      2);
  EXPECT_TRUE(stop(vehicle));
  const std::string log = slurp(dir / "a.log");
  EXPECT_NE(log.find("error: uav1 (UAV 0): the PX4 vehicle did not start an offboard flight "
                     "within 4 s (stuck arming); waited for rt/uav_1/fmu/out/vehicle_status: "
                     "never armed ("),
            std::string::npos)
      << log;
  const std::string vehicle_log = slurp(dir / "vehicle.log");
  EXPECT_EQ(vehicle_log.find(" 0 vehicle_command"), std::string::npos) << vehicle_log;
}

TEST(FlyPx4Dds, BadOptionsAreOneErrorNamingTheOption) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  struct Case {
    std::string args, message;
  };
  const Case cases[] = {
      {"fly --uav 0", "--udp: is required (or --px4-dds)"},
      {"fly --uav 0 --px4-dds --px4-namespace fmu",
       "--px4-namespace: 'fmu' is not a PX4 vehicle namespace (uav_N, e.g. uav_1, or empty)"},
      {"fly --uav 0 --px4-dds --px4-namespace uav_007",
       "--px4-namespace: 'uav_007' is not a PX4 vehicle namespace"},
      {"fly --uav 0 --px4-dds --start-timeout 0",
       "--start-timeout: 0 s is not a positive number of seconds"},
      {"fly --uav 7 --px4-dds", "--uav: 7 is not a UAV of the scenario (0..2)"},
      {"fly --uav 0 --px4-dds --target-system 0",
       "--target-system: 0 is not a MAVLink system id (1..255)"},
      {"vehicle-sim --px4-dds --peer 127.0.0.1:9",
       "--peer: is for MAVLink over UDP, not --px4-dds"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const fs::path log = dir / ("case" + std::to_string(k++) + ".log");
    EXPECT_EQ(run_cli(c.args, log), 2) << c.args;
    EXPECT_NE(slurp(log).find("error: " + c.message), std::string::npos) << slurp(log);
  }
  // CLI11's own checks (exit 106, 109): --udp with --px4-dds, DDS options without it.
  EXPECT_NE(run_cli("fly --uav 0 --px4-dds --udp 127.0.0.1:9", dir / "x.log"), 0);
  EXPECT_NE(slurp(dir / "x.log").find("--udp excludes --px4-dds"), std::string::npos)
      << slurp(dir / "x.log");
  EXPECT_NE(run_cli("fly --uav 0 --udp 127.0.0.1:9 --domain-id 3", dir / "y.log"), 0);
  EXPECT_NE(slurp(dir / "y.log").find("--domain-id requires --px4-dds"), std::string::npos)
      << slurp(dir / "y.log");
}

}  // namespace
