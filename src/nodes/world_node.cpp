#include "nodes/world_node.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "core/error.hpp"
#include "mission/flight_recorder.hpp"
#include "mission/statistics.hpp"
#include "mission/truth_world.hpp"
#include "transport_dds/sim_link.hpp"

namespace ridgeline::nodes {
namespace {

using Clock = std::chrono::steady_clock;
using transport_dds::CommandReport;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// An agent's answer as the flight recorder takes it (the same fields as the in-process step).
mission::ControlReport control_report(const CommandReport& a) {
  mission::ControlReport r;
  r.finished = a.mode == swarm::AgentMode::kFinished;
  r.reference_m = a.reference_m;
  r.command = a.command;
  r.has_tracker = a.has_tracker;
  r.mpc_step_us = a.mpc_step_us;
  r.mpc_step_cpu_us = a.mpc_step_cpu_us;
  r.qp_iterations = a.qp_iterations;
  r.max_slack_m = a.max_slack_m;
  return r;
}

struct Slot {
  bool started = false;
  bool lost = false;
  bool finished = false;
  bool measured = false;  ///< got a measurement of the current tick (started before it)
  bool answered = false;  ///< answered the current tick
  int silent_periods = 0;
  double finish_time_s = -1.0;
  CommandReport last;
  std::vector<double> periods, computes, latencies;
  long long missed = 0;
  long long turn_limited = 0;
  double started_s = -1.0, lost_s = -1.0;
};

}  // namespace

WorldNodeResult run_world_node(const mission::Scenario& scenario,
                               std::shared_ptr<const world::Terrain> terrain,
                               const transport_dds::DdsOptions& dds,
                               const WorldNodeOptions& options) {
  const int n = static_cast<int>(scenario.uavs.size());
  if (options.wait_for_agents > n)
    throw InputError("wait_for_agents", fmt::format("the scenario has {} UAVs", n));
  if (!(options.answer_timeout_s > 0.0) || !std::isfinite(options.answer_timeout_s))
    throw InputError("answer_timeout_s", "must be positive and finite");
  if (options.lost_after_periods < 1) throw InputError("lost_after_periods", "must be >= 1");
  const auto wall_start = Clock::now();
  auto participant = std::make_shared<transport_dds::DdsParticipant>(dds);
  transport_dds::SimLink link(participant, n, transport_dds::world_role());
  mission::TruthWorld world(scenario, terrain);
  mission::FlightRecorder recorder(scenario, *terrain, world, options.record_trajectories);
  std::vector<Slot> slots(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) slots[static_cast<std::size_t>(i)].last.uav = i;
  WorldNodeResult result;
  result.lock_step = options.lock_step;

  const double control_s = scenario.mpc.control_period_s;
  const double duration = scenario.simulation.duration_s;
  const int sub_ticks =
      std::max(1, static_cast<int>(std::lround(control_s * scenario.simulation.message_rate_hz)));
  std::vector<CommandReport> answers;
  double t = 0.0;
  std::uint64_t tick = 0;
  Clock::time_point published_at = Clock::now();

  // A hello starts an agent; a UAV whose agent starts after tick 0 is released from its hold.
  auto start_agent = [&](int i) {
    Slot& s = slots[static_cast<std::size_t>(i)];
    if (s.started || s.lost) return;
    s.started = true;
    s.started_s = t;
    if (world.holding(i)) {
      const double v = scenario.uavs[static_cast<std::size_t>(i)].start_speed_m_s;
      world.release(i, vehicle::Input(v, 0.0, 0.0));
    }
  };
  auto apply = [&](const CommandReport& a) {
    Slot& s = slots[static_cast<std::size_t>(a.uav)];
    if (s.lost || !s.started) return;
    s.last = a;
    if (a.loop_period_s > 0.0) s.periods.push_back(a.loop_period_s);
    s.computes.push_back(a.compute_s);
    s.latencies.push_back(seconds_since(published_at));
    if (options.lock_step && a.compute_s > control_s) ++s.missed;
    if (a.mode == swarm::AgentMode::kFinished) {
      if (!s.finished) {
        world.hold(a.uav);
        s.finished = true;
        s.finish_time_s = t;
      }
    } else {
      if (!options.lock_step) {
        // In real time a setpoint lands some milliseconds after the state it was computed
        // from, when the speed may have dropped: the flight controller holds |ω_c| to the turn
        // limit (eq. 3) at the lowest speed of the coming period, which lies between the speed
        // now and the commanded one (first-order speed response), and the limiting is counted.
        const vehicle::VehicleParams& vp = scenario.uavs[static_cast<std::size_t>(a.uav)].vehicle;
        const double v = std::min(world.true_state(a.uav)[vehicle::kV], s.last.command[0]);
        const double limit = vp.max_turn_rate_rad_s(v);
        if (std::abs(s.last.command[1]) > limit) {
          s.last.command[1] = std::copysign(limit, s.last.command[1]);
          ++s.turn_limited;
        }
      }
      if (s.finished) {
        // A finished UAV that got new targets (re-allocation) flies again.
        s.finished = false;
        s.finish_time_s = -1.0;
        world.release(a.uav, s.last.command);
      }
      world.set_command(a.uav, s.last.command);
    }
  };
  auto declare_lost = [&](int i) {
    Slot& s = slots[static_cast<std::size_t>(i)];
    if (s.lost) return;
    s.lost = true;
    s.lost_s = t;
    result.lost.push_back(i);
    if (!world.holding(i)) world.hold(i);  // the autopilot's failsafe: hold position
  };
  auto take_answers = [&](bool real_time) {
    answers.clear();
    link.take(answers);
    for (const CommandReport& a : answers) {
      Slot& s = slots[static_cast<std::size_t>(a.uav)];
      if (a.hello) {
        start_agent(a.uav);
        continue;
      }
      if (!s.started || s.lost) continue;
      if (a.tick == tick && s.measured && !s.answered) {
        if (real_time) {
          // The command takes effect now, inside the period.
          const double now = std::min(t + seconds_since(published_at), t + control_s - 1e-6);
          world.advance_to(std::max(now, world.time_s()));
        }
        s.answered = true;
        s.silent_periods = 0;
        apply(a);
      } else if (real_time && a.tick + 1 == tick) {
        // Late for its period (already counted as missed): the flight controller still takes
        // the newest setpoint it gets.
        apply(a);
      }
    }
  };

  // Wait for the agents before tick 0.
  const int wait_for = options.wait_for_agents < 0 ? n : options.wait_for_agents;
  auto started_count = [&] {
    return static_cast<int>(
        std::count_if(slots.begin(), slots.end(), [](const Slot& s) { return s.started; }));
  };
  while (started_count() < wait_for && seconds_since(wall_start) < options.start_timeout_s) {
    link.wait(0.05);
    take_answers(false);
  }
  if (started_count() == 0)
    throw std::runtime_error(fmt::format("world: no agent said hello within {} s (domain {})",
                                         options.start_timeout_s, dds.domain_id));
  for (int i = 0; i < n; ++i)
    if (!slots[static_cast<std::size_t>(i)].started) world.hold(i);  // waits for its agent

  double next_progress_s = 0.0;
  const auto run_start = Clock::now();
  std::vector<int> sensed;
  for (;; ++tick) {
    t = static_cast<double>(tick) * control_s;
    if (t > duration + 1e-9) break;
    if (!options.lock_step) {
      const auto due =
          run_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t));
      std::this_thread::sleep_until(due);
    }
    world.advance_to(t);
    if (options.progress && t >= next_progress_s) {
      options.progress(t, duration);
      next_progress_s += 1.0;
    }
    transport_dds::ClockTick clock;
    clock.tick = tick;
    clock.t_s = t;
    clock.lock_step = options.lock_step;
    clock.lost = result.lost;
    for (int i = 0; i < n; ++i) {
      const Slot& s = slots[static_cast<std::size_t>(i)];
      if (!s.answered) continue;  // (still the previous tick's flag)
      clock.answered.push_back(i);
      clock.reports_sent.push_back(static_cast<std::int64_t>(s.last.counters.threat_reports_sent));
      clock.prediction_stamps.push_back(s.last.prediction_stamp_s);
    }
    link.publish(clock);
    published_at = Clock::now();
    for (int i = 0; i < n; ++i) {
      Slot& s = slots[static_cast<std::size_t>(i)];
      s.answered = false;
      s.measured = false;
      // The sensors of every UAV are read at every tick, in UAV order (as in the in-process
      // mission, so the noise streams match).
      world.sensed_threats(i, sensed);
      transport_dds::Measurement m;
      m.uav = i;
      m.tick = tick;
      m.t_s = t;
      for (const int k : sensed) {
        const world::Threat& th = world.threats()[static_cast<std::size_t>(k)];
        m.threats.push_back({k, th.centre_at(t), th.velocity_m_s, th.radius_m});
        recorder.sensed(i, k, t, world);
      }
      m.state = world.measured_state(i);
      m.wind_m_s = world.measured_wind(i);
      if (s.started && !s.lost) {
        link.publish(m);
        s.measured = true;
      }
    }

    auto waiting = [&] {
      for (const Slot& s : slots)
        if (s.measured && !s.lost && !s.answered) return true;
      return false;
    };
    if (options.lock_step) {
      while (waiting() && seconds_since(published_at) < options.answer_timeout_s) {
        link.wait(std::max(1e-4, options.answer_timeout_s - seconds_since(published_at)));
        take_answers(false);
      }
      for (int i = 0; i < n; ++i) {
        const Slot& s = slots[static_cast<std::size_t>(i)];
        if (s.measured && !s.lost && !s.answered) declare_lost(i);
      }
    } else {
      const double period_end = static_cast<double>(tick + 1) * control_s;
      while (true) {
        const double left = period_end - seconds_since(run_start);
        if (left <= 0.0) break;
        link.wait(left);
        take_answers(true);
      }
      for (int i = 0; i < n; ++i) {
        Slot& s = slots[static_cast<std::size_t>(i)];
        if (!s.measured || s.lost || s.answered) continue;
        ++s.missed;
        if (++s.silent_periods >= options.lost_after_periods) declare_lost(i);
      }
    }

    for (int i = 0; i < n; ++i) {
      const Slot& s = slots[static_cast<std::size_t>(i)];
      if (s.answered)
        recorder.control_step(i, t, world, control_report(s.last));
      else
        recorder.unanswered(i, t, world);
    }
    recorder.tick(t, world);
    if (options.lock_step) {
      // The truth's distances at the message rate between control ticks, as in-process.
      for (int j = 1; j < sub_ticks; ++j) {
        const double tj = t + j * control_s / sub_ticks;
        world.advance_to(tj);
        recorder.tick(tj, world);
      }
    }
    bool all_done = true;
    for (const Slot& s : slots) all_done = all_done && (s.finished || s.lost);
    if (all_done) break;
  }

  transport_dds::ClockTick stop;
  stop.tick = tick;
  stop.t_s = t;
  stop.running = false;
  stop.lock_step = options.lock_step;
  stop.lost = result.lost;
  for (int k = 0; k < 3; ++k) {
    link.publish(stop);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }

  // A UAV whose agent was lost counts as not finished.
  std::vector<mission::UavOutcome> outcomes;
  for (const Slot& s : slots) {
    mission::UavOutcome o;
    o.targets_assigned = s.last.targets_assigned;
    o.targets_inspected = s.last.targets_inspected;
    o.missed_targets = s.last.missed_targets;
    o.finished = s.finish_time_s >= 0.0;
    o.finish_time_s = s.finish_time_s;
    o.counters = s.last.counters;
    outcomes.push_back(std::move(o));
  }
  result.mission = recorder.finish(t, outcomes);
  result.wall_time_s = seconds_since(wall_start);
  result.mission.metrics.wall_time_s = result.wall_time_s;
  for (int i = 0; i < n; ++i) {
    const Slot& s = slots[static_cast<std::size_t>(i)];
    AgentDeadlineStats d;
    d.name = scenario.uavs[static_cast<std::size_t>(i)].name;
    d.answers = static_cast<long long>(s.computes.size());
    if (!s.periods.empty()) {
      double sum = 0.0, max_dev = 0.0;
      for (const double p : s.periods) {
        sum += p;
        max_dev = std::max(max_dev, std::abs(p - control_s));
      }
      d.loop_period_mean_s = sum / static_cast<double>(s.periods.size());
      double var = 0.0;
      for (const double p : s.periods)
        var += (p - d.loop_period_mean_s) * (p - d.loop_period_mean_s);
      d.loop_period_jitter_s = std::sqrt(var / static_cast<double>(s.periods.size()));
      d.loop_period_max_dev_s = max_dev;
    }
    const mission::Percentiles c = mission::percentiles(s.computes);
    d.compute_p50_s = c.median;
    d.compute_p99_s = c.p99;
    d.compute_max_s = c.max;
    d.latency_p99_s = mission::percentiles(s.latencies).p99;
    d.missed_deadlines = s.missed;
    d.turn_setpoints_limited = s.turn_limited;
    d.started_s = s.started_s;
    d.lost_s = s.lost_s;
    result.agents.push_back(d);
  }
  result.messages_rejected = static_cast<long long>(link.stats().rejected);
  result.last_rejection = link.stats().last_rejection;
  return result;
}

}  // namespace ridgeline::nodes
