// Running the `ridgeline` program from a test (tests/apps): its exit code and output, JSON
// results, a shortened default scenario, and relative differences of metrics.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

namespace ridgeline::testing_support {

/// `ridgeline ARGS` with stdout and stderr in `log`; its exit code (-1: it did not exit).
inline int run_cli(const std::string& args, const std::filesystem::path& log) {
  // `timeout` guards the test against a hang whatever the program does (it has its own).
  const std::string cmd = "timeout -k 5 300 " + std::string(RIDGELINE_CLI_PATH) + " " + args +
                          " >" + log.string() + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(slurp(p));
}

/// The default scenario with its mission cut to `duration_s` seconds, as DIR/short.yaml.
inline std::filesystem::path short_default_scenario(const std::filesystem::path& dir,
                                                    int duration_s) {
  EXPECT_EQ(run_cli("scenario default", dir / "default.yaml"), 0);
  const std::string text =
      std::regex_replace(slurp(dir / "default.yaml"), std::regex("duration_s: 600"),
                         "duration_s: " + std::to_string(duration_s));
  EXPECT_NE(text.find("duration_s: " + std::to_string(duration_s)), std::string::npos);
  const std::filesystem::path p = dir / "short.yaml";
  std::ofstream(p) << text;
  return p;
}

/// |a − b| / |a|.
inline double relative(double a, double b) {
  return std::abs(a - b) / std::max(std::abs(a), 1e-12);
}

}  // namespace ridgeline::testing_support
