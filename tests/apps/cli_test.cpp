// End-to-end checks of the `ridgeline` program as a user runs it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct CliRun {
  int exit_code;
  std::string out;
  std::string err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ridgeline::testing_support::fresh_test_dir();
  }
  void TearDown() override { fs::remove_all(dir_); }

  CliRun run(const std::string& args) {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string cmd = std::string(RIDGELINE_CLI_PATH) + " " + args + " >" + out.string() +
                            " 2>" + err.string() + " </dev/null";
    const int status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
  }
  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
  }
  std::string default_yaml() { return run("scenario default").out; }

  fs::path dir_;
};

TEST_F(Cli, DefaultScenarioRoundTripsThroughValidate) {
  const CliRun printed = run("scenario default");
  ASSERT_EQ(printed.exit_code, 0) << printed.err;
  write("s.yaml", printed.out);
  const CliRun valid = run("validate " + (dir_ / "s.yaml").string());
  EXPECT_EQ(valid.exit_code, 0) << valid.err;
  EXPECT_THAT(valid.out, HasSubstr("3 UAVs"));
}

// CLI11's parse errors (a value that does not convert, an unknown option, a missing one) are bad
// input like any other: one line naming the option, exit 2; --help still prints and exits 0.
TEST_F(Cli, CommandLineErrorsAreOneLineNamingTheOptionAndExitTwo) {
  for (const auto& [args, message] : {std::pair{"bench mpc --nc nan", "--nc"},
                                      {"bench mpc --steps 1.5", "--steps"},
                                      {"bench mpc --no-such-option", "--no-such-option"},
                                      {"scenario team --targets 3", "--uavs"}}) {
    const CliRun r = run(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_THAT(r.err, HasSubstr(message)) << args;
    EXPECT_THAT(r.err, HasSubstr("error: ")) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
  }
  const CliRun help = run("bench mpc --help");
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_THAT(help.out, HasSubstr("--np"));
}

// `bench host` probes the thread for as long as asked and prints the probe as JSON; a duration
// or threshold that is not finite and positive is an error naming the option.
TEST_F(Cli, BenchHostReportsThePausesOfItsThreadAndRejectsBadDurations) {
  const CliRun r = run("bench host --seconds 0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* field :
       {"\"cpu\"", "\"processor\"", "\"dependent_adds_per_ns\"", "\"host_interruptions\"",
        "\"probed_ms\"", "\"per_ms\"", "\"lost_fraction\""}) {
    EXPECT_THAT(r.out, HasSubstr(field));
  }
  for (const auto& [args, option] : {std::pair{"--seconds 0", "--seconds"},
                                     {"--seconds nan", "--seconds"},
                                     {"--seconds 1e9", "--seconds"},
                                     {"--threshold-us -1", "--threshold-us"},
                                     {"--threshold-us inf", "--threshold-us"}}) {
    const CliRun bad = run(std::string("bench host ") + args);
    EXPECT_EQ(bad.exit_code, 2) << args;
    EXPECT_THAT(bad.err, HasSubstr(option)) << args;
    EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  }
}

TEST_F(Cli, ValidateListsEveryProblemByFieldAndFails) {
  std::string yaml = default_yaml();
  // Bury the first target in the tallest peak and give a threat a negative radius.
  const std::string target = "position_m: [1700, 1300, 90]";
  ASSERT_NE(yaml.find(target), std::string::npos);
  yaml.replace(yaml.find(target), target.size(), "position_m: [900, 1250, 250]");
  const std::string radius = "radius_m: 40";
  ASSERT_NE(yaml.find(radius), std::string::npos);
  yaml.replace(yaml.find(radius), radius.size(), "radius_m: -40");
  write("bad.yaml", yaml);
  const CliRun r = run("validate " + (dir_ / "bad.yaml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("targets[0].position_m: 70.0 m below the terrain clearance"));
  EXPECT_THAT(r.err, HasSubstr("threats[0].radius_m: must be > 0"));
  EXPECT_THAT(r.err, HasSubstr("2 problems"));
}

TEST_F(Cli, ReplanBenchmarkBudgetMustBePositive) {
  // Checked before the scenario is planned: one message naming the option, non-zero exit.
  for (const char* bad : {"0", "-1", "nan"}) {
    const CliRun r = run(std::string("bench replan --cases 1 --budget-s ") + bad);
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_THAT(r.err, HasSubstr("--budget-s")) << bad;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST_F(Cli, MalformedAndMissingFilesFailWithOneMessage) {
  write("broken.yaml", "area: [1, 2\n");
  CliRun r = run("validate " + (dir_ / "broken.yaml").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("malformed YAML"));
  r = run("validate " + (dir_ / "none.yaml").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("none.yaml"));
  r = run("validate");
  EXPECT_NE(r.exit_code, 0);
}

TEST_F(Cli, RunWritesTheSummaryAndNothingOnBadInput) {
  CliRun r = run("run --out " + (dir_ / "ok").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "ok" / "summary.json"));
  EXPECT_THAT(slurp(dir_ / "ok" / "summary.json"), HasSubstr("\"scenario\": \"default\""));

  std::string yaml = default_yaml();
  yaml.replace(yaml.find("tau_v_s: 0.5"), 12, "tau_v_s: .nan");
  write("nan.yaml", yaml);
  r = run("run --scenario " + (dir_ / "nan.yaml").string() + " --out " + (dir_ / "bad").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("vehicle.tau_v_s: must be a finite number"));
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

TEST_F(Cli, SynthesizedDemIsFittedAndIncludedByAScenario) {
  const std::string dem = (dir_ / "default.tif").string();
  CliRun r = run("make-dem --cell 10 --noise 1 --seed 5 --out " + dem);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run("fit-dem --dem " + dem + " --peaks 7 --out " + (dir_ / "terrain.yaml").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // 1 m noise: the fit's RMSE is the noise level when the seven peaks are recovered.
  EXPECT_THAT(r.out, ::testing::ContainsRegex("RMSE (0\\.9|1\\.0)[0-9]* m"));
  std::string yaml = default_yaml();
  const std::size_t begin = yaml.find("terrain:\n  combination");
  const std::size_t end = yaml.find("\n# Vehicle defaults");
  ASSERT_NE(begin, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  yaml.replace(begin, end - begin, "terrain: {include: terrain.yaml}\n");
  write("fitted.yaml", yaml);
  r = run("validate " + (dir_ / "fitted.yaml").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("peaks from "));

  r = run("make-dem --cell 10 --out " + (dir_ / "x.png").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--out: must end in .tif"));
}

TEST_F(Cli, TeamScenarioIsValidAndBadCountsFailWithOneMessage) {
  const fs::path file = dir_ / "team30.yaml";
  CliRun r = run("scenario team --uavs 30 --targets 40 --seed 5 --out " + file.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CliRun valid = run("validate " + file.string());
  EXPECT_EQ(valid.exit_code, 0) << valid.err;
  EXPECT_THAT(valid.out, HasSubstr("30 UAVs"));
  EXPECT_THAT(valid.out, HasSubstr("40 targets"));
  EXPECT_THAT(slurp(file), HasSubstr("--uavs 30 --targets 40 --seed 5"));
  // Printed without --out: the same text.
  EXPECT_EQ(run("scenario team --uavs 30 --targets 40 --seed 5").out, slurp(file));

  const fs::path bad = dir_ / "bad.yaml";
  for (const auto& [args, message] :
       {std::pair{"--uavs 0 --targets 3", "--uavs: must be >= 1"},
        {"--uavs nan --targets 3", "--uavs: must be an integer"},
        {"--uavs 3 --targets nan", "--targets: must be an integer"},
        {"--uavs 5000 --targets 3", "--uavs: 5000 UAVs do not fit on a take-off grid"},
        {"--uavs 3 --targets 3 --seed -2", "--seed: must be >= 0"},
        {"--uavs 3 --targets 3 --dem nowhere.tif", "--dem:"}}) {
    r = run(std::string("scenario team ") + args + " --out " + bad.string());
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_THAT(r.err, HasSubstr(message)) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(bad)) << args;
  }
}

}  // namespace
