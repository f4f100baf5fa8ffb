// `ridgeline run --px4-dds`: the whole team flown through PX4's own DDS topics (px4_msgs over
// uXRCE-DDS, rt/uav_N/fmu/...), one `ridgeline vehicle-sim --px4-dds --lockstep` process per
// UAV. As for `run --mavlink` (run_mavlink_test.cpp), a shortened default mission flown both
// ways must give the in-process run's metrics: the vehicles integrate the same RK4 in the same
// wind, so only float32 on the wire (and the attitude as a quaternion) and the metrics'
// sampling at the control rate differ. Bad options, an unknown namespace and vehicles that
// never report are one error each naming the option, or the UAV, the topic and what was waited
// for; exit 2, nothing written. Every run uses a DDS partition of its own (the default:
// ridgeline-px4-<pid>), so parallel runs never mix.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

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

TEST(RunPx4Dds, AShortenedMissionThroughPx4TopicsMatchesTheInProcessRun) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const fs::path scenario = short_default_scenario(dir, 60);
  ASSERT_EQ(
      run_cli("run --quiet --scenario " + scenario.string() + " --out " + (dir / "run").string(),
              dir / "run.log"),
      0)
      << slurp(dir / "run.log");
  ASSERT_EQ(run_cli("run --quiet --px4-dds --scenario " + scenario.string() + " --out " +
                        (dir / "px4").string(),
                    dir / "px4.log"),
            0)
      << slurp(dir / "px4.log");
  const json a = read_json(dir / "run" / "metrics.json");
  const json b = read_json(dir / "px4" / "metrics.json");

  EXPECT_TRUE(b["safe"].get<bool>());
  for (const char* key : {"terrain_collisions", "separation_violations", "threat_intrusions"})
    EXPECT_EQ(b[key].get<int>(), 0) << key;
  for (const auto& [kind, count] : b["constraint_violations"].items())
    EXPECT_EQ(count.get<int>(), 0) << kind;
  EXPECT_EQ(a["sim_time_s"], b["sim_time_s"]);
  EXPECT_EQ(a["threat_encounters"], b["threat_encounters"]);
  EXPECT_GT(b["threat_encounters"].get<int>(), 0);

  // The tolerances of run --mavlink (README: the default mission within 8e-4): float32 on the
  // wire, positions sampled at the control rate.
  EXPECT_LT(relative(a["min_separation_m"], b["min_separation_m"]), 1e-4);
  EXPECT_LT(relative(a["min_threat_distance_m"], b["min_threat_distance_m"]), 5e-3);
  ASSERT_EQ(b["uavs"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const json& ua = a["uavs"][i];
    const json& ub = b["uavs"][i];
    EXPECT_LT(relative(ua["path_length_m"], ub["path_length_m"]), 1e-4) << i;
    EXPECT_LT(relative(ua["tracking_mse_m2"], ub["tracking_mse_m2"]), 1e-2) << i;
    EXPECT_LT(relative(ua["min_terrain_clearance_m"], ub["min_terrain_clearance_m"]), 1e-4) << i;
    EXPECT_EQ(ua["replans"], ub["replans"]) << i;
  }

  // Every vehicle stepped once per control period, on its own namespace, nothing rejected.
  const json& p = b["px4_dds"];
  EXPECT_EQ(p["mode"], "lock-step");
  EXPECT_EQ(p["px4_release"], "v1.14");
  EXPECT_EQ(p["odometry_rejected"].get<int>(), 0);
  ASSERT_EQ(p["vehicles"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const json& v = p["vehicles"][i];
    EXPECT_EQ(v["namespace"], "uav_" + std::to_string(i + 1)) << v;
    EXPECT_EQ(v["steps"].get<int>(), 60 * 50 + 1) << v;
    EXPECT_EQ(v["process"], "exit 0") << v;
    EXPECT_GE(v["odometry_received"].get<int>(), v["steps"].get<int>()) << v;
  }
  const std::string vehicle_log = slurp(dir / "px4" / "logs" / "vehicle-sim-uav1.log");
  EXPECT_NE(vehicle_log.find("on PX4's DDS topics rt/uav_1/fmu/"), std::string::npos)
      << vehicle_log;
  EXPECT_NE(vehicle_log.find("(0 rejected)"), std::string::npos) << vehicle_log;
}

TEST(RunPx4Dds, VehiclesThatNeverReportAreOneErrorNamingTheUavTheTopicAndWhatWasAwaited) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  // --px4-external: nobody runs uav_1..uav_3 in this run's partition.
  const fs::path out = dir / "out";
  EXPECT_EQ(run_cli("run --quiet --px4-dds --px4-external --px4-timeout 0.5 --out " + out.string(),
                    dir / "a.log"),
            2);
  const std::string log = slurp(dir / "a.log");
  EXPECT_NE(log.find("error: uav1 (UAV 0): the PX4 vehicle did not start a lock-step offboard "
                     "flight within 1.5 s; waited for rt/uav_1/fmu/out/vehicle_odometry: no "
                     "usable odometry (0 received, 0 rejected)"),
            std::string::npos)
      << log;
  for (const char* f : {"metrics.json", "trajectories.csv", "plan.json", "summary.json"})
    EXPECT_FALSE(fs::exists(out / f)) << f;
}

TEST(RunPx4Dds, BadOptionsAndUnknownNamespacesGetOneErrorNamingTheOption) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  struct Case {
    std::string args, message;
  };
  const Case cases[] = {
      {"run --px4-namespaces uav_1,uav_2,uav_3", "--px4-namespaces: needs --px4-dds"},
      {"run --domain-id 7", "--domain-id: needs --px4-dds"},
      {"run --px4-dds --mavlink", "--px4-dds: cannot be combined with --mavlink"},
      {"run --px4-dds --px4-timeout 0", "--px4-timeout: 0 s is not a positive number"},
      {"run --px4-dds --px4-namespaces uav_1,uav_2",
       "--px4-namespaces: 2 namespaces for the scenario's 3 UAVs"},
      {"run --px4-dds --px4-namespaces uav_1,fmu,uav_3",
       "--px4-namespaces: 'fmu' is not a PX4 vehicle namespace (uav_N, e.g. uav_1, or empty)"},
      {"run --px4-dds --px4-namespaces uav_1,uav_01,uav_3",
       "--px4-namespaces: 'uav_01' is not a PX4 vehicle namespace"},
      {"run --px4-dds --px4-namespaces uav_1,uav_2,uav_1",
       "--px4-namespaces: 'uav_1' is given twice"},
      {"vehicle-sim --lockstep", "--udp: is required (or --px4-dds)"},
      {"vehicle-sim --px4-dds --lockstep --peer 127.0.0.1:9",
       "--peer: is for MAVLink over UDP, not --px4-dds"},
      {"vehicle-sim --px4-dds --lockstep --px4-namespace uav_x",
       "--px4-namespace: 'uav_x' is not a PX4 vehicle namespace"},
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
