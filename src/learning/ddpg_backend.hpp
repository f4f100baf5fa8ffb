// The seam between the DDPG facade (ddpg.hpp, linked into every program) and its libtorch
// implementation, the module libridgeline_ddpg.so (src/learning/torch/), which is loaded on
// first use. libtorch takes ~0.7 s to load, so no program links it: only `ridgeline train ddpg`
// and `--method ddpg` pay for it (issue 17).
//
// The module exports one C symbol, kBackendEntrySymbol, returning a BackendEntry: its ABI
// version, the sizes of the structs that cross the seam (a stale module from another build is
// refused instead of misreading them), and the Backend that creates the policies and trainers.
// Both sides are built by the same compiler from the same tree, so C++ types (std::string,
// std::unique_ptr, Vec3) cross the seam as they are, and InputError thrown by the module is
// caught by type in the program (its type_info is matched by name). The module is never
// unloaded: objects it created may live until exit.
//
// Where the module is looked for, first that loads wins:
//   1. $RIDGELINE_DDPG_MODULE, when set: that file only (nothing else is tried);
//   2. libridgeline_ddpg.so beside the running program (the directory of /proc/self/exe);
//   3. the module's path in the build tree the program was built in (for the test programs,
//      which live in build/tests/).
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "learning/ddpg.hpp"

namespace ridgeline::learning::ddpg_backend {

/// Raised when a virtual function of the seam changes meaning or order.
constexpr int kAbiVersion = 1;
constexpr const char* kModuleFileName = "libridgeline_ddpg.so";
constexpr const char* kModuleEnvironmentVariable = "RIDGELINE_DDPG_MODULE";
constexpr const char* kBackendEntrySymbol = "ridgeline_ddpg_backend_entry";

/// A trained actor (DdpgPolicy's implementation).
class PolicyBackend {
 public:
  virtual ~PolicyBackend() = default;
  virtual Vec3 act(const Observation& observation) const = 0;
  virtual double action_period_s() const = 0;
  virtual std::string serialize() const = 0;
};

/// DdpgTrainer's implementation: the networks, the replay buffer and the environment.
class TrainerBackend {
 public:
  virtual ~TrainerBackend() = default;
  /// Runs episode `episode` of a schedule of `schedule_episodes` (the noise decay).
  virtual TrainingEpisode run_episode(int episode, int schedule_episodes) = 0;
  virtual std::unique_ptr<PolicyBackend> snapshot() const = 0;
  virtual long long environment_steps() const = 0;
  virtual long long updates() const = 0;
};

class Backend {
 public:
  virtual ~Backend() = default;
  /// DdpgPolicy::deserialize: throws InputError naming `source`.
  virtual std::unique_ptr<PolicyBackend> deserialize(const std::string& bytes,
                                                     const std::string& source) const = 0;
  /// Throws InputError for invalid options.
  virtual std::unique_ptr<TrainerBackend> make_trainer(
      const DdpgOptions& options, const EnvironmentOptions& environment) const = 0;
};

struct BackendEntry {
  int abi_version = 0;
  std::size_t layout_size = 0;  ///< layout_size() of the module's build
  const Backend* backend = nullptr;
};

/// A check of the layouts that cross the seam: the sum of their sizes, each weighted.
constexpr std::size_t layout_size() {
  return sizeof(DdpgOptions) + 3 * sizeof(EnvironmentOptions) + 5 * sizeof(TrainingEpisode) +
         7 * sizeof(Observation) + 11 * sizeof(Vec3) + 13 * sizeof(std::string);
}

using EntryFunction = const BackendEntry* (*)();

/// The module's backend, loading the module on the first call (thread-safe). Throws one
/// InputError naming the module and every place it was looked for, with the loader's reason.
const Backend& backend();
/// The file the module was loaded from (loads it if needed; throws as backend()).
const std::string& module_path();

}  // namespace ridgeline::learning::ddpg_backend
