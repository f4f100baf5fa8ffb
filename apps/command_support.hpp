// Steps several subcommands share, so each command file stays a thin shell.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "apps/scenario_argument.hpp"
#include "io/scenario_file.hpp"
#include "learning/ddpg.hpp"
#include "planning/global_planner.hpp"
#include "sim/method.hpp"

namespace ridgeline::apps {

/// Plans the mission with `method`'s planner (sim/method.hpp); on failure prints one error
/// line, sets exit code 3 and returns nothing.
std::optional<planning::GlobalPlan> plan_or_report(const io::LoadedScenario& loaded,
                                                   sim::Method method = sim::Method::kProposed);

/// The committed DDPG model (models/ddpg_mountain.pt in the source tree this was built from).
std::string default_ddpg_model_path();
/// Adds `--ddpg-model FILE` (default: default_ddpg_model_path()) to a subcommand.
void add_ddpg_model_option(CLI::App* command, std::string& path);

/// The whole of `text` as a decimal integer, or nothing ("nan", "1.5", "3x", out of range).
std::optional<long long> whole_integer(std::string_view text);
// An integer option's check: "must be at least N, got V" (CLI11's PositiveNumber would say
// "Value 0 not in range 0 to 1.8e308").
CLI::Validator at_least(int minimum);
/// The DDPG policy at `path` when `needed`, else null; InputError naming the file when it is
/// missing or not a model. Called before planning, so nothing is written on that error.
std::shared_ptr<const learning::DdpgPolicy> load_ddpg_policy_if(bool needed,
                                                                const std::string& path);

/// Writes DIR/report.html as `build(plotly_js)` makes it, with the plotly bundle from
/// io::plotly_js_path(). When the bundle is missing, prints one warning saying how to install
/// it and writes no report (removing one an earlier run left in DIR, which would not describe
/// the outputs beside it); the command's other outputs stand.
void write_report(const std::filesystem::path& dir,
                  const std::function<std::string(std::string_view plotly_js)>& build);

}  // namespace ridgeline::apps
