#include "nodes/agent_node.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "core/error.hpp"
#include "mission/stage_inputs.hpp"
#include "swarm/agent.hpp"
#include "transport_dds/dds_transport.hpp"
#include "transport_dds/plan_link.hpp"
#include "transport_dds/sim_link.hpp"

namespace ridgeline::nodes {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::unique_ptr<swarm::Agent> make_agent(const mission::Scenario& scenario, int id,
                                         const messages::ReferencePlan& plan,
                                         std::shared_ptr<const world::Terrain> terrain) {
  planning::UavPlan up;
  up.name = scenario.uavs[static_cast<std::size_t>(id)].name;
  up.targets = plan.target_ids;
  auto reference = std::make_shared<const mpc::SampledReference>(plan.times_s, plan.points);
  return std::make_unique<swarm::Agent>(mission::make_agent_options(scenario, id, up),
                                        scenario.safety, std::move(reference), std::move(terrain));
}

}  // namespace

AgentNodeResult run_agent_node(const mission::Scenario& scenario,
                               std::shared_ptr<const world::Terrain> terrain,
                               const transport_dds::DdsOptions& dds,
                               const AgentNodeOptions& options) {
  const int n = static_cast<int>(scenario.uavs.size());
  const int id = options.id;
  if (id < 0 || id >= n)
    throw InputError("id", fmt::format("must be a UAV of the scenario (0..{}), got {}", n - 1, id));
  auto participant = std::make_shared<transport_dds::DdsParticipant>(dds);
  transport_dds::SimLink link(participant, n, transport_dds::agent_role());
  transport_dds::PlanLink plans(participant, n, static_cast<int>(scenario.targets.size()), false);
  transport_dds::DdsTransportOptions to;
  to.participant_id = id;
  to.num_uavs = n;
  // The scenario's link latency at least (in mission time, from the sender's stamp): in
  // lock-step a neighbour's message is then never seen in the tick it was sent, as in the
  // in-process simulation. Loss only when asked for.
  to.emulated_link = options.emulated_link;
  to.emulated_link.latency_s =
      std::max(options.emulated_link.latency_s, scenario.simulation.link_latency_s);
  to.emulated_link.jitter_s =
      std::max(options.emulated_link.jitter_s, scenario.simulation.link_jitter_s);
  to.seed = options.seed;
  transport_dds::DdsTransport transport(participant, to);
  AgentNodeResult result;

  // 1. The plan.
  std::vector<messages::ReferencePlan> received;
  std::vector<transport_dds::ClockTick> clocks;
  const auto wait_start = Clock::now();
  while (received.empty()) {
    plans.take(received, id);
    clocks.clear();
    link.take(clocks);
    for (const auto& c : clocks)
      if (!c.running) {
        result.message = "the world stopped before a plan arrived";
        result.world_stopped = true;
        return result;
      }
    if (!received.empty()) break;
    if (seconds_since(wait_start) > options.plan_timeout_s)
      throw std::runtime_error(fmt::format("agent {}: no plan from the ground station within {} s",
                                           id, options.plan_timeout_s));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  messages::ReferencePlan plan = received.back();
  std::unique_ptr<swarm::Agent> agent = make_agent(scenario, id, plan, terrain);
  int inspected_before = 0;  // targets inspected under earlier plan versions
  result.plan_version = plan.version;

  // 2. Hello until the world's first measurement, then answer every measurement.
  transport_dds::CommandReport hello;
  hello.uav = id;
  hello.hello = true;
  bool first = true;
  auto last_hello = Clock::now() - std::chrono::seconds(1);
  auto last_heard = Clock::now();
  auto last_answer = Clock::time_point{};
  std::vector<transport_dds::Measurement> measurements;
  transport_dds::ClockTick latest_clock;
  latest_clock.lock_step = false;  // until the world's first tick says otherwise
  std::vector<swarm::Envelope> inbox;
  std::vector<swarm::Message> outbox;
  // Per neighbour: threat reports it sent that this agent will never receive (lock-step).
  std::vector<std::int64_t> reports_never_coming(static_cast<std::size_t>(n), 0);
  for (;;) {
    if (first && seconds_since(last_hello) > 0.1) {
      link.publish(hello);
      last_hello = Clock::now();
    }
    link.wait(first ? 0.05 : 0.5);
    clocks.clear();
    link.take(clocks);
    bool stop = false;
    for (const auto& c : clocks) {
      stop = stop || !c.running;
      if (c.tick >= latest_clock.tick) latest_clock = c;
    }
    if (stop) {
      result.world_stopped = true;
      break;
    }
    measurements.clear();
    link.take(measurements, id);
    if (measurements.empty()) {
      if (seconds_since(last_heard) > options.silence_timeout_s) {
        result.message =
            fmt::format("no measurement from the world for {} s", options.silence_timeout_s);
        break;
      }
      continue;
    }
    const bool joining = first && measurements.back().tick > 0;
    first = false;
    last_heard = Clock::now();
    // Behind (real time): only the newest measurement is worth answering.
    const transport_dds::Measurement& m = measurements.back();
    const auto taken = Clock::now();
    if (latest_clock.lock_step) {
      // Lock-step: the clock of this tick says which neighbours answered the previous one and
      // what they had published by then; wait for it all (bounded: a sample lost on the way
      // costs a wait, never a deadlock), so the run does not depend on delivery timing.
      auto missing_reports = [&](std::size_t k) {
        const int j = latest_clock.answered[k];
        return latest_clock.reports_sent[k] -
               (transport.reports_taken(j) + reports_never_coming[static_cast<std::size_t>(j)]);
      };
      auto complete = [&] {
        if (latest_clock.tick < m.tick) return false;
        // Joining a running mission: what the neighbours sent before this agent's readers
        // matched can never arrive (volatile durability), so only the clock is awaited.
        if (joining) return true;
        for (std::size_t k = 0; k < latest_clock.answered.size(); ++k) {
          const int j = latest_clock.answered[k];
          if (j == id) continue;
          if (transport.newest_prediction_stamp(j) < latest_clock.prediction_stamps[k] ||
              missing_reports(k) > 0)
            return false;
        }
        return true;
      };
      const auto wait_start = Clock::now();
      while (!complete() && seconds_since(wait_start) < options.lock_step_wait_s) {
        clocks.clear();
        link.take(clocks);
        for (const auto& c : clocks)
          if (c.tick >= latest_clock.tick) latest_clock = c;
        transport.poll(m.t_s);
        if (!complete()) std::this_thread::sleep_for(std::chrono::microseconds(20));
      }
      if (!complete()) ++result.lock_step_timeouts;
      // From here on, wait only for reports sent after this point: a report that did not come
      // (sent before this agent joined, or lost) must cost one wait, not one every tick.
      if (latest_clock.tick >= m.tick)
        for (std::size_t k = 0; k < latest_clock.answered.size(); ++k) {
          const int j = latest_clock.answered[k];
          if (j != id && missing_reports(k) > 0)
            reports_never_coming[static_cast<std::size_t>(j)] += missing_reports(k);
        }
    }

    received.clear();
    plans.take(received, id);
    for (const messages::ReferencePlan& p : received) {
      if (p.version <= plan.version) continue;
      inspected_before += agent->targets_inspected();
      plan = p;
      agent = make_agent(scenario, id, plan, terrain);
      result.plan_version = plan.version;
    }
    inbox.clear();
    transport.receive(id, m.t_s, inbox);
    for (const swarm::Envelope& e : inbox)
      // Plans reach the agent through the plan link (full reference samples, versions).
      if (!std::holds_alternative<swarm::ReferencePlan>(e.message())) agent->receive(e);
    outbox.clear();
    agent->sense(m.t_s, m.threats, outbox);
    for (const swarm::Message& msg : outbox) transport.publish(id, m.t_s, msg);
    const swarm::AgentStep step = agent->control(m.t_s, m.state, m.wind_m_s);
    transport.publish(id, m.t_s, agent->prediction_message());

    transport_dds::CommandReport a;
    a.uav = id;
    a.tick = m.tick;
    a.t_s = m.t_s;
    a.command = step.command;
    a.mode = step.mode;
    a.reference_m = step.reference_m;
    a.has_tracker = step.tracker != nullptr;
    if (step.tracker != nullptr) {
      a.mpc_step_us = step.tracker->step_time_us;
      a.mpc_step_cpu_us = step.tracker->step_cpu_time_us;
      a.qp_iterations = step.tracker->qp_iterations;
    }
    a.max_slack_m = step.max_slack_m;
    a.plan_version = plan.version;
    a.targets_assigned = inspected_before + static_cast<int>(plan.target_ids.size());
    a.targets_inspected = inspected_before + agent->targets_inspected();
    a.missed_targets = agent->missed_targets();
    a.counters = agent->counters();
    const swarm::TransportStats ts = transport.stats();
    a.counters.messages_rejected += ts.rejected + link.stats().rejected + plans.rejected();
    a.prediction_stamp_s = agent->prediction().stamp_s;
    a.loop_period_s = last_answer == Clock::time_point{}
                          ? 0.0
                          : std::chrono::duration<double>(taken - last_answer).count();
    last_answer = taken;
    a.compute_s = seconds_since(taken);
    link.publish(a);
    ++result.steps;
  }
  result.rejected =
      static_cast<long long>(agent->counters().messages_rejected + transport.stats().rejected +
                             link.stats().rejected + plans.rejected());
  result.dropped = static_cast<long long>(transport.stats().dropped);
  return result;
}

}  // namespace ridgeline::nodes
