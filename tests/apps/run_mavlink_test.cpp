// `ridgeline run --mavlink`: the whole team flown through `ridgeline vehicle-sim --lockstep`
// processes over UDP on loopback. A shortened default mission (the scenario with
// simulation.duration_s cut to 60 s, threats t1 and t2 already out and sensed) flown both ways must
// give the in-process run's metrics: the world model (threats, wind, sensors, metrics) is the
// same, the vehicles integrate the same RK4 in the same wind field, so only float32 on the wire
// and the metrics' sampling (the control rate instead of the message rate) differ. Bad options
// and a vehicle that never answers are one clear error each, with nothing written.
// Every vehicle takes a port the system chooses (port 0) and announces itself to the
// companion's own free port, so parallel runs never collide.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>

#include "mavlink/udp_link.hpp"
#include "support/cli_run.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ridgeline::testing_support::read_json;
using ridgeline::testing_support::relative;
using ridgeline::testing_support::run_cli;
using ridgeline::testing_support::short_default_scenario;
using ridgeline::testing_support::slurp;

/// scripts/geo_example.sh's scenario (an EPSG:4326 valley DEM, a geodetic origin with its home
/// at 800 m above sea level, z above mean sea level) with the mission cut to 30 s.
fs::path short_geo_scenario(const fs::path& dir) {
  const std::string cmd = std::string(RIDGELINE_SOURCE_DIR) + "/scripts/geo_example.sh " +
                          (dir / "geo").string() + " >" + (dir / "geo.log").string() + " 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << slurp(dir / "geo.log");
  const fs::path p = dir / "geo" / "short.yaml";
  std::ofstream(p) << slurp(dir / "geo" / "valley.yaml") << "simulation: {duration_s: 30}\n";
  return p;
}

/// Starts `ridgeline ARGS...` in the background with its output in `log`.
pid_t spawn_cli(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(RIDGELINE_CLI_PATH));
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execv(RIDGELINE_CLI_PATH, argv.data());
    ::_exit(127);
  }
  return pid;
}

/// The port a `vehicle-sim --udp 0` prints in its log ("listening on 127.0.0.1:PORT"); 0 when
/// it has not within 30 s.
int announced_port(const fs::path& log) {
  const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
  for (int i = 0; i < 300; ++i) {
    std::smatch m;
    const std::string text = slurp(log);
    if (std::regex_search(text, m, listening)) return std::stoi(m[1]);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return 0;
}

/// Flies `scenario` in process into DIR/run and through vehicle-sim processes into DIR/mav.
void fly_both_ways(const fs::path& dir, const fs::path& scenario) {
  ASSERT_EQ(
      run_cli("run --quiet --scenario " + scenario.string() + " --out " + (dir / "run").string(),
              dir / "run.log"),
      0)
      << slurp(dir / "run.log");
  ASSERT_EQ(run_cli("run --quiet --mavlink --scenario " + scenario.string() + " --out " +
                        (dir / "mav").string(),
                    dir / "mav.log"),
            0)
      << slurp(dir / "mav.log");
}

TEST(RunMavlink, AShortenedMissionThroughVehicleSimProcessesMatchesTheInProcessRun) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const fs::path scenario = short_default_scenario(dir, 60);
  ASSERT_NO_FATAL_FAILURE(fly_both_ways(dir, scenario));
  for (const char* f : {"metrics.json", "trajectories.csv", "plan.json", "summary.json"})
    EXPECT_TRUE(fs::exists(dir / "mav" / f)) << f;
  const json a = read_json(dir / "run" / "metrics.json");
  const json b = read_json(dir / "mav" / "metrics.json");

  // Zero collisions of any kind, as in the in-process run.
  EXPECT_TRUE(b["safe"].get<bool>());
  for (const char* key : {"terrain_collisions", "separation_violations", "threat_intrusions"})
    EXPECT_EQ(b[key].get<int>(), 0) << key;
  for (const auto& [kind, count] : b["constraint_violations"].items())
    EXPECT_EQ(count.get<int>(), 0) << kind;
  EXPECT_EQ(a["sim_time_s"], b["sim_time_s"]);
  EXPECT_NEAR(b["sim_time_s"].get<double>(), 60.0, 0.02);
  EXPECT_EQ(a["threat_encounters"], b["threat_encounters"]);
  EXPECT_GT(b["threat_encounters"].get<int>(), 0);  // sensed threats by 60 s

  // The issue asks for 5 %; the flights agree far closer. Float32 on the wire and the UAV's
  // position sampled at 50 Hz instead of 100 Hz cost ~1e-6 relative on path length and
  // separation (the measured default mission: < 4e-7) and up to ~1e-3 on the closest threat
  // approach (a minimum over a faster relative motion; measured 8e-4); tracking MSE sums
  // squares of sub-metre errors, measured 6e-6.
  EXPECT_LT(relative(a["min_separation_m"], b["min_separation_m"]), 1e-4);
  EXPECT_LT(relative(a["min_threat_distance_m"], b["min_threat_distance_m"]), 5e-3);
  ASSERT_EQ(a["uavs"].size(), 3u);
  ASSERT_EQ(b["uavs"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const json& ua = a["uavs"][i];
    const json& ub = b["uavs"][i];
    EXPECT_LT(relative(ua["path_length_m"], ub["path_length_m"]), 1e-4) << i;
    EXPECT_LT(relative(ua["tracking_mse_m2"], ub["tracking_mse_m2"]), 1e-2) << i;
    EXPECT_LT(relative(ua["min_terrain_clearance_m"], ub["min_terrain_clearance_m"]), 1e-4) << i;
    EXPECT_EQ(ua["replans"], ub["replans"]) << i;
    EXPECT_EQ(ua["tracking_samples"], ub["tracking_samples"]) << i;
  }

  // The MAVLink block: every vehicle stepped once per control period of the 60 s, answered
  // every frame cleanly and exited when told to.
  const json& m = b["mavlink"];
  EXPECT_EQ(m["mode"], "lock-step");
  EXPECT_EQ(m["frames_rejected"].get<int>(), 0);
  EXPECT_EQ(m["checksum_errors"].get<int>(), 0);
  EXPECT_EQ(m["home_altitude_m"].get<double>(), 0.0);
  ASSERT_EQ(m["vehicles"].size(), 3u);
  for (const json& v : m["vehicles"]) {
    EXPECT_EQ(v["steps"].get<int>(), 60 * 50 + 1) << v;  // control steps at t = 0 .. 60 s
    EXPECT_EQ(v["process"], "exit 0") << v;
    // Each answer is HEARTBEAT + LOCAL_POSITION_NED + ATTITUDE.
    EXPECT_GE(v["frames_received"].get<int>(), 3 * v["steps"].get<int>()) << v;
    EXPECT_GT(v["round_trip_us"]["median"].get<double>(), 0.0);
  }
  EXPECT_TRUE(fs::exists(dir / "mav" / "logs" / "vehicle-sim-uav1.log"));
  EXPECT_NE(slurp(dir / "mav" / "logs" / "vehicle-sim-uav1.log").find("in lock step"),
            std::string::npos);
}

// With a geodetic origin our z is above mean sea level (the UAVs fly at 900-1000 m) while the
// vehicles' local NED is about home at 800 m: both sides take the offset from the scenario, so
// the vehicles start where the UAVs do (checked before the flight, to 1 m) and the flight is
// the in-process one.
TEST(RunMavlink, AScenarioWithAGeodeticOriginFliesWithPx4LocalZAboutHome) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const fs::path scenario = short_geo_scenario(dir);
  ASSERT_NO_FATAL_FAILURE(fly_both_ways(dir, scenario));
  const json a = read_json(dir / "run" / "metrics.json");
  const json b = read_json(dir / "mav" / "metrics.json");
  EXPECT_EQ(b["mavlink"]["home_altitude_m"].get<double>(), 800.0);
  EXPECT_EQ(b["terrain_collisions"].get<int>(), 0);
  EXPECT_LT(relative(a["min_separation_m"], b["min_separation_m"]), 1e-4);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_LT(relative(a["uavs"][i]["path_length_m"], b["uavs"][i]["path_length_m"]), 1e-4);
    EXPECT_LT(
        relative(a["uavs"][i]["min_terrain_clearance_m"], b["uavs"][i]["min_terrain_clearance_m"]),
        1e-4);
  }
  EXPECT_TRUE(fs::exists(dir / "mav" / "flight.geojson"));
}

// Vehicles the user started (--mavlink-vehicles) for another scenario (the default one: UAV 0
// at (100, 130), 60 m above its home) are refused before the flight: read about this scenario's
// home at 800 m AMSL, UAV 0's vehicle is at 860 m, 1.8 km from uav1's start.
TEST(RunMavlink, VehiclesOfAnotherScenarioAreRefusedBeforeTheFlight) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const fs::path scenario = short_geo_scenario(dir);
  std::vector<pid_t> vehicles;
  std::string addresses;
  for (int i = 0; i < 3; ++i) {
    const fs::path log = dir / ("vehicle" + std::to_string(i) + ".log");
    // At most 60 s whatever happens, so a failed test leaves no process behind.
    vehicles.push_back(spawn_cli(
        {"vehicle-sim", "--udp", "0", "--uav", std::to_string(i), "--lockstep", "--duration", "60"},
        log));
    const int port = announced_port(log);
    ASSERT_GT(port, 0) << slurp(log);
    if (i > 0) addresses += ',';
    addresses += "127.0.0.1:" + std::to_string(port);
  }
  const int rc = run_cli("run --quiet --mavlink --mavlink-vehicles " + addresses + " --scenario " +
                             scenario.string() + " --out " + (dir / "out").string(),
                         dir / "run.log");
  for (const pid_t pid : vehicles) {
    ::kill(pid, SIGTERM);
    ::waitpid(pid, nullptr, 0);
  }
  EXPECT_EQ(rc, 1);
  const std::string log = slurp(dir / "run.log");
  EXPECT_NE(log.find("error: uav1: its vehicle starts at (100.0, 130.0, 860.0) m, not at the "
                     "scenario's start"),
            std::string::npos)
      << log;
  EXPECT_FALSE(fs::exists(dir / "out" / "metrics.json"));
}

TEST(RunMavlink, AVehicleThatNeverAnswersIsATimeoutNamingTheUavWithNothingWritten) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  // Bound sockets that never read: nobody answers there and no other process can take them.
  std::vector<ridgeline::mavlink::UdpLink> silent;
  std::string addresses;
  for (int i = 0; i < 3; ++i) {
    silent.push_back(ridgeline::mavlink::UdpLink::listen("127.0.0.1", 0));
    if (i > 0) addresses += ',';
    addresses += "127.0.0.1:";
    addresses += std::to_string(silent.back().local_port());
  }
  const fs::path out = dir / "out";
  EXPECT_EQ(run_cli("run --quiet --mavlink --mavlink-timeout 0.5 --mavlink-vehicles " + addresses +
                        " --out " + out.string(),
                    dir / "a.log"),
            1);
  const std::string log = slurp(dir / "a.log");
  EXPECT_NE(log.find("error: uav1 (UAV 0): the MAVLink vehicle at 127.0.0.1:" +
                     std::to_string(silent[0].local_port()) +
                     " did not start a lock-step offboard flight within 1.5 s"),
            std::string::npos)
      << log;
  for (const char* f : {"metrics.json", "trajectories.csv", "plan.json", "summary.json"})
    EXPECT_FALSE(fs::exists(out / f)) << f;
}

TEST(RunMavlink, BadOptionsGetOneErrorNamingTheOption) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  struct Case {
    std::string args, message;
  };
  const Case cases[] = {
      {"run --mavlink-vehicles 127.0.0.1:9", "--mavlink-vehicles: needs --mavlink"},
      {"run --mavlink --mavlink-timeout -1", "--mavlink-timeout: -1 s is not a positive number"},
      {"run --mavlink --variation 4200001", "--variation: cannot be combined with --mavlink"},
      {"run --mavlink --mavlink-vehicles 127.0.0.1:9,127.0.0.1:10",
       "--mavlink-vehicles: 2 addresses for the scenario's 3 UAVs"},
      {"run --mavlink --mavlink-vehicles 127.0.0.1:9,localhost,127.0.0.1:11",
       "--mavlink-vehicles: 'localhost' is not HOST:PORT (e.g. 127.0.0.1:14540) (entry 1)"},
      {"vehicle-sim --udp 0 --peer nowhere", "--peer: 'nowhere' is not HOST:PORT"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const fs::path log = dir / ("case" + std::to_string(k++) + ".log");
    const bool run = c.args.rfind("run ", 0) == 0;
    EXPECT_EQ(run_cli(c.args + (run ? " --out " + (dir / "out").string() : ""), log), 2) << c.args;
    EXPECT_NE(slurp(log).find("error: " + c.message), std::string::npos) << slurp(log);
  }
  EXPECT_FALSE(fs::exists(dir / "out" / "metrics.json"));
}

}  // namespace
