#include "apps/vehicle_processes.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

namespace ridgeline::apps {
namespace {

std::string describe_exit(int status) {
  if (WIFEXITED(status)) return fmt::format("exit {}", WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return fmt::format("killed by signal {}", WTERMSIG(status));
  return "unknown";
}

}  // namespace

void VehicleProcesses::spawn_vehicle_sim(int uav, const std::string& uav_name,
                                         std::vector<std::string> link_arguments,
                                         const std::string& scenario_path,
                                         const std::filesystem::path& log_dir) {
  std::vector<std::string> arguments = {"vehicle-sim"};
  arguments.insert(arguments.end(), link_arguments.begin(), link_arguments.end());
  for (const std::string& a : {std::string("--uav"), std::to_string(uav), std::string("--lockstep"),
                               std::string("--wind"), std::string("--cruise-start")})
    arguments.push_back(a);
  if (!scenario_path.empty()) {
    arguments.push_back("--scenario");
    arguments.push_back(scenario_path);
  }
  if (!log_dir.empty()) std::filesystem::create_directories(log_dir);
  spawn(arguments, log_dir.empty()
                       ? std::string()
                       : (log_dir / fmt::format("vehicle-sim-{}.log", uav_name)).string());
}

void VehicleProcesses::spawn(const std::vector<std::string>& arguments, const std::string& log) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) {
    stop();
    throw std::runtime_error(
        fmt::format("{}: cannot find this program (/proc/self/exe): {}", what_, ec.message()));
  }
  std::vector<std::string> argv = {self.string()};
  argv.insert(argv.end(), arguments.begin(), arguments.end());
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const std::string log_path = log.empty() ? std::string("/dev/null") : log;
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const std::string reason = std::strerror(errno);
    stop();
    throw std::runtime_error(fmt::format("{}: cannot start {}: {}", what_, argv[1], reason));
  }
  if (pid == 0) {
    // Only async-signal-safe calls between fork and exec.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(126);
    const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    const int null_in = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (null_in >= 0) ::dup2(null_in, STDIN_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  processes_.push_back({pid, "running"});
}

void VehicleProcesses::stop() {
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

}  // namespace ridgeline::apps
