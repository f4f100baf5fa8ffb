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
#include "sim/safety_tally.hpp"
#include "sim/truth_world.hpp"
#include "baselines/ddpg_agent.hpp"
#include "baselines/dwa_agent.hpp"
#include "baselines/pursuit_agent.hpp"
#include "swarm/in_process_transport.hpp"

namespace ridgeline::sim {
namespace {

constexpr std::uint64_t kTransportStream = 21;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTrackingSampleSpacingM = 10.0;  // DESIGN §6: every 10 m of flown path

/// Running metrics of one UAV.
struct UavTally {
  Vec3 last_position = Vec3::Zero();
  double path_m = 0.0;
  double next_sample_m = 0.0;
  double squared_error_sum = 0.0;
  int samples = 0;
  double max_slack_m = 0.0;
};

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

mpc::UavTrackerOptions make_tracker_options(const Scenario& scenario, const UavSpec& uav) {
  const MpcConfig& m = scenario.mpc;
  mpc::UavTrackerOptions o;
  o.vehicle = uav.vehicle;
  o.control_period_s = m.control_period_s;
  o.prediction_step_s = m.prediction_step_s;
  o.prediction_horizon = m.horizon_steps;
  o.control_horizon = m.control_horizon_steps;
  o.weight_xy_per_m2 = m.position_weight;
  o.weight_z_per_m2 = m.position_weight;
  o.weight_speed_move = m.move_weights[0];
  o.weight_turn_move = m.move_weights[1];
  o.weight_climb_move = m.move_weights[2];
  o.max_speed_cmd_rate_m_s2 = m.max_moves[0] / m.prediction_step_s;
  o.max_turn_cmd_rate_rad_s2 = m.max_moves[1] / m.prediction_step_s;
  o.max_climb_cmd_rate_m_s2 = m.max_moves[2] / m.prediction_step_s;
  o.slack_linear_weight = m.slack_weight;
  // The anemometer's error: 3σ of its noise bounds it with 99.7 % per component.
  o.wind_error_bound_m_s = std::max(0.1, 3.0 * scenario.wind.measurement_noise_m_s);
  o.max_threats = std::max<int>(4, static_cast<int>(scenario.threats.size()));
  o.max_neighbours = std::clamp<int>(static_cast<int>(scenario.uavs.size()) - 1, 1, 8);
  return o;
}

swarm::AgentOptions make_agent_options(const Scenario& scenario, int index,
                                       const planning::UavPlan& plan) {
  const UavSpec& uav = scenario.uavs[static_cast<std::size_t>(index)];
  swarm::AgentOptions o;
  o.id = index;
  o.num_uavs = static_cast<int>(scenario.uavs.size());
  o.tracker = make_tracker_options(scenario, uav);
  for (const int k : plan.targets) {
    const InspectionTarget& t = scenario.targets.at(static_cast<std::size_t>(k));
    o.targets.push_back({t.name, t.position_m, t.inspection_radius_m, t.inspection_radius_m});
  }
  o.broadcast_period_s = 1.0 / scenario.simulation.message_rate_hz;
  o.detour.max_climb_rate_m_s = uav.vehicle.max_climb_rate_m_s;
  o.optimizer_replan = scenario.planner.optimizer_replan;
  return o;
}

baselines::BaselineAgentOptions make_baseline_agent_options(const Scenario& scenario, int index,
                                                            const planning::UavPlan& plan) {
  const UavSpec& uav = scenario.uavs[static_cast<std::size_t>(index)];
  baselines::BaselineAgentOptions o;
  o.id = index;
  o.num_uavs = static_cast<int>(scenario.uavs.size());
  o.vehicle = uav.vehicle;
  for (const int k : plan.targets) {
    const InspectionTarget& t = scenario.targets.at(static_cast<std::size_t>(k));
    o.targets.push_back({t.name, t.position_m, t.inspection_radius_m, t.inspection_radius_m});
  }
  o.control_period_s = scenario.mpc.control_period_s;
  o.prediction_step_s = scenario.mpc.prediction_step_s;
  o.prediction_steps = scenario.mpc.horizon_steps;
  // The proposed tracker's command-rate limits (max_moves per prediction step).
  o.max_command_rate = scenario.mpc.max_moves / scenario.mpc.prediction_step_s;
  return o;
}

MissionResult fly_mission(const Scenario& scenario, std::shared_ptr<const world::Terrain> terrain,
                          const planning::GlobalPlan& plan, const MissionOptions& options) {
  if (plan.status != planning::GlobalPlanStatus::kPlanned)
    throw InputError("plan", "is not planned: " + plan.message);
  const auto wall_start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_time_s();
  const int n = static_cast<int>(scenario.uavs.size());

  TruthWorld world(scenario, terrain);
  swarm::InProcessTransport transport(
      n,
      swarm::LinkModel{scenario.simulation.link_latency_s, scenario.simulation.link_jitter_s,
                       scenario.simulation.link_drop_rate},
      derive_seed(scenario.seed, kTransportStream));
  // The plan names its UAVs; a UAV the allocation left without targets has no plan entry and
  // stays idle: its agent finishes at once and the UAV holds at its start (still broadcasting,
  // so the others keep their distance).
  std::vector<planning::UavPlan> plans(static_cast<std::size_t>(n));
  for (const planning::UavPlan& up : plan.uavs) {
    const auto it = std::find_if(scenario.uavs.begin(), scenario.uavs.end(),
                                 [&](const UavSpec& u) { return u.name == up.name; });
    if (it == scenario.uavs.end())
      throw InputError("plan.uavs", fmt::format("'{}' is not a UAV of the scenario", up.name));
    if (!up.timing.reference)
      throw InputError(fmt::format("plan.uavs.{}.reference", up.name), "is missing");
    plans[static_cast<std::size_t>(it - scenario.uavs.begin())] = up;
  }
  std::vector<std::unique_ptr<swarm::UavAgent>> agents;
  for (int i = 0; i < n; ++i) {
    const planning::UavPlan& up = plans[static_cast<std::size_t>(i)];
    std::shared_ptr<const mpc::SampledReference> reference;
    if (up.timing.reference) {
      reference = std::make_shared<const mpc::SampledReference>(*up.timing.reference);
    } else {
      const UavSpec& u = scenario.uavs[static_cast<std::size_t>(i)];
      mpc::ReferencePoint hold;
      hold.position_m = u.start_position_m;
      hold.heading_rad = u.start_heading_rad;
      reference = std::make_shared<const mpc::SampledReference>(
          std::vector<double>{-1.0, 0.0}, std::vector<mpc::ReferencePoint>{hold, hold});
    }
    switch (options.method) {
      case Method::kProposed:
        agents.push_back(std::make_unique<swarm::Agent>(
            make_agent_options(scenario, i, up), scenario.safety, std::move(reference), terrain));
        break;
      case Method::kAstarDwa:
        agents.push_back(std::make_unique<baselines::DwaAgent>(
            make_baseline_agent_options(scenario, i, up), scenario.safety, baselines::DwaOptions{},
            std::move(reference), terrain));
        break;
      case Method::kWindAware:
        agents.push_back(std::make_unique<baselines::PursuitAgent>(
            make_baseline_agent_options(scenario, i, up), scenario.safety,
            baselines::PursuitOptions{}, std::move(reference), terrain));
        break;
      case Method::kDdpg:
        if (!options.ddpg_policy)
          throw InputError("--ddpg-model", "method ddpg needs a DDPG model (none loaded)");
        agents.push_back(std::make_unique<baselines::DdpgAgent>(
            make_baseline_agent_options(scenario, i, up), scenario.safety, options.ddpg_policy,
            std::move(reference), terrain));
        break;
    }
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

  MissionResult result;
  MissionMetrics& m = result.metrics;
  m.global_plan_s = plan.total_time_s;
  std::vector<UavTally> tally(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    tally[static_cast<std::size_t>(i)].last_position = world.true_position(i);
  std::vector<double> step_us, step_cpu_us, iterations;
  SafetyTally safety(scenario.safety, static_cast<int>(scenario.uavs.size()), *terrain);
  for (const char* kind : {"altitude", "pitch", "turn"}) m.constraint_violations[kind] = 0;
  double min_turn_radius = kInf;
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
        UavTally& u = tally[static_cast<std::size_t>(i)];
        // Sensing: the truth's threats within this UAV's range.
        world.sensed_threats(i, sensed);
        observations.clear();
        for (const int k : sensed) {
          const world::Threat& th = world.threats()[static_cast<std::size_t>(k)];
          observations.push_back({k, th.centre_at(t), th.velocity_m_s, th.radius_m});
          safety.sensed(i, k);
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
          if (step.tracker != nullptr) {
            step_us.push_back(step.tracker->step_time_us);
            step_cpu_us.push_back(step.tracker->step_cpu_time_us);
            iterations.push_back(step.tracker->qp_iterations);
          } else if (step.step_time_us >= 0.0) {
            step_us.push_back(step.step_time_us);
          }
          u.max_slack_m = std::max(u.max_slack_m, step.max_slack_m);
        }

        const vehicle::State& s = world.true_state(i);
        const Vec3 p = s.head<3>();
        u.path_m += (p - u.last_position).norm();
        u.last_position = p;
        if (!agent.finished() && u.path_m >= u.next_sample_m) {
          u.squared_error_sum += (p - step.reference_m).squaredNorm();
          ++u.samples;
          u.next_sample_m += kTrackingSampleSpacingM;
        }
        if (!world.holding(i)) {
          const vehicle::VehicleParams& vp = scenario.uavs[static_cast<std::size_t>(i)].vehicle;
          if (p.z() < scenario.safety.altitude.min_m || p.z() > scenario.safety.altitude.max_m)
            ++m.constraint_violations["altitude"];
          if (std::abs(vehicle::pitch_angle_rad(s)) > vp.max_pitch_rad + 1e-3)
            ++m.constraint_violations["pitch"];
          // Eq. 3 bounds the command: |ω_c| ≤ v/R_min at the speed the vehicle has when the
          // command is issued. The flown radius v/|ω| is reported too (it includes the lags).
          if (!agent.finished()) {
            const double limit = vp.max_turn_rate_rad_s(s[vehicle::kV]);
            const double ratio = std::abs(step.command[1]) / limit;
            m.max_turn_command_ratio = std::max(m.max_turn_command_ratio, ratio);
            if (ratio > 1.0 + 1e-6) ++m.constraint_violations["turn"];
          }
          if (std::abs(s[vehicle::kOmega]) > 1e-9)
            min_turn_radius =
                std::min(min_turn_radius, s[vehicle::kV] / std::abs(s[vehicle::kOmega]));
        }
        if (options.record_trajectories) {
          result.trajectories.push_back(
              {t, i, p, step.reference_m, s[vehicle::kV], s[vehicle::kPsi], s[vehicle::kW]});
        }
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
    safety.sample(t, world);
    bool all_finished = true;
    for (const auto& a : agents) all_finished = all_finished && a->finished();
    if (all_finished) break;
  }

  m.sim_time_s = t;
  m.min_turn_radius_m = min_turn_radius;
  m.mpc_solve_us = percentiles(step_us);
  m.mpc_solve_cpu_us = percentiles(step_cpu_us);
  m.qp_iterations = percentiles(iterations);
  m.mission_complete = true;
  for (int i = 0; i < n; ++i) {
    const swarm::UavAgent& a = *agents[static_cast<std::size_t>(i)];
    const UavTally& u = tally[static_cast<std::size_t>(i)];
    UavMetrics um;
    um.name = scenario.uavs[static_cast<std::size_t>(i)].name;
    um.path_length_m = u.path_m;
    um.tracking_samples = u.samples;
    um.tracking_mse_m2 = u.samples > 0 ? u.squared_error_sum / u.samples : 0.0;
    um.tracking_rmse_m = std::sqrt(um.tracking_mse_m2);
    um.targets_assigned = static_cast<int>(plans[static_cast<std::size_t>(i)].targets.size());
    um.targets_inspected = a.targets_inspected();
    um.missed_targets = a.missed_targets();
    um.finished = a.finished();
    um.finish_time_s = finish_time[static_cast<std::size_t>(i)];
    const swarm::AgentCounters& c = a.counters();
    um.replans = static_cast<long long>(c.replans);
    um.optimizer_replans = static_cast<long long>(c.optimizer_replans);
    um.neighbour_conflicts = static_cast<long long>(c.neighbour_conflicts);
    um.replan_failures = static_cast<long long>(c.replan_failures);
    um.rejoins = static_cast<long long>(c.rejoins);
    um.fallback_steps = static_cast<long long>(c.fallback_steps);
    um.qp_failures = static_cast<long long>(c.qp_failures);
    um.stale_neighbour_steps = static_cast<long long>(c.stale_neighbour_steps);
    um.messages_rejected = static_cast<long long>(c.messages_rejected);
    um.max_slack_m = u.max_slack_m;
    m.mission_complete =
        m.mission_complete && um.finished && um.targets_inspected == um.targets_assigned;
    m.uavs.push_back(std::move(um));
  }
  safety.write(m);
  const swarm::TransportStats stats = transport.stats();
  m.messages_published = static_cast<long long>(stats.published);
  m.messages_dropped = static_cast<long long>(stats.dropped);
  m.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  m.cpu_time_s = thread_cpu_time_s() - cpu_start_s;
  return result;
}

std::string trajectories_csv(const std::vector<TrajectoryRow>& rows, const Scenario& scenario) {
  std::string out = "t,uav,x,y,z,ref_x,ref_y,ref_z,v,psi,w\n";
  out.reserve(rows.size() * 96);
  for (const TrajectoryRow& r : rows) {
    out += fmt::format("{:.2f},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.4f},{:.3f}\n",
                       r.t_s, scenario.uavs[static_cast<std::size_t>(r.uav)].name, r.position_m.x(),
                       r.position_m.y(), r.position_m.z(), r.reference_m.x(), r.reference_m.y(),
                       r.reference_m.z(), r.speed_m_s, r.heading_rad, r.climb_rate_m_s);
  }
  return out;
}

}  // namespace ridgeline::sim
