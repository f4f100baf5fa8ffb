// `ridgeline launch`: the swarm as separate processes over Cyclone DDS on loopback (issue 7).
// The default mission in lock-step with three agent processes must complete with zero
// collisions, give the same safety results as the in-process `ridgeline run` (same truth, same
// noise streams, same agents: only the transport differs), and the faults of the issue must
// leave the team safe: an agent killed mid-mission (its targets re-allocated), 20 % loss with
// 50 ms latency, an agent that starts late, malformed messages (rejected and counted).
// Every launch runs in a DDS partition of its own (launch derives it from its pid), so
// parallel ctest runs do not see each other.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Every launch has a wall-time limit far below ctest's: a stuck swarm fails the test with its
// logs instead of hanging the suite.
int run_cli(const std::string& args, const fs::path& log) {
  const std::string limit = args.rfind("launch", 0) == 0 ? " --timeout-s 300" : "";
  const std::string cmd = std::string(RIDGELINE_CLI_PATH) + " " + args + limit + " >" +
                          log.string() + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

json read_json(const fs::path& p) { return json::parse(slurp(p)); }

/// The safety results every flight must have.
void expect_safe(const json& m) {
  EXPECT_TRUE(m["safe"].get<bool>());
  EXPECT_EQ(m["terrain_collisions"].get<int>(), 0);
  EXPECT_EQ(m["separation_violations"].get<int>(), 0);
  EXPECT_EQ(m["threat_intrusions"].get<int>(), 0);
  for (const auto& [kind, count] : m["constraint_violations"].items())
    EXPECT_EQ(count.get<int>(), 0) << kind;
  // d_safe of the default scenario is 10 m.
  EXPECT_GE(m["min_separation_m"].get<double>(), 10.0);
}

/// Safety results of two flights of the same mission: equal up to the floating-point
/// summation order (1e-6 relative).
void expect_same_flight(const json& a, const json& b) {
  for (const char* key : {"min_separation_m", "min_threat_distance_m", "sim_time_s"})
    EXPECT_NEAR(a[key].get<double>(), b[key].get<double>(), 1e-6 * std::abs(a[key].get<double>()))
        << key;
  for (const char* key :
       {"threat_encounters", "threat_intrusions", "terrain_collisions", "separation_violations"})
    EXPECT_EQ(a[key].get<int>(), b[key].get<int>()) << key;
  ASSERT_EQ(a["uavs"].size(), b["uavs"].size());
  for (std::size_t i = 0; i < a["uavs"].size(); ++i) {
    const double la = a["uavs"][i]["path_length_m"].get<double>();
    EXPECT_NEAR(la, b["uavs"][i]["path_length_m"].get<double>(), 1e-6 * la) << i;
    EXPECT_EQ(a["uavs"][i]["targets_inspected"], b["uavs"][i]["targets_inspected"]) << i;
  }
}

/// Every key path of a metrics document ("uavs[].path_length_m"), the elements of an array
/// merged; the DDS-only section "distributed" is left out.
void collect_keys(const json& j, const std::string& prefix, std::set<std::string>& keys) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (prefix.empty() && key == "distributed") continue;
      const std::string path = prefix.empty() ? key : prefix + "." + key;
      keys.insert(path);
      collect_keys(value, path, keys);
    }
  } else if (j.is_array()) {
    for (const json& element : j) collect_keys(element, prefix + "[]", keys);
  }
}

std::set<std::string> metric_keys(const json& m) {
  std::set<std::string> keys;
  collect_keys(m, "", keys);
  return keys;
}

TEST(LaunchCommand, ThreeAgentProcessesFlyTheDefaultMissionInLockStepLikeTheInProcessRun) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  ASSERT_EQ(
      run_cli("launch --agents-as-processes --out " + (dir / "dds").string(), dir / "launch.log"),
      0)
      << slurp(dir / "launch.log");
  for (const char* f : {"metrics.json", "trajectories.csv", "plan.json", "summary.json"})
    EXPECT_TRUE(fs::exists(dir / "dds" / f)) << f;
  const json m = read_json(dir / "dds" / "metrics.json");
  expect_safe(m);
  EXPECT_TRUE(m["mission_complete"].get<bool>());
  const json& d = m["distributed"];
  EXPECT_EQ(d["mode"], "lock-step");
  EXPECT_TRUE(d["agents_as_processes"].get<bool>());
  ASSERT_EQ(d["agents"].size(), 3u);
  for (const json& a : d["agents"]) {
    // One answer per control tick of the mission (50 Hz).
    EXPECT_NEAR(a["answers"].get<double>(), m["sim_time_s"].get<double>() * 50.0, 2.0);
    EXPECT_GT(a["loop_period_mean_s"].get<double>(), 0.0);
    EXPECT_EQ(a["lost_s"].get<double>(), -1.0);
  }
  for (const auto& [name, status] : d["processes"].items()) EXPECT_EQ(status, "exit 0") << name;
  for (const json& u : m["uavs"]) EXPECT_EQ(u["messages_rejected"].get<int>(), 0);

  // The same mission in one process (`run`): the transport is the only difference.
  ASSERT_EQ(run_cli("run --quiet --out " + (dir / "run").string(), dir / "run.log"), 0)
      << slurp(dir / "run.log");
  const json r = read_json(dir / "run" / "metrics.json");
  expect_same_flight(r, m);
  // One recorder writes both (mission/flight_recorder.hpp): the same metrics, key for key, the
  // controller's CPU time and the optimizer's re-plans included.
  const std::set<std::string> run_keys = metric_keys(r);
  EXPECT_EQ(run_keys, metric_keys(m));
  EXPECT_TRUE(run_keys.contains("uavs[].optimizer_replans"));
  EXPECT_TRUE(run_keys.contains("mpc_solve_cpu_us.median"));
  EXPECT_GT(m["mpc_solve_cpu_us"]["median"].get<double>(), 0.0);
  for (const char* key : {"optimizer_replans", "replans", "fallback_steps"})
    for (std::size_t i = 0; i < r["uavs"].size(); ++i)
      EXPECT_EQ(r["uavs"][i][key], m["uavs"][i][key]) << key << " " << i;
}

TEST(LaunchCommand, AKilledAgentsTargetsAreReallocatedAndTheOthersStaySafe) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  // uav3 (index 2) flies the longest route; at 60 s it is far from its target.
  const int rc = run_cli(
      "launch --agents-as-processes --kill-agent 2@60 --answer-timeout-s 1 "
      "--out " +
          dir.string(),
      dir / "launch.log");
  const std::string log = slurp(dir / "launch.log");
  ASSERT_TRUE(rc == 0) << log;
  const json m = read_json(dir / "metrics.json");
  expect_safe(m);
  const json& d = m["distributed"];
  ASSERT_EQ(d["lost_uavs"], json::array({"uav3"}));
  EXPECT_GE(d["agents"][2]["lost_s"].get<double>(), 60.0);
  EXPECT_LT(d["agents"][2]["lost_s"].get<double>(), 62.0);
  EXPECT_NE(d["processes"]["agent 2"].get<std::string>().find("fault injection"),
            std::string::npos);
  const json& realloc = d["ground"]["reallocations"];
  ASSERT_EQ(realloc.size(), 1u) << d["ground"].dump();
  EXPECT_EQ(realloc[0]["lost_uav"], "uav3");
  EXPECT_EQ(realloc[0]["status"], "planned") << realloc[0].dump();
  // Every target of the team is inspected in the end: the lost UAV's by a survivor.
  EXPECT_EQ(d["targets_inspected_by_team"].get<int>(), 3) << m["uavs"].dump();
  EXPECT_FALSE(m["uavs"][2]["finished"].get<bool>());
  EXPECT_TRUE(m["uavs"][0]["finished"].get<bool>());
  EXPECT_TRUE(m["uavs"][1]["finished"].get<bool>());
}

TEST(LaunchCommand, TwentyPercentLossWithFiftyMillisecondsLatencyStaysSafe) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  ASSERT_EQ(run_cli("launch --agents-as-processes --link-loss 0.2 --link-latency-s 0.05 --out " +
                        dir.string(),
                    dir / "launch.log"),
            0)
      << slurp(dir / "launch.log");
  const json m = read_json(dir / "metrics.json");
  expect_safe(m);
  EXPECT_TRUE(m["mission_complete"].get<bool>());
  EXPECT_DOUBLE_EQ(m["distributed"]["faults"]["link_loss"].get<double>(), 0.2);
}

TEST(LaunchCommand, AnAgentThatStartsLateCatchesUpSafely) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  // Late by 20 s of mission time, when its neighbours may already have reported threats that
  // it can never receive (it must not wait for them at every tick).
  ASSERT_EQ(run_cli("launch --agents-as-processes --late-agent 1@20 --out " + dir.string(),
                    dir / "launch.log"),
            0)
      << slurp(dir / "launch.log");
  const json m = read_json(dir / "metrics.json");
  expect_safe(m);
  EXPECT_TRUE(m["mission_complete"].get<bool>());
  const json& a = m["distributed"]["agents"];
  EXPECT_EQ(a[0]["started_s"].get<double>(), 0.0);
  EXPECT_GE(a[1]["started_s"].get<double>(), 20.0);  // the world was already ticking
  EXPECT_EQ(a[2]["started_s"].get<double>(), 0.0);
}

// In real time a setpoint lands after the state it was computed from; the flight controller
// holds its turn rate to the limit at the speed it lands at, so late setpoints never exceed
// eq. 3 (they did by up to 0.2 % before), and the limiting is counted per agent.
TEST(LaunchCommand, RealTimeFlightKeepsTheTurnLimitWhenSetpointsLandLate) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  ASSERT_EQ(run_cli("launch --agents-as-processes --real-time --duration-s 8 --out " + dir.string(),
                    dir / "launch.log"),
            0)
      << slurp(dir / "launch.log");
  const json m = read_json(dir / "metrics.json");
  expect_safe(m);
  EXPECT_LE(m["max_turn_command_ratio"].get<double>(), 1.0 + 1e-6);
  EXPECT_EQ(m["distributed"]["mode"], "real-time");
  for (const json& a : m["distributed"]["agents"]) {
    EXPECT_GE(a["turn_setpoints_limited"].get<long long>(), 0);
    EXPECT_GT(a["answers"].get<long long>(), 0);
  }
}

TEST(LaunchCommand, MalformedMessagesAreRejectedCountedAndChangeNothing) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  ASSERT_EQ(run_cli("launch --inject-malformed --out " + dir.string(), dir / "launch.log"), 0)
      << slurp(dir / "launch.log");
  const json m = read_json(dir / "metrics.json");
  expect_safe(m);
  EXPECT_TRUE(m["mission_complete"].get<bool>());
  const json& d = m["distributed"];
  EXPECT_GT(d["faults"]["malformed_injections"].get<int>(), 0);
  EXPECT_GT(d["world_messages_rejected"].get<int>(), 0) << d.dump();
  for (const json& u : m["uavs"]) EXPECT_GT(u["messages_rejected"].get<int>(), 0) << u.dump();
}

TEST(LaunchCommand, BadArgumentsGetOneErrorNamingTheOption) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  EXPECT_EQ(run_cli("launch --kill-agent 7@10 --agents-as-processes --out " + dir.string(),
                    dir / "a.log"),
            2);
  EXPECT_NE(slurp(dir / "a.log").find("--kill-agent"), std::string::npos) << slurp(dir / "a.log");
  EXPECT_EQ(run_cli("launch --kill-agent 1@10 --out " + dir.string(), dir / "b.log"), 2);
  EXPECT_NE(slurp(dir / "b.log").find("--agents-as-processes"), std::string::npos);
  EXPECT_EQ(run_cli("launch --link-loss 1.5 --out " + dir.string(), dir / "c.log"), 2);
  EXPECT_NE(slurp(dir / "c.log").find("--link-loss"), std::string::npos);
  EXPECT_EQ(run_cli("launch --domain-id 400 --out " + dir.string(), dir / "d.log"), 2);
  EXPECT_NE(slurp(dir / "d.log").find("domain_id"), std::string::npos);
  EXPECT_EQ(run_cli("launch --late-agent one@2 --out " + dir.string(), dir / "e.log"), 2);
  EXPECT_NE(slurp(dir / "e.log").find("ID@SECONDS"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "metrics.json"));
}

}  // namespace
