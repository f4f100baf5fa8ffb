// Loading the DDPG torch module (ddpg_backend.hpp): dlopen, one exported entry, checks.
#include "learning/ddpg_backend.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.hpp"

#ifndef RIDGELINE_DDPG_MODULE_BUILD_PATH
#define RIDGELINE_DDPG_MODULE_BUILD_PATH ""
#endif

namespace ridgeline::learning::ddpg_backend {
namespace {

namespace fs = std::filesystem;

struct LoadedModule {
  std::string path;
  const Backend* backend = nullptr;
};

/// $RIDGELINE_DDPG_MODULE when it is set and not empty, else null.
const char* environment_override() {
  const char* env = std::getenv(kModuleEnvironmentVariable);
  return env != nullptr && *env != '\0' ? env : nullptr;
}

struct Candidate {
  std::string path;
  const char* origin;  ///< why it is looked at, for the error message
};

/// The places to look, in order (ddpg_backend.hpp), without repeats.
std::vector<Candidate> candidates() {
  if (const char* env = environment_override()) return {{env, "from $RIDGELINE_DDPG_MODULE"}};
  std::vector<Candidate> found;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) found.push_back({(exe.parent_path() / kModuleFileName).string(), "beside the program"});
  const fs::path built = RIDGELINE_DDPG_MODULE_BUILD_PATH;
  if (!built.empty() &&
      (found.empty() || fs::path(found[0].path).lexically_normal() != built.lexically_normal()))
    found.push_back({built.string(), "in the build tree"});
  return found;
}

/// Loads one candidate; on failure returns the reason and leaves `loaded` empty. A module that
/// was opened but refused stays open (never dlclose: libtorch does not unload cleanly).
std::string try_load(const std::string& path, LoadedModule& loaded) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return "not found";
  dlerror();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* error = dlerror();
    std::string why = error != nullptr ? error : "dlopen failed";
    if (why.starts_with(path + ": ")) why.erase(0, path.size() + 2);  // the path is said already
    return why;
  }
  void* symbol = dlsym(handle, kBackendEntrySymbol);
  if (symbol == nullptr)
    return fmt::format("no symbol {}: not a Ridgeline DDPG module", kBackendEntrySymbol);
  const BackendEntry* entry = reinterpret_cast<EntryFunction>(symbol)();
  if (entry == nullptr || entry->backend == nullptr) return "the module returned no backend";
  if (entry->abi_version != kAbiVersion || entry->layout_size != layout_size())
    return fmt::format(
        "built from another version of Ridgeline (ABI {}, layout {}; this program: ABI {}, "
        "layout {})",
        entry->abi_version, entry->layout_size, kAbiVersion, layout_size());
  loaded.path = path;
  loaded.backend = entry->backend;
  return {};
}

LoadedModule load_module() {
  const std::vector<Candidate> places = candidates();
  std::string tried;
  for (const Candidate& place : places) {
    LoadedModule loaded;
    const std::string why = try_load(place.path, loaded);
    if (loaded.backend != nullptr) return loaded;
    tried += fmt::format("{}{} ({}): {}", tried.empty() ? "" : "; ", place.path, place.origin, why);
  }
  const bool from_environment = environment_override() != nullptr;
  throw InputError(
      fmt::format("DDPG torch module {}", kModuleFileName),
      fmt::format("not loaded (method ddpg and 'train ddpg' need it); tried {}. Build the target "
                  "ridgeline_ddpg, or {} {}{}",
                  tried, from_environment ? "unset" : "set", kModuleEnvironmentVariable,
                  from_environment ? "" : " to the module's path"));
}

const LoadedModule& loaded_module() {
  // A throw leaves it unset, so a later call tries again (and reports again).
  static const LoadedModule module = load_module();
  return module;
}

}  // namespace

const Backend& backend() { return *loaded_module().backend; }
const std::string& module_path() { return loaded_module().path; }

}  // namespace ridgeline::learning::ddpg_backend
