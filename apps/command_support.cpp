#include "apps/command_support.hpp"

#include <fmt/format.h>

#include <charconv>
#include <iostream>
#include <system_error>

#include "apps/commands.hpp"
#include "io/atomic_file.hpp"
#include "io/report_html.hpp"

namespace ridgeline::apps {

std::optional<planning::GlobalPlan> plan_or_report(const io::LoadedScenario& loaded,
                                                   sim::Method method) {
  planning::GlobalPlan plan = sim::plan_for_method(loaded.scenario, loaded.terrain, method);
  if (plan.status == planning::GlobalPlanStatus::kPlanned) return plan;
  std::cerr << "error: planning failed (" << planning::to_string(plan.status)
            << "): " << plan.message << '\n';
  set_exit_code(3);
  return std::nullopt;
}

std::string default_ddpg_model_path() { return RIDGELINE_DEFAULT_DDPG_MODEL; }

void add_ddpg_model_option(CLI::App* command, std::string& path) {
  path = default_ddpg_model_path();
  command
      ->add_option("--ddpg-model", path,
                   "DDPG model of method ddpg (ridgeline train ddpg; default: the committed one)")
      ->capture_default_str();
}

std::optional<long long> whole_integer(std::string_view text) {
  long long value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, value);
  if (error != std::errc() || ptr != end) return std::nullopt;
  return value;
}

CLI::Validator at_least(int minimum) {
  return CLI::Validator(
      [minimum](std::string& value) -> std::string {
        const std::optional<long long> v = whole_integer(value);
        if (!v) return "must be an integer, got " + value;
        if (*v < minimum) return fmt::format("must be at least {}, got {}", minimum, value);
        return std::string();
      },
      fmt::format("INT >= {}", minimum));
}

std::shared_ptr<const learning::DdpgPolicy> load_ddpg_policy_if(bool needed,
                                                                const std::string& path) {
  if (!needed) return nullptr;
  return std::make_shared<const learning::DdpgPolicy>(learning::DdpgPolicy::load(path));
}

void write_report(const std::filesystem::path& dir,
                  const std::function<std::string(std::string_view plotly_js)>& build) {
  std::string plotly_js;
  try {
    plotly_js = io::read_plotly_js(io::plotly_js_path());
  } catch (const InputError& e) {
    std::error_code not_removed;
    std::filesystem::remove(dir / "report.html", not_removed);
    std::cerr << "warning: no report.html: " << e.what() << '\n';
    return;
  }
  io::write_file_atomically(dir / "report.html", build(plotly_js));
  std::cout << "wrote report.html to " << dir.string() << '\n';
}

}  // namespace ridgeline::apps
