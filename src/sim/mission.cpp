#include "sim/mission.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/cpu_clock.hpp"
#include "core/error.hpp"
#include "core/random.hpp"
#include "mission/flight_recorder.hpp"
#include "mission/truth_world.hpp"
#include "mission/stage_inputs.hpp"
#include "swarm/in_process_transport.hpp"
#include "swarm/prediction_reach.hpp"

namespace ridgeline::sim {
namespace {

constexpr std::uint64_t kTransportStream = 21;

/// The truth's state of an external vehicle from its report: the model's airspeed along the
/// heading and climb rate are the reported ground velocity less the truth's wind (eq. 1).
vehicle::State state_from_vehicle(const VehicleReport& r, const Vec3& wind_m_s) {
  vehicle::State s = vehicle::State::Zero();
  s.head<3>() = r.position_m;
  s[vehicle::kPsi] = r.heading_rad;
  s[vehicle::kOmega] = r.turn_rate_rad_s;
  const Vec3 air = r.ground_velocity_m_s - wind_m_s;
  s[vehicle::kV] = air.x() * std::cos(r.heading_rad) + air.y() * std::sin(r.heading_rad);
  s[vehicle::kW] = air.z();
  return s;
}

}  // namespace

mission::MissionResult fly_mission(const mission::Scenario& scenario,
                                   std::shared_ptr<const world::Terrain> terrain,
                                   const planning::GlobalPlan& plan,
                                   const MissionOptions& options) {
  if (plan.status != planning::GlobalPlanStatus::kPlanned)
    throw InputError("plan", "is not planned: " + plan.message);
  const auto wall_start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_time_s();
  const int n = static_cast<int>(scenario.uavs.size());

  mission::TruthWorld world(scenario, terrain);
  // The plan names its UAVs; a UAV the allocation left without targets has no plan entry and
  // stays idle: its agent finishes at once and the UAV holds at its start (still broadcasting,
  // so the others keep their distance). The plans are read in place, not copied (each holds its
  // sampled reference).
  const planning::UavPlan no_plan;
  std::vector<const planning::UavPlan*> plans(static_cast<std::size_t>(n), &no_plan);
  for (const planning::UavPlan& up : plan.uavs) {
    const auto it = std::find_if(scenario.uavs.begin(), scenario.uavs.end(),
                                 [&](const mission::UavSpec& u) { return u.name == up.name; });
    if (it == scenario.uavs.end())
      throw InputError("plan.uavs", fmt::format("'{}' is not a UAV of the scenario", up.name));
    if (!up.timing.reference)
      throw InputError(fmt::format("plan.uavs.{}.reference", up.name), "is missing");
    plans[static_cast<std::size_t>(it - scenario.uavs.begin())] = &up;
  }
  // Predictions go at once only to the agents within reach (in_process_transport.hpp): the
  // proposed agents' reach (swarm/prediction_reach.hpp). The baselines get every broadcast.
  const swarm::LinkModel link{scenario.simulation.link_latency_s,
                              scenario.simulation.link_jitter_s, scenario.simulation.link_drop_rate};
  swarm::PredictionReach reach;
  if (options.method == Method::kProposed) {
    std::vector<swarm::AgentOptions> agent_options;
    for (int i = 0; i < n; ++i)
      agent_options.push_back(
          mission::make_agent_options(scenario, i, *plans[static_cast<std::size_t>(i)]));
    reach = swarm::prediction_reach(agent_options, scenario.safety, link,
                                    1.0 / scenario.simulation.message_rate_hz);
  }
  swarm::InProcessTransport transport(n, link, derive_seed(scenario.seed, kTransportStream), reach);
  std::vector<std::unique_ptr<swarm::UavAgent>> agents;
  for (int i = 0; i < n; ++i) {
    const planning::UavPlan& up = *plans[static_cast<std::size_t>(i)];
    std::shared_ptr<const mpc::SampledReference> reference;
    if (up.timing.reference) {
      reference = std::make_shared<const mpc::SampledReference>(*up.timing.reference);
    } else {
      const mission::UavSpec& u = scenario.uavs[static_cast<std::size_t>(i)];
      mpc::ReferencePoint hold;
      hold.position_m = u.start_position_m;
      hold.heading_rad = u.start_heading_rad;
      reference = std::make_shared<const mpc::SampledReference>(
          std::vector<double>{-1.0, 0.0}, std::vector<mpc::ReferencePoint>{hold, hold});
    }
    agents.push_back(make_agent(options.method, scenario, i, up, std::move(reference), terrain,
                                options.ddpg_policy));
  }

  // External vehicles: the truth's states come from their reports (applied when the mission
  // reaches the time they were reported for); a finished UAV's vehicle is told to hold.
  ExternalVehicles* const vehicles = options.vehicles;
  std::vector<VehicleReport> reports;
  std::vector<VehicleCommand> vehicle_commands(static_cast<std::size_t>(n));
  double reports_time_s = 0.0;
  bool reports_pending = false;
  auto apply_reports = [&] {
    for (int i = 0; i < n; ++i) {
      const VehicleReport& r = reports[static_cast<std::size_t>(i)];
      if (world.holding(i)) {
        vehicle::State s = world.true_state(i);
        s.head<3>() = r.position_m;
        world.set_state(i, s);
      } else {
        world.set_state(i, state_from_vehicle(r, world.wind().at(r.position_m, world.time_s())));
      }
    }
    reports_pending = false;
  };
  if (vehicles != nullptr) {
    world.set_external_dynamics();
    vehicles->start(reports);
    if (reports.size() != static_cast<std::size_t>(n))
      throw std::runtime_error(fmt::format("external vehicles: {} reports for {} UAVs",
                                           reports.size(), n));
    for (int i = 0; i < n; ++i) {
      // A vehicle elsewhere than its UAV's start flies another mission (another scenario,
      // UAV index or home altitude): refuse it rather than measure a different flight.
      const Vec3 start = scenario.uavs[static_cast<std::size_t>(i)].start_position_m;
      const Vec3 at = reports[static_cast<std::size_t>(i)].position_m;
      if ((at - start).norm() > 1.0)
        throw std::runtime_error(fmt::format(
            "{}: its vehicle starts at ({:.1f}, {:.1f}, {:.1f}) m, not at the scenario's start "
            "({:.1f}, {:.1f}, {:.1f}) m (another scenario, UAV or home altitude?)",
            scenario.uavs[static_cast<std::size_t>(i)].name, at.x(), at.y(), at.z(), start.x(),
            start.y(), start.z()));
    }
    apply_reports();
  }

  mission::FlightRecorder recorder(scenario, *terrain, world, options.record_trajectories);
  std::vector<double> finish_time(static_cast<std::size_t>(n), -1.0);

  const double tick_s = 1.0 / scenario.simulation.message_rate_hz;
  const double control_s = scenario.mpc.control_period_s;
  const double duration = scenario.simulation.duration_s;
  std::vector<swarm::Envelope> inbox;
  std::vector<swarm::Message> outbox;
  std::vector<int> sensed;
  std::vector<swarm::ThreatObservation> observations;
  double next_control_s = 0.0;
  long long control_steps = 0;
  double next_progress_s = 0.0;
  double t = 0.0;
  for (long long tick = 0;; ++tick) {
    t = static_cast<double>(tick) * tick_s;
    if (t > duration + 1e-9) break;
    world.advance_to(t);
    if (reports_pending && t >= reports_time_s - 1e-9) apply_reports();
    if (options.progress && t >= next_progress_s) {
      options.progress(t, duration);
      next_progress_s += 1.0;
    }
    for (int i = 0; i < n; ++i) {
      inbox.clear();
      transport.receive(i, t, inbox);
      for (const swarm::Envelope& e : inbox) agents[static_cast<std::size_t>(i)]->receive(e);
    }

    const bool control_tick = t >= next_control_s - 1e-9;
    if (control_tick) {
      next_control_s += control_s;
      for (int i = 0; i < n; ++i) {
        swarm::UavAgent& agent = *agents[static_cast<std::size_t>(i)];
        // Sensing: the truth's threats within this UAV's range.
        world.sensed_threats(i, sensed);
        observations.clear();
        for (const int k : sensed) {
          const world::Threat& th = world.threats()[static_cast<std::size_t>(k)];
          observations.push_back({k, th.centre_at(t), th.velocity_m_s, th.radius_m});
          recorder.sensed(i, k, t, world);
        }
        outbox.clear();
        agent.sense(t, observations, outbox);
        for (const swarm::Message& msg : outbox) transport.publish(i, t, msg);

        const bool was_finished = agent.finished();
        const vehicle::State measured = world.measured_state(i);
        const Vec3 wind = world.measured_wind(i);
        const swarm::AgentStep step = agent.control(t, measured, wind);
        if (step.mode == swarm::AgentMode::kFinished) {
          if (!was_finished) {
            world.hold(i);
            finish_time[static_cast<std::size_t>(i)] = t;
          }
          vehicle_commands[static_cast<std::size_t>(i)].hold = true;
        } else {
          world.set_command(i, step.command);
          vehicle_commands[static_cast<std::size_t>(i)] = {step.command, false};
        }
        mission::ControlReport report;
        report.finished = agent.finished();
        report.reference_m = step.reference_m;
        report.command = step.command;
        report.has_tracker = step.tracker != nullptr;
        if (step.tracker != nullptr) {
          report.mpc_step_us = step.tracker->step_time_us;
          report.mpc_step_cpu_us = step.tracker->step_cpu_time_us;
          report.qp_iterations = step.tracker->qp_iterations;
        }
        report.step_time_us = step.step_time_us;
        report.max_slack_m = step.max_slack_m;
        recorder.control_step(i, t, world, report);
      }
      if (vehicles != nullptr) {
        vehicles->step(control_steps, t, vehicle_commands, reports);
        reports_time_s = t + control_s;
        reports_pending = true;
      }
      ++control_steps;
    }

    // Broadcast (every tick) and the truth's distances (every tick).
    for (int i = 0; i < n; ++i)
      transport.publish(i, t, agents[static_cast<std::size_t>(i)]->prediction_message());
    recorder.tick(t, world);
    bool all_finished = true;
    for (const auto& a : agents) all_finished = all_finished && a->finished();
    if (all_finished) break;
  }

  std::vector<mission::UavOutcome> outcomes(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const swarm::UavAgent& a = *agents[static_cast<std::size_t>(i)];
    mission::UavOutcome& o = outcomes[static_cast<std::size_t>(i)];
    o.targets_assigned = static_cast<int>(plans[static_cast<std::size_t>(i)]->targets.size());
    o.targets_inspected = a.targets_inspected();
    o.missed_targets = a.missed_targets();
    o.finished = a.finished();
    o.finish_time_s = finish_time[static_cast<std::size_t>(i)];
    o.counters = a.counters();
  }
  mission::MissionResult result = recorder.finish(t, outcomes);
  mission::MissionMetrics& m = result.metrics;
  m.global_plan_s = plan.total_time_s;
  const swarm::TransportStats stats = transport.stats();
  m.messages_published = static_cast<long long>(stats.published);
  m.messages_dropped = static_cast<long long>(stats.dropped);
  m.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  m.cpu_time_s = thread_cpu_time_s() - cpu_start_s;
  return result;
}

}  // namespace ridgeline::sim
