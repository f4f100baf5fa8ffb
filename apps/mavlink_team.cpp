#include "apps/mavlink_team.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "core/error.hpp"
#include "mission/statistics.hpp"

namespace ridgeline::apps {
namespace {

/// This program's own path, to start `vehicle-sim` from the same build.
std::string own_executable() {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec)
    throw std::runtime_error("run --mavlink: cannot find this program (/proc/self/exe): " +
                             ec.message());
  return p.string();
}

/// Starts argv[0] with argv, its output to `log` (or /dev/null). The child gets SIGTERM when
/// this process dies, so no vehicle outlives its companion.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0)
    throw std::runtime_error(
        fmt::format("run --mavlink: cannot start {}: {}", argv[1], std::strerror(errno)));
  if (pid == 0) {
    // Only async-signal-safe calls between fork and exec.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(126);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    const int null_in = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (null_in >= 0) ::dup2(null_in, STDIN_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return pid;
}

std::string describe_exit(int status) {
  if (WIFEXITED(status)) return fmt::format("exit {}", WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return fmt::format("killed by signal {}", WTERMSIG(status));
  return "unknown";
}

}  // namespace

double home_altitude_m(const mission::Scenario& scenario) {
  return scenario.origin ? scenario.origin->alt_amsl_m : 0.0;
}

MavlinkTeam::MavlinkTeam(const mission::Scenario& scenario, const MavlinkTeamOptions& options)
    : period_s_(scenario.mpc.control_period_s), home_altitude_m_(home_altitude_m(scenario)) {
  const std::size_t n = scenario.uavs.size();
  if (!(options.timeout_s > 0.0) || !std::isfinite(options.timeout_s))
    throw InputError("--mavlink-timeout",
                     fmt::format("{} s is not a positive number of seconds", options.timeout_s));
  if (!options.vehicle_addresses.empty() && options.vehicle_addresses.size() != n)
    throw InputError("--mavlink-vehicles",
                     fmt::format("{} addresses for the scenario's {} UAVs (one HOST:PORT each, "
                                 "in the scenario's order)",
                                 options.vehicle_addresses.size(), n));
  std::vector<mavlink::UdpLink> links;
  for (std::size_t i = 0; i < n; ++i) {
    names_.push_back(fmt::format("{} (UAV {})", scenario.uavs[i].name, i));
    if (!options.vehicle_addresses.empty()) {
      std::pair<std::string, std::uint16_t> hp;
      try {
        hp = mavlink::parse_host_port(options.vehicle_addresses[i]);
      } catch (const InputError& e) {
        throw InputError("--mavlink-vehicles", fmt::format("{} (entry {})", e.reason(), i));
      }
      links.push_back(mavlink::UdpLink::connect(hp.first, hp.second));
      processes_.push_back({});
    } else {
      // The companion's port first; the vehicle, on a free port of its own, announces itself
      // there (as PX4 SITL sends to its companion's port).
      links.push_back(mavlink::UdpLink::listen("127.0.0.1", 0));
    }
  }
  if (options.vehicle_addresses.empty()) {
    const std::string exe = own_executable();
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<std::string> argv = {
          exe,      "vehicle-sim",     "--udp",
          "0",      "--peer",          fmt::format("127.0.0.1:{}", links[i].local_port()),
          "--uav",  std::to_string(i), "--lockstep",
          "--wind", "--cruise-start"};
      if (!options.scenario_path.empty()) {
        argv.push_back("--scenario");
        argv.push_back(options.scenario_path);
      }
      const std::string log =
          options.log_dir.empty()
              ? std::string("/dev/null")
              : (options.log_dir / fmt::format("vehicle-sim-{}.log", scenario.uavs[i].name))
                    .string();
      Process p;
      try {
        p.pid = spawn(argv, log);
      } catch (...) {
        stop_vehicles();
        throw;
      }
      p.status = "running";
      processes_.push_back(p);
    }
  }
  mavlink::LockstepFleetOptions fo;
  fo.period_s = period_s_;
  fo.home_altitude_m = home_altitude_m_;
  // A spawned vehicle loads the scenario (a DEM can take seconds) before it announces itself.
  fo.start_timeout_s = 3.0 * options.timeout_s;
  fo.step_timeout_s = options.timeout_s;
  fleet_ = std::make_unique<mavlink::LockstepFleet>(fo, names_, std::move(links));
  commands_.resize(n);
}

MavlinkTeam::~MavlinkTeam() { stop_vehicles(); }

void MavlinkTeam::stop_vehicles() {
  using Clock = std::chrono::steady_clock;
  for (Process& p : processes_)
    if (p.pid > 0 && p.status == "running") ::kill(p.pid, SIGTERM);
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(3);
  for (Process& p : processes_) {
    if (p.pid <= 0 || p.status != "running") continue;
    int status = 0;
    pid_t r = 0;
    while ((r = ::waitpid(p.pid, &status, WNOHANG)) == 0 && Clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (r == 0) {
      ::kill(p.pid, SIGKILL);
      ::waitpid(p.pid, &status, 0);
      p.status = "killed after 3 s (did not stop on SIGTERM)";
    } else {
      p.status = r == p.pid ? describe_exit(status) : "unknown";
    }
  }
}

void MavlinkTeam::start(std::vector<sim::VehicleReport>& out) {
  fleet_->start(reports_);
  out.clear();
  for (const mavlink::FleetReport& r : reports_)
    out.push_back({r.position_m, r.ground_velocity_m_s, r.heading_rad, r.turn_rate_rad_s});
}

void MavlinkTeam::step(long long step, double /*t_s*/,
                       const std::vector<sim::VehicleCommand>& commands,
                       std::vector<sim::VehicleReport>& out) {
  for (std::size_t i = 0; i < commands.size() && i < commands_.size(); ++i)
    commands_[i] = {commands[i].command, commands[i].hold};
  fleet_->step(static_cast<std::uint64_t>(step), commands_, reports_);
  out.clear();
  for (const mavlink::FleetReport& r : reports_)
    out.push_back({r.position_m, r.ground_velocity_m_s, r.heading_rad, r.turn_rate_rad_s});
}

nlohmann::json MavlinkTeam::to_json() const {
  nlohmann::json vehicles = nlohmann::json::array();
  std::uint64_t sent = 0, received = 0, rejected = 0, checksum = 0, resends = 0;
  for (int i = 0; i < fleet_->size(); ++i) {
    const mavlink::FleetVehicleStats s = fleet_->stats(i);
    nlohmann::json by_reason = nlohmann::json::object();
    for (int k = 0; k < mavlink::kFrameStatusCount; ++k) {
      const auto status = static_cast<mavlink::FrameStatus>(k);
      if (status == mavlink::FrameStatus::kOk || status == mavlink::FrameStatus::kIncomplete)
        continue;
      by_reason[std::string(mavlink::to_string(status))] = s.parser.count(status);
    }
    vehicles.push_back(
        {{"uav", names_[static_cast<std::size_t>(i)]},
         {"address", fleet_->address(i)},
         {"process", processes_[static_cast<std::size_t>(i)].status},
         {"steps", s.steps},
         {"datagrams_sent", s.datagrams_sent},
         {"frames_sent", s.frames_sent},
         {"frames_received", s.parser.accepted()},
         {"frames_rejected", s.parser.rejected()},
         {"rejected_by_reason", by_reason},
         {"bytes_skipped", s.parser.bytes_skipped},
         {"resends", s.resends},
         {"stale_reports", s.stale_reports},
         {"start_s", s.start_s},
         {"round_trip_us", mission::to_json(mission::percentiles(s.round_trip_us))}});
    sent += s.frames_sent;
    received += s.parser.accepted();
    rejected += s.parser.rejected();
    checksum += s.parser.count(mavlink::FrameStatus::kBadChecksum);
    resends += s.resends;
  }
  return {{"mode", "lock-step"},
          {"period_s", period_s_},
          {"home_altitude_m", home_altitude_m_},
          {"frames_sent", sent},
          {"frames_received", received},
          {"frames_rejected", rejected},
          {"checksum_errors", checksum},
          {"resends", resends},
          {"vehicles", vehicles}};
}

}  // namespace ridgeline::apps
