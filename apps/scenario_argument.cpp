#include "apps/scenario_argument.hpp"

namespace ridgeline::apps {

io::LoadedScenario load_scenario_argument(const std::string& path) {
  return path.empty() ? io::load_default_scenario() : io::load_scenario_file(path);
}

}  // namespace ridgeline::apps
