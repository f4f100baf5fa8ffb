// The vehicle processes a team command spawns (`run --mavlink`, `run --px4-dds`): this program
// started again as `ridgeline vehicle-sim ...`, one per UAV, stopped with the team. A child gets
// SIGTERM when its parent dies, so no vehicle outlives its companion.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace ridgeline::apps {

class VehicleProcesses {
 public:
  /// `what` names the command in errors ("run --mavlink").
  explicit VehicleProcesses(std::string what) : what_(std::move(what)) {}
  ~VehicleProcesses() { stop(); }
  VehicleProcesses(const VehicleProcesses&) = delete;
  VehicleProcesses& operator=(const VehicleProcesses&) = delete;

  /// Starts this program with `arguments` (after its own path), its output to `log` (a file;
  /// "" discards it). Throws std::runtime_error when it cannot start (and stops the others).
  void spawn(const std::vector<std::string>& arguments, const std::string& log);
  /// Starts `ridgeline vehicle-sim` for UAV `uav` (named `uav_name`) in lock step with wind and
  /// a cruise start, on the link `link_arguments` chooses (--udp ..., --px4-dds ...), loading
  /// `scenario_path` ("" = the embedded default); its output to log_dir/vehicle-sim-<name>.log
  /// (log_dir, created if missing; empty: discarded). Throws as spawn().
  void spawn_vehicle_sim(int uav, const std::string& uav_name,
                         std::vector<std::string> link_arguments, const std::string& scenario_path,
                         const std::filesystem::path& log_dir);
  /// A vehicle this command does not start (one the user runs).
  void add_external() { processes_.push_back({}); }
  /// Stops the running ones (SIGTERM, then SIGKILL after 3 s) and records how each ended.
  void stop();
  /// "external", "running" or how it ended ("exit 0", "killed by signal 9", ...).
  const std::string& status(int i) const { return processes_[static_cast<std::size_t>(i)].status; }

 private:
  struct Process {
    pid_t pid = -1;
    std::string status = "external";
  };
  std::string what_;
  std::vector<Process> processes_;
};

}  // namespace ridgeline::apps
