// `ridgeline launch [--scenario FILE] [--agents-as-processes] [--real-time] --out DIR`: the
// swarm as separate processes on this machine (issue 7, part 3). Starts `ridgeline ground`
// (plans, publishes plans, re-allocates) and `ridgeline world` (truth, clock, metrics) as
// processes and one agent per UAV — each `ridgeline agent --id I` process with
// --agents-as-processes, else a thread of this process with a DDS participant of its own —
// all on loopback, in a DDS domain and partition of this run. It waits for them and writes the
// same outputs as `run` (metrics.json, trajectories.csv, plan.json, summary.json, report.html;
// metrics.json also has "distributed": per-agent deadline statistics, lost UAVs and the ground
// station's re-allocations), and each process's output in DIR/logs/.
//
// Faults, for tests: --kill-agent I@T kills agent I's process (SIGKILL) once the world's clock
// passes T s; --late-agent I@S starts agent I once the world's clock passes S s (mission time,
// so the fault is the same on a fast and a slow machine; the agent then needs some wall time to
// start, discover the others and take its plan while the world goes on); --link-loss and
// --link-latency-s emulate a lossy, slow UAV-to-UAV link; --inject-malformed publishes
// malformed and out-of-range messages on every topic throughout the mission.
// Exit 0 when the flight was safe and every process ended as expected, 4 when a safety metric
// failed, 5 when a process failed.
#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <thread>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "apps/node_support.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "io/scenario_summary.hpp"
#include "nodes/agent_node.hpp"
#include "transport_dds/dds_transport.hpp"
#include "transport_dds/sim_link.hpp"

extern char** environ;

namespace ridgeline::apps {
namespace {

using Clock = std::chrono::steady_clock;

struct Child {
  std::string name;
  pid_t pid = -1;
  bool exited = false;
  int status = 0;
  bool killed_by_us = false;
};

pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& log) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0)
    throw std::runtime_error(
        fmt::format("launch: cannot start {}: {}", argv[0], std::strerror(rc)));
  return pid;
}

bool poll_exit(Child& c) {
  if (c.exited || c.pid < 0) return true;
  int status = 0;
  if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
    c.exited = true;
    c.status = status;
  }
  return c.exited;
}

std::string describe(const Child& c) {
  if (!c.exited) return "still running (killed at the end)";
  if (WIFEXITED(c.status)) return fmt::format("exit {}", WEXITSTATUS(c.status));
  if (WIFSIGNALED(c.status))
    return fmt::format("killed by signal {}{}", WTERMSIG(c.status),
                       c.killed_by_us ? " (fault injection)" : "");
  return "unknown";
}

/// "I@X" → (I, X); InputError naming `field` otherwise.
std::pair<int, double> parse_at(const std::string& text, const char* field, int num_uavs) {
  const auto at = text.find('@');
  try {
    if (at == std::string::npos) throw std::invalid_argument("no @");
    std::size_t used = 0;
    const int id = std::stoi(text.substr(0, at), &used);
    if (used != at) throw std::invalid_argument("id");
    const double value = std::stod(text.substr(at + 1), &used);
    if (used != text.size() - at - 1 || !std::isfinite(value) || value < 0.0)
      throw std::invalid_argument("value");
    if (id < 0 || id >= num_uavs)
      throw InputError(field, fmt::format("'{}': UAV {} is not in 0..{}", text, id, num_uavs - 1));
    return {id, value};
  } catch (const std::invalid_argument&) {
    throw InputError(field, fmt::format("'{}' is not ID@SECONDS (e.g. 1@60)", text));
  } catch (const std::out_of_range&) {
    throw InputError(field, fmt::format("'{}' is out of range", text));
  }
}

/// Publishes malformed and out-of-range samples on the swarm's and the world's topics.
class MalformedInjector {
 public:
  MalformedInjector(const transport_dds::DdsOptions& dds, int num_uavs)
      : participant_(std::make_shared<transport_dds::DdsParticipant>(dds)),
        transport_(participant_, options(num_uavs)),
        link_(participant_, num_uavs, transport_dds::agent_role()),
        num_uavs_(num_uavs) {}

  void inject(double t_s) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    swarm::PredictedTrajectory p;
    p.uav = num_uavs_ + 3;  // no such UAV
    p.stamp_s = t_s;
    p.positions_m.assign(40, Vec3(0, 0, 100));
    transport_.publish(0, t_s, p);
    swarm::ThreatReport r{0, 99, t_s, Vec3(nan, 0, 0), Vec3::Zero(), 50.0};
    transport_.publish(0, t_s, r);
    swarm::ThreatReport r2{1 % num_uavs_, 98, t_s, Vec3(500, 500, 100), Vec3::Zero(), -10.0};
    transport_.publish(0, t_s, r2);
    transport_dds::CommandReport c;
    c.uav = num_uavs_ + 1;  // no such UAV
    c.t_s = t_s;
    link_.publish(c);
    ++injected_;
  }
  long long injected() const { return injected_; }

 private:
  static transport_dds::DdsTransportOptions options(int num_uavs) {
    transport_dds::DdsTransportOptions o;
    o.participant_id = 0;
    o.num_uavs = num_uavs;
    return o;
  }
  std::shared_ptr<transport_dds::DdsParticipant> participant_;
  transport_dds::DdsTransport transport_;
  transport_dds::SimLink link_;
  int num_uavs_;
  long long injected_ = 0;
};

struct LaunchArgs {
  std::string scenario;
  std::string out = "out";
  bool agents_as_processes = false;
  bool real_time = false;
  std::optional<int> domain_id;
  std::optional<std::string> partition;
  std::vector<std::string> kill;
  std::vector<std::string> late;
  double link_loss = 0.0;
  double link_latency_s = 0.0;
  bool inject_malformed = false;
  double answer_timeout_s = 5.0;
  double timeout_s = 3600.0;
  std::optional<double> duration_s;
};

// The fault injections of the command line, checked against the team.
struct Faults {
  std::map<int, double> kill_at;  ///< UAV -> mission time its agent is killed
  std::map<int, double> late_by;  ///< UAV -> mission time its agent starts
};

Faults check_arguments(const LaunchArgs& args, int n) {
  if (!(args.link_loss >= 0.0 && args.link_loss <= 1.0))
    throw InputError("--link-loss", fmt::format("must be in [0, 1], got {}", args.link_loss));
  if (!(args.link_latency_s >= 0.0 && std::isfinite(args.link_latency_s)))
    throw InputError("--link-latency-s", fmt::format("must be >= 0, got {}", args.link_latency_s));
  if (args.duration_s && !(*args.duration_s > 0.0 && std::isfinite(*args.duration_s)))
    throw InputError("--duration-s", fmt::format("must be positive, got {}", *args.duration_s));
  Faults faults;
  for (const std::string& k : args.kill) {
    const auto [id, t] = parse_at(k, "--kill-agent", n);
    faults.kill_at[id] = t;
  }
  for (const std::string& k : args.late) {
    const auto [id, s] = parse_at(k, "--late-agent", n);
    faults.late_by[id] = s;
  }
  if (!faults.kill_at.empty() && !args.agents_as_processes)
    throw InputError("--kill-agent", "needs --agents-as-processes (a thread cannot be killed)");
  if (static_cast<int>(faults.late_by.size()) >= n)
    throw InputError("--late-agent", "at least one agent must start on time");
  return faults;
}

// Waits for every child (up to 20 s after the world ended, none when `at_once`), kills what
// is left, and joins the agent threads.
void finish_children(std::vector<Child>& children, std::vector<std::thread>& threads,
                     bool at_once) {
  const auto grace_end = Clock::now() + std::chrono::seconds(at_once ? 0 : 20);
  for (Child& c : children) {
    while (!poll_exit(c) && Clock::now() < grace_end)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (!poll_exit(c)) {
      ::kill(c.pid, SIGKILL);
      waitpid(c.pid, &c.status, 0);
    }
  }
  for (std::thread& th : threads) th.join();
}

// metrics.json's distributed.processes: how each process (or agent thread) ended. Prints one
// error line for each that failed and sets `failed`.
nlohmann::json report_exits(const std::vector<Child>& children,
                            const std::vector<std::string>& thread_errors, bool agents_as_processes,
                            const std::filesystem::path& logs, bool& failed) {
  nlohmann::json processes = nlohmann::json::object();
  for (const Child& c : children) {
    processes[c.name] = describe(c);
    const bool ok =
        c.killed_by_us ||
        (c.exited && WIFEXITED(c.status) &&
         (WEXITSTATUS(c.status) == 0 || (c.name == "world" && WEXITSTATUS(c.status) == 4)));
    if (!ok) {
      failed = true;
      std::cerr << fmt::format("error: {} failed ({}), see {}\n", c.name, describe(c),
                               (logs / (c.name == "ground" || c.name == "world"
                                            ? c.name + ".log"
                                            : fmt::format("agent{}.log", c.name.substr(6))))
                                   .string());
    }
  }
  if (!agents_as_processes)
    for (std::size_t i = 0; i < thread_errors.size(); ++i) {
      const std::string& e = thread_errors[i];
      processes[fmt::format("agent {}", i)] = e.empty() ? "thread ended" : "thread failed: " + e;
      if (!e.empty()) {
        failed = true;
        std::cerr << fmt::format("error: agent {} failed: {}\n", i, e);
      }
    }
  return processes;
}

// Merges the launcher's and the ground station's reports into the world's metrics.json and
// writes summary.json. Returns the merged metrics, or null when the world wrote none.
nlohmann::json write_launch_outputs(const std::filesystem::path& dir,
                                    const io::LoadedScenario& loaded, const LaunchArgs& args,
                                    const DdsArgs& dds, const nlohmann::json& processes,
                                    int malformed_injections) {
  if (!std::filesystem::exists(dir / "metrics.json")) return nullptr;
  nlohmann::json metrics = nlohmann::json::parse(std::ifstream(dir / "metrics.json"));
  if (std::filesystem::exists(dir / "ground.json"))
    metrics["distributed"]["ground"] = nlohmann::json::parse(std::ifstream(dir / "ground.json"));
  metrics["distributed"]["processes"] = processes;
  metrics["distributed"]["agents_as_processes"] = args.agents_as_processes;
  metrics["distributed"]["domain_id"] = dds.domain_id;
  metrics["distributed"]["partition"] = dds.partition;
  metrics["distributed"]["faults"] = {{"killed", args.kill},
                                      {"late", args.late},
                                      {"link_loss", args.link_loss},
                                      {"link_latency_s", args.link_latency_s},
                                      {"malformed_injections", malformed_injections}};
  io::write_file_atomically(dir / "metrics.json", metrics.dump(2) + "\n");
  nlohmann::json summary = io::summarize(loaded);
  if (std::filesystem::exists(dir / "plan.json")) {
    const nlohmann::json plan = nlohmann::json::parse(std::ifstream(dir / "plan.json"));
    summary["plan"] = {{"status", plan["status"]},
                       {"solve_time_s", plan["solve_time_s"]},
                       {"cost", plan["cost"]},
                       {"validation", plan["validation"]}};
  }
  summary["flight"] = {{"mission_complete", metrics["mission_complete"]},
                       {"safe", metrics["safe"]},
                       {"sim_time_s", metrics["sim_time_s"]},
                       {"wall_time_s", metrics["wall_time_s"]},
                       {"distributed", true}};
  io::write_file_atomically(dir / "summary.json", summary.dump(2) + "\n");
  return metrics;
}

}  // namespace

void register_launch_command(CLI::App& app) {
  auto args = std::make_shared<LaunchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "launch", "Fly the mission as separate processes over DDS on this machine (loopback)");
  cmd->add_option("--scenario", args->scenario, "Scenario YAML file (default: embedded default)");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  cmd->add_flag("--agents-as-processes", args->agents_as_processes,
                "One `ridgeline agent` process per UAV (default: agent threads in this process)");
  cmd->add_flag("--real-time", args->real_time,
                "Real time at the control rate (default: lock-step, as fast as the agents allow)");
  cmd->add_option("--domain-id", args->domain_id, "DDS domain id (default: 100 + pid mod 100)");
  cmd->add_option("--partition", args->partition,
                  "DDS partition (default: one of this run; \"\" is ROS 2's default partition)");
  cmd->add_option("--kill-agent", args->kill,
                  "Fault: kill agent I's process at mission time T (I@T)");
  cmd->add_option("--late-agent", args->late,
                  "Fault: start agent I once the mission clock passes S s (I@S)");
  cmd->add_option("--link-loss", args->link_loss, "Fault: loss of UAV-to-UAV messages, [0, 1]");
  cmd->add_option("--link-latency-s", args->link_latency_s,
                  "Fault: extra latency of UAV-to-UAV messages (mission time)");
  cmd->add_flag("--inject-malformed", args->inject_malformed,
                "Fault: publish malformed and out-of-range messages throughout");
  cmd->add_option("--answer-timeout-s", args->answer_timeout_s,
                  "Lock-step: wall time before a silent agent is declared lost")
      ->capture_default_str();
  cmd->add_option("--duration-s", args->duration_s,
                  "Stop the mission at this time (default: the scenario's simulation.duration_s)");
  cmd->add_option("--timeout-s", args->timeout_s, "Wall time limit of the whole run")
      ->capture_default_str();
  cmd->callback([args] {
    const io::LoadedScenario loaded = load_scenario_argument(args->scenario);
    const int n = static_cast<int>(loaded.scenario.uavs.size());
    Faults faults = check_arguments(*args, n);
    std::map<int, double>& kill_at = faults.kill_at;
    std::map<int, double>& late_by = faults.late_by;

    const int pid = static_cast<int>(::getpid());
    DdsArgs dds;
    dds.domain_id = args->domain_id.value_or(100 + pid % 100);
    dds.partition = args->partition.value_or(fmt::format("ridgeline-launch-{}", pid));
    const transport_dds::DdsOptions dds_opts = dds_options(dds);
    transport_dds::DdsParticipant check(dds_opts);  // fails early on a bad domain id

    char exe_buf[4096];
    const ssize_t len = ::readlink("/proc/self/exe", exe_buf, sizeof(exe_buf) - 1);
    if (len <= 0) throw std::runtime_error("launch: cannot find its own executable");
    const std::string exe(exe_buf, static_cast<std::size_t>(len));
    // The agents are their own program, which links no simulator (apps/agent/main.cpp).
    const std::string agent_exe =
        (std::filesystem::path(exe).parent_path() / "ridgeline-agent").string();
    if (args->agents_as_processes && ::access(agent_exe.c_str(), X_OK) != 0)
      throw InputError("--agents-as-processes",
                       agent_exe +
                           " is not there or not executable (build the target "
                           "ridgeline_agent, which the build puts beside ridgeline)");
    const std::filesystem::path dir(args->out);
    const std::filesystem::path logs = dir / "logs";
    std::filesystem::create_directories(logs);
    std::vector<std::string> common;
    if (!args->scenario.empty()) {
      common.push_back("--scenario");
      common.push_back(std::filesystem::absolute(args->scenario).string());
    }
    common.insert(common.end(),
                  {"--domain-id", std::to_string(dds.domain_id), "--partition", dds.partition});
    auto with = [&](std::vector<std::string> a) {
      a.insert(a.end(), common.begin(), common.end());
      return a;
    };
    std::cout << fmt::format("launch: {} UAVs, DDS domain {}, partition {}, {}, agents as {}\n", n,
                             dds.domain_id, dds.partition,
                             args->real_time ? "real time" : "lock-step",
                             args->agents_as_processes ? "processes" : "threads");

    std::vector<Child> children;
    children.push_back(
        {"ground", spawn(with({exe, "ground", "--out", dir.string()}), logs / "ground.log")});
    std::vector<std::string> world_args = {exe,
                                           "world",
                                           "--out",
                                           dir.string(),
                                           "--quiet",
                                           "--wait-for-agents",
                                           std::to_string(n - static_cast<int>(late_by.size())),
                                           "--answer-timeout-s",
                                           fmt::format("{}", args->answer_timeout_s)};
    if (args->real_time) world_args.push_back("--real-time");
    if (args->duration_s) {
      world_args.push_back("--duration-s");
      world_args.push_back(fmt::format("{}", *args->duration_s));
    }
    children.push_back({"world", spawn(with(world_args), logs / "world.log")});
    const std::size_t world_index = 1;

    auto agent_args = [&](int i) {
      std::vector<std::string> a = {agent_exe, "--id", std::to_string(i)};
      if (args->link_loss > 0.0) {
        a.push_back("--link-loss");
        a.push_back(fmt::format("{}", args->link_loss));
      }
      if (args->link_latency_s > 0.0) {
        a.push_back("--link-latency-s");
        a.push_back(fmt::format("{}", args->link_latency_s));
      }
      return with(a);
    };
    std::map<int, std::size_t> agent_child;  // UAV -> index in children
    std::vector<std::thread> threads;
    std::vector<std::string> thread_errors(static_cast<std::size_t>(n));
    std::vector<nodes::AgentNodeResult> thread_results(static_cast<std::size_t>(n));
    auto start_agent = [&](int i) {
      if (args->agents_as_processes) {
        agent_child[i] = children.size();
        children.push_back({fmt::format("agent {}", i),
                            spawn(agent_args(i), logs / fmt::format("agent{}.log", i))});
      } else {
        nodes::AgentNodeOptions o;
        o.id = i;
        o.emulated_link = swarm::LinkModel{args->link_latency_s, 0.0, args->link_loss};
        o.seed = loaded.scenario.seed * 1000003ULL + static_cast<std::uint64_t>(i);
        threads.emplace_back([&, o, i] {
          try {
            thread_results[static_cast<std::size_t>(i)] =
                nodes::run_agent_node(loaded.scenario, loaded.terrain, dds_opts, o);
            if (!thread_results[static_cast<std::size_t>(i)].world_stopped)
              thread_errors[static_cast<std::size_t>(i)] =
                  thread_results[static_cast<std::size_t>(i)].message;
          } catch (const std::exception& e) {
            thread_errors[static_cast<std::size_t>(i)] = e.what();
          }
        });
      }
    };
    for (int i = 0; i < n; ++i)
      if (late_by.count(i) == 0) start_agent(i);

    std::unique_ptr<transport_dds::SimLink> observer;
    std::shared_ptr<transport_dds::DdsParticipant> observer_participant;
    if (!kill_at.empty() || !late_by.empty()) {
      observer_participant = std::make_shared<transport_dds::DdsParticipant>(dds_opts);
      transport_dds::SimLinkRole role;
      role.reads_clock = true;
      observer = std::make_unique<transport_dds::SimLink>(observer_participant, n, role);
    }
    std::unique_ptr<MalformedInjector> injector;
    if (args->inject_malformed) injector = std::make_unique<MalformedInjector>(dds_opts, n);

    const auto start = Clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    double mission_t = 0.0;
    std::vector<transport_dds::ClockTick> clocks;
    auto last_injection = Clock::now();
    bool timed_out = false;
    bool aborted = false;  // the ground station failed
    while (!poll_exit(children[world_index])) {
      if (elapsed() > args->timeout_s) {
        timed_out = true;
        break;
      }
      // The ground station failed (e.g. planning failed): nothing will fly; stop at once.
      if (poll_exit(children[0]) &&
          !(WIFEXITED(children[0].status) && WEXITSTATUS(children[0].status) == 0)) {
        aborted = true;
        std::cerr << "error: the ground station failed, see " << (logs / "ground.log").string()
                  << '\n';
        break;
      }
      if (observer) {
        observer->wait(0.02);
        clocks.clear();
        observer->take(clocks);
        for (const auto& c : clocks) mission_t = std::max(mission_t, c.t_s);
        for (auto it = late_by.begin(); it != late_by.end();) {
          if (!clocks.empty() && mission_t >= it->second) {
            start_agent(it->first);
            std::cout << fmt::format("launch: started agent {} at t = {:.2f} s\n", it->first,
                                     mission_t);
            it = late_by.erase(it);
          } else {
            ++it;
          }
        }
        for (auto it = kill_at.begin(); it != kill_at.end();) {
          const auto child = agent_child.find(it->first);
          if (mission_t >= it->second && child != agent_child.end()) {
            Child& c = children[child->second];
            ::kill(c.pid, SIGKILL);
            c.killed_by_us = true;
            std::cout << fmt::format("launch: killed agent {} at t = {:.2f} s\n", it->first,
                                     mission_t);
            it = kill_at.erase(it);
          } else {
            ++it;
          }
        }
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      if (injector && Clock::now() - last_injection > std::chrono::milliseconds(100)) {
        injector->inject(mission_t);
        last_injection = Clock::now();
      }
    }
    // The world has ended (its clock said stop): the others follow within seconds.
    finish_children(children, threads, timed_out || aborted);
    bool failed = timed_out || aborted;
    const nlohmann::json processes =
        report_exits(children, thread_errors, args->agents_as_processes, logs, failed);
    if (timed_out)
      std::cerr << fmt::format("error: launch timed out after {} s\n", args->timeout_s);

    const nlohmann::json metrics = write_launch_outputs(dir, loaded, *args, dds, processes,
                                                        injector ? injector->injected() : 0);
    if (metrics.is_null()) {
      std::cerr << "error: the world wrote no metrics.json (see " << (logs / "world.log").string()
                << ")\n";
      set_exit_code(5);
      return;
    }
    std::cout << fmt::format(
        "launch: mission {} in {} s simulated, {:.1f} s wall; safe: {}; processes: {}\n",
        metrics.value("mission_complete", false) ? "complete" : "NOT complete",
        metrics.value("sim_time_s", 0.0), elapsed(), metrics.value("safe", false) ? "yes" : "NO",
        processes.dump());
    std::cout << "wrote metrics.json, trajectories.csv, plan.json, summary.json, logs/ to "
              << dir.string() << '\n';
    if (failed)
      set_exit_code(5);
    else if (!metrics.value("safe", false))
      set_exit_code(4);
  });
}

}  // namespace ridgeline::apps
