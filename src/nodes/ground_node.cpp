#include "nodes/ground_node.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <set>
#include <thread>

#include "core/error.hpp"
#include "mission/stage_inputs.hpp"
#include "transport_dds/dds_transport.hpp"
#include "transport_dds/plan_link.hpp"
#include "transport_dds/sim_link.hpp"

namespace ridgeline::nodes {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

messages::ReferencePlan hold_plan(int uav, const Vec3& position_m, double heading_rad,
                                     double t_s, int version) {
  messages::ReferencePlan p;
  p.uav = uav;
  p.version = version;
  p.stamp_s = std::max(0.0, t_s);
  mpc::ReferencePoint hold;
  hold.position_m = position_m;
  hold.heading_rad = heading_rad;
  p.times_s = {t_s - 1.0, t_s};
  p.points = {hold, hold};
  return p;
}

messages::ReferencePlan plan_message(int uav, const planning::UavPlan& up, double shift_s,
                                        int version, double stamp_s) {
  messages::ReferencePlan p;
  p.uav = uav;
  p.version = version;
  p.stamp_s = stamp_s;
  for (const double t : up.timing.sample_times_s) p.times_s.push_back(t + shift_s);
  p.points = up.timing.samples;
  return p;
}

}  // namespace

GroundNodeResult run_ground_node(const mission::Scenario& scenario,
                                 std::shared_ptr<const world::Terrain> terrain,
                                 const planning::GlobalPlan& plan,
                                 const transport_dds::DdsOptions& dds,
                                 const GroundNodeOptions& options) {
  if (plan.status != planning::GlobalPlanStatus::kPlanned)
    throw InputError("plan", "is not planned: " + plan.message);
  const int n = static_cast<int>(scenario.uavs.size());
  const int num_targets = static_cast<int>(scenario.targets.size());
  auto participant = std::make_shared<transport_dds::DdsParticipant>(dds);
  transport_dds::PlanLink plans(participant, n, num_targets, true);
  transport_dds::SimLink link(participant, n, transport_dds::observer_role());
  transport_dds::DdsTransportOptions to;
  to.participant_id = n;  // the ground station
  to.num_uavs = n;
  transport_dds::DdsTransport transport(participant, to);
  GroundNodeResult result;

  // Version 0: the global plan.
  std::vector<messages::ReferencePlan> current(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const mission::UavSpec& u = scenario.uavs[static_cast<std::size_t>(i)];
    const auto it = std::find_if(plan.uavs.begin(), plan.uavs.end(),
                                 [&](const planning::UavPlan& up) { return up.name == u.name; });
    messages::ReferencePlan p;
    if (it == plan.uavs.end() || !it->timing.reference) {
      p = hold_plan(i, u.start_position_m, u.start_heading_rad, 0.0, 0);
    } else {
      p = plan_message(i, *it, 0.0, 0, 0.0);
      p.target_ids = it->targets;
    }
    plans.publish(p);
    current[static_cast<std::size_t>(i)] = std::move(p);
  }

  std::vector<transport_dds::Measurement> last_measurement(static_cast<std::size_t>(n));
  std::vector<transport_dds::CommandReport> last_answer(static_cast<std::size_t>(n));
  std::vector<bool> has_answer(static_cast<std::size_t>(n), false);
  std::set<int> lost;
  std::vector<transport_dds::ClockTick> clocks;
  std::vector<transport_dds::Measurement> measurements;
  std::vector<transport_dds::CommandReport> answers;
  std::vector<swarm::Envelope> ignored;
  double t = 0.0;
  bool ticking = false;
  auto last_tick = Clock::now();
  const auto start = Clock::now();
  for (;;) {
    link.wait(0.2);
    clocks.clear();
    link.take(clocks);
    measurements.clear();
    link.take(measurements);
    for (auto& m : measurements) last_measurement[static_cast<std::size_t>(m.uav)] = m;
    answers.clear();
    link.take(answers);
    for (auto& a : answers)
      if (!a.hello) {
        last_answer[static_cast<std::size_t>(a.uav)] = a;
        has_answer[static_cast<std::size_t>(a.uav)] = true;
      }
    transport.receive(n, t, ignored);  // keeps the reader's history drained
    ignored.clear();
    bool stop = false;
    std::vector<int> newly_lost;
    for (const auto& c : clocks) {
      ticking = true;
      last_tick = Clock::now();
      t = std::max(t, c.t_s);
      stop = stop || !c.running;
      for (const int i : c.lost)
        if (lost.insert(i).second) newly_lost.push_back(i);
    }
    if (stop) {
      result.world_stopped = true;
      break;
    }
    if (!ticking && seconds_since(start) > options.start_timeout_s) {
      result.message = fmt::format("no clock from the world within {} s", options.start_timeout_s);
      break;
    }
    if (ticking && seconds_since(last_tick) > options.silence_timeout_s) {
      result.message = fmt::format("the world's clock stopped for {} s", options.silence_timeout_s);
      break;
    }
    // The lost UAVs' autopilots hold: tell the team where (a stationary prediction).
    if (!clocks.empty()) {
      for (const int i : lost) {
        const transport_dds::Measurement& m = last_measurement[static_cast<std::size_t>(i)];
        if (m.uav != i) continue;
        swarm::PredictedTrajectory p;
        p.uav = i;
        p.stamp_s = t;
        p.step_s = scenario.mpc.prediction_step_s;
        p.positions_m.assign(static_cast<std::size_t>(scenario.mpc.horizon_steps),
                             m.state.head<3>());
        transport.publish(n, t, p);
      }
    }
    if (newly_lost.empty() || !options.reallocate) continue;

    // Re-allocate every open target over the survivors.
    const auto plan_start = Clock::now();
    std::vector<int> open;
    for (int i = 0; i < n; ++i) {
      const messages::ReferencePlan& p = current[static_cast<std::size_t>(i)];
      int done_in_plan = 0;
      if (has_answer[static_cast<std::size_t>(i)]) {
        const transport_dds::CommandReport& a = last_answer[static_cast<std::size_t>(i)];
        if (a.plan_version == p.version)
          done_in_plan =
              static_cast<int>(p.target_ids.size()) - (a.targets_assigned - a.targets_inspected);
      }
      for (std::size_t k = static_cast<std::size_t>(std::max(0, done_in_plan));
           k < p.target_ids.size(); ++k)
        open.push_back(p.target_ids[k]);
    }
    for (const int lost_uav : newly_lost) {
      Reallocation r;
      r.t_s = t;
      r.lost_uav = scenario.uavs[static_cast<std::size_t>(lost_uav)].name;
      for (const int k : open)
        r.open_targets.push_back(scenario.targets[static_cast<std::size_t>(k)].name);
      result.reallocations.push_back(r);
    }
    Reallocation& r = result.reallocations.back();
    if (open.empty()) {
      r.status = "nothing to re-allocate";
      continue;
    }
    const planning::GlobalPlanningProblem problem_all =
        mission::make_planning_problem(scenario, terrain);
    planning::GlobalPlanningProblem problem = problem_all;
    std::vector<int> survivors;
    problem.uavs.clear();
    for (int i = 0; i < n; ++i) {
      if (lost.count(i) != 0) continue;
      const transport_dds::Measurement& m = last_measurement[static_cast<std::size_t>(i)];
      if (m.uav != i) continue;  // never measured: its agent has not started
      planning::PlannerUav pu;
      pu.name = scenario.uavs[static_cast<std::size_t>(i)].name;
      pu.start_m = m.state.head<3>();
      pu.start_heading_rad = m.state[vehicle::kPsi];
      pu.vehicle = scenario.uavs[static_cast<std::size_t>(i)].vehicle;
      // A survivor keeps its end and its own open targets; the lost UAV's become anyone's.
      pu.end_m = scenario.uavs[static_cast<std::size_t>(i)].end_position_m;
      for (std::size_t k = 0; k < open.size(); ++k)
        for (const int required : problem_all.uavs[static_cast<std::size_t>(i)].required_targets)
          if (required == open[k]) pu.required_targets.push_back(static_cast<int>(k));
      problem.uavs.push_back(pu);
      survivors.push_back(i);
    }
    std::vector<planning::AllocationTarget> all_targets = problem.targets;
    problem.targets.clear();
    for (const int k : open) problem.targets.push_back(all_targets[static_cast<std::size_t>(k)]);
    const planning::GlobalPlannerOptions po = mission::make_planner_options(scenario);
    const planning::GlobalPlan replan =
        survivors.empty() ? planning::GlobalPlan{} : planning::plan_mission(problem, po);
    r.plan_time_s = seconds_since(plan_start);
    if (survivors.empty() || replan.status != planning::GlobalPlanStatus::kPlanned) {
      r.status =
          survivors.empty()
              ? "no surviving UAV"
              : fmt::format("failed ({}): {}", planning::to_string(replan.status), replan.message);
      continue;
    }
    r.status = "planned";
    for (std::size_t s = 0; s < survivors.size(); ++s) {
      const int i = survivors[s];
      const std::string& name = scenario.uavs[static_cast<std::size_t>(i)].name;
      const auto it = std::find_if(replan.uavs.begin(), replan.uavs.end(),
                                   [&](const planning::UavPlan& up) { return up.name == name; });
      const int version = current[static_cast<std::size_t>(i)].version + 1;
      messages::ReferencePlan p;
      std::vector<std::string> names;
      if (it == replan.uavs.end() || !it->timing.reference) {
        const transport_dds::Measurement& m = last_measurement[static_cast<std::size_t>(i)];
        p = hold_plan(i, m.state.head<3>(), m.state[vehicle::kPsi], t, version);
      } else {
        p = plan_message(i, *it, t, version, t);
        for (const int k : it->targets) {
          p.target_ids.push_back(open[static_cast<std::size_t>(k)]);
          names.push_back(
              scenario.targets[static_cast<std::size_t>(open[static_cast<std::size_t>(k)])].name);
        }
      }
      plans.publish(p);
      current[static_cast<std::size_t>(i)] = std::move(p);
      r.assignment.push_back({name, names});
    }
  }
  result.rejected =
      static_cast<long long>(link.stats().rejected + transport.stats().rejected + plans.rejected());
  return result;
}

}  // namespace ridgeline::nodes
