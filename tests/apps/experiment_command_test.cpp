// `ridgeline experiment` end to end on the default scenario with one short run of one task:
// experiment.json has the issue's shape ({"tasks": [{"task", "methods": {"proposed",
// "astar_dwa", "wind_aware"}}]}) with the same seeds for every method, and an unknown method or
// task is one clear error with a non-zero exit and nothing written; so is a missing DDPG model
// or torch module.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

/// `environment`: assignments put before the command (NAME=VALUE ...).
int run_cli(const std::string& args, const fs::path& log, const std::string& environment = "") {
  const std::string cmd = environment + " " + std::string(RIDGELINE_CLI_PATH) + " " + args + " > " +
                          log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(ExperimentCommand, WritesTheIssuesShapeWithIdenticalSeeds) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const int rc =
      run_cli("experiment --quiet --runs 1 --threads 2 --tasks northeast --duration 12 --out " +
                  (dir / "ex").string(),
              dir / "log");
  ASSERT_EQ(rc, 0) << slurp(dir / "log");
  const nlohmann::json e = nlohmann::json::parse(slurp(dir / "ex" / "experiment.json"));
  ASSERT_EQ(e.at("tasks").size(), 1u);
  const nlohmann::json& task = e["tasks"][0];
  EXPECT_EQ(task.at("task"), "northeast");
  ASSERT_EQ(task.at("methods").size(), 4u);
  const auto seed = task["methods"]["proposed"]["runs"][0]["seed"];
  for (const char* name : {"proposed", "astar_dwa", "wind_aware", "ddpg"}) {
    const nlohmann::json& M = task["methods"].at(name);
    EXPECT_TRUE(M.at("path_length_m").contains("mean"));
    EXPECT_TRUE(M.at("path_length_m").contains("std"));
    EXPECT_TRUE(M.contains("avoidance_success_rate"));
    EXPECT_TRUE(M.contains("tracking_mse_m2"));
    EXPECT_TRUE(M.contains("tracking_mse_by_distance"));
    EXPECT_TRUE(M.contains("collisions"));
    EXPECT_EQ(M["runs"][0]["seed"], seed) << name;
  }
  EXPECT_NE(slurp(dir / "log").find("task northeast:"), std::string::npos) << slurp(dir / "log");
  fs::remove_all(dir);
}

TEST(ExperimentCommand, UnknownMethodOrTaskIsOneErrorAndWritesNothing) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  EXPECT_EQ(
      run_cli("experiment --methods proposed,sac --out " + (dir / "a").string(), dir / "a.log"), 2);
  EXPECT_NE(slurp(dir / "a.log").find("error: --methods: unknown method 'sac'"), std::string::npos)
      << slurp(dir / "a.log");
  EXPECT_EQ(run_cli("experiment --tasks moon --out " + (dir / "b").string(), dir / "b.log"), 2);
  EXPECT_NE(slurp(dir / "b.log").find("error: --tasks: unknown task 'moon'"), std::string::npos)
      << slurp(dir / "b.log");
  EXPECT_EQ(run_cli("run --method dqn --out " + (dir / "c").string(), dir / "c.log"), 2);
  EXPECT_NE(slurp(dir / "c.log").find("error: --method: unknown method 'dqn'"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "a" / "experiment.json"));
  EXPECT_FALSE(fs::exists(dir / "b" / "experiment.json"));
  EXPECT_FALSE(fs::exists(dir / "c"));
  fs::remove_all(dir);
}

// A count below its minimum, or not an integer, is one error naming the option and the reason
// (CLI11's own check said "Value 0 not in range 0 to 1.8e308"), and nothing is written.
TEST(CountOptions, BelowTheMinimumNameTheOptionAndTheBound) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const fs::path out = dir / "out";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"montecarlo --quiet --runs 0", "--runs: must be at least 1, got 0"},
      {"montecarlo --quiet --runs -2", "--runs: must be at least 1, got -2"},
      {"montecarlo --quiet --runs two", "--runs: must be an integer, got two"},
      {"experiment --quiet --runs 0", "--runs: must be at least 1, got 0"},
      {"train ddpg --quiet --episodes 0", "--episodes: must be at least 1, got 0"}};
  for (const auto& [command, expected] : cases) {
    EXPECT_NE(run_cli(command + " --out " + out.string(), dir / "log"), 0) << command;
    const std::string log = slurp(dir / "log");
    EXPECT_NE(log.find(expected), std::string::npos) << command << "\n" << log;
    EXPECT_FALSE(fs::exists(out)) << command;
  }
  fs::remove_all(dir);
}

TEST(DdpgMethod, MissingModelFileIsOneErrorNamingItAndWritesNothing) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const std::string missing = (dir / "no_such_model.pt").string();
  const std::string expected = "error: " + missing + ": DDPG model file not found";
  for (const std::string command :
       {"run --method ddpg --quiet", "montecarlo --method ddpg --runs 1 --quiet",
        "experiment --methods proposed,ddpg --runs 1 --quiet"}) {
    const fs::path out = dir / "out";
    EXPECT_EQ(run_cli(command + " --ddpg-model " + missing + " --out " + out.string(), dir / "log"),
              2)
        << command;
    const std::string log = slurp(dir / "log");
    EXPECT_NE(log.find(expected), std::string::npos) << command << "\n" << log;
    EXPECT_EQ(log.find("error", log.find("error") + 1), std::string::npos) << log;  // once
    EXPECT_FALSE(fs::exists(out)) << command;
  }
  // A file that is not a model names the file too.
  std::ofstream(dir / "bad.pt") << "not a model";
  EXPECT_EQ(run_cli("run --method ddpg --quiet --ddpg-model " + (dir / "bad.pt").string() +
                        " --out " + (dir / "out").string(),
                    dir / "log"),
            2);
  EXPECT_NE(slurp(dir / "log").find("error: " + (dir / "bad.pt").string() + ": not a readable"),
            std::string::npos)
      << slurp(dir / "log");
  fs::remove_all(dir);
}

TEST(DdpgMethod, MissingOrUnloadableTorchModuleIsOneErrorNamingItAndWritesNothing) {
  const fs::path dir = ridgeline::testing_support::fresh_test_dir();
  const std::string missing = (dir / "no_such_dir" / "libridgeline_ddpg.so").string();
  std::ofstream(dir / "not_a_module.so") << "not a shared library";
  const std::string unloadable = (dir / "not_a_module.so").string();
  for (const std::string& module : {missing, unloadable}) {
    for (const std::string command :
         {"run --method ddpg --quiet", "montecarlo --method ddpg --runs 1 --quiet",
          "experiment --methods proposed,ddpg --runs 1 --quiet",
          "train ddpg --episodes 1 --quiet"}) {
      const fs::path out = dir / "out";
      const std::string target = command.starts_with("train") ? " --out " + (out / "m.pt").string()
                                                              : " --out " + out.string();
      EXPECT_EQ(run_cli(command + target, dir / "log", "RIDGELINE_DDPG_MODULE=" + module), 2)
          << command;
      const std::string log = slurp(dir / "log");
      EXPECT_NE(log.find("error: DDPG torch module libridgeline_ddpg.so: not loaded"),
                std::string::npos)
          << command << "\n"
          << log;
      EXPECT_NE(log.find("tried " + module + " (from $RIDGELINE_DDPG_MODULE): "), std::string::npos)
          << log;
      EXPECT_EQ(log.find("error", log.find("error") + 1), std::string::npos) << log;  // once
      EXPECT_FALSE(fs::exists(out)) << command;
    }
  }
  // The model file is checked first: a missing model is still reported as such.
  EXPECT_EQ(run_cli("run --method ddpg --quiet --ddpg-model " + (dir / "none.pt").string() +
                        " --out " + (dir / "out").string(),
                    dir / "log", "RIDGELINE_DDPG_MODULE=" + missing),
            2);
  EXPECT_NE(slurp(dir / "log").find("none.pt: DDPG model file not found"), std::string::npos)
      << slurp(dir / "log");
  fs::remove_all(dir);
}

}  // namespace
