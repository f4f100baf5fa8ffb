// The DDPG agent (baselines/ddpg_agent.hpp): on board it builds exactly the observation the
// training environment builds (learning::make_observation) from its fix, its filtered wind,
// its current target, the threats it sensed and its neighbours' broadcasts (radius d_safe);
// its command is the policy's action mapped to the limits and rate-limited like every method's;
// it moves on to the next target once one is inspected; without a policy it is a clear error.
#include "baselines/ddpg_agent.hpp"

#include <gtest/gtest.h>

#include "core/error.hpp"

namespace ridgeline::baselines {
namespace {

std::shared_ptr<const learning::DdpgPolicy> some_policy() {
  // A policy with trained (not initial) weights, from a short seeded run on the flat task.
  learning::DdpgOptions o;
  o.hidden_units = 16;
  o.batch_size = 16;
  o.warmup_steps = 16;
  learning::DdpgTrainer trainer(o, learning::task_environment(learning::TrainingTask::kFlat));
  trainer.train(1);
  return std::make_shared<const learning::DdpgPolicy>(trainer.policy());
}

struct AgentSetup {
  BaselineAgentOptions options;
  std::shared_ptr<const mpc::SampledReference> reference;
  std::shared_ptr<const world::Terrain> terrain;
};

AgentSetup make_setup() {
  AgentSetup s;
  s.options.id = 0;
  s.options.num_uavs = 2;
  s.options.targets = {{"a", Vec3(400, 0, 100), 30.0, 30.0},
                       {"b", Vec3(400, 400, 120), 30.0, 30.0}};
  mpc::ReferencePoint p0, p1;
  p0.position_m = Vec3(0, 0, 100);
  p1.position_m = Vec3(400, 400, 120);
  s.reference = std::make_shared<const mpc::SampledReference>(
      std::vector<double>{0.0, 80.0}, std::vector<mpc::ReferencePoint>{p0, p1});
  world::PeakTerrainConfig c;
  c.peaks.push_back({200.0, 50.0, 60.0, 80.0, 80.0});
  s.terrain = std::make_shared<world::PeakTerrain>(c);
  return s;
}

TEST(DdpgAgent, ObservationIsTheEnvironmentsAndTheCommandThePolicys) {
  const AgentSetup s = make_setup();
  const auto policy = some_policy();
  DdpgAgent agent(s.options, world::SafetyLimits{}, policy, s.reference, s.terrain);
  std::vector<swarm::Message> outbox;
  const swarm::ThreatObservation seen{3, Vec3(150, -60, 100), Vec3(0, 4, 0), 35.0};
  agent.sense(1.0, std::span<const swarm::ThreatObservation>(&seen, 1), outbox);
  swarm::PredictedTrajectory neighbour;
  neighbour.uav = 1;
  neighbour.stamp_s = 1.0;
  neighbour.step_s = 0.1;
  for (int k = 1; k <= 40; ++k) neighbour.positions_m.push_back(Vec3(30.0 + k, 20.0, 100.0));
  agent.receive(swarm::Envelope{1, 1.0, 1.0, neighbour});

  vehicle::State state;
  state << 10, 5, 100, 0.2, 10, 0, 0;
  const Vec3 wind(1.0, -0.5, 0.1);
  const swarm::AgentStep step = agent.control(1.0, state, wind);

  learning::ObservationInput in;
  in.state = state;
  in.wind_m_s = wind;  // the first reading initializes the filter
  in.target_m = Vec3(400, 0, 100);
  in.terrain = s.terrain.get();
  in.obstacles.push_back({seen.centre_m, seen.velocity_m_s, seen.radius_m});
  // The neighbour at t = 1 s: its prediction starts at stamp + step, so at t it is the first
  // point; it moves 1 m per 0.1 s along x.
  in.obstacles.push_back({Vec3(31, 20, 100), Vec3(10, 0, 0), world::SafetyLimits{}.separation_m});
  const learning::Observation expected = learning::make_observation(in, s.options.vehicle);
  const learning::Observation got = agent.observe(1.0, state, wind);
  for (int k = 0; k < learning::kObservationSize; ++k)
    EXPECT_NEAR(got[static_cast<std::size_t>(k)], expected[static_cast<std::size_t>(k)], 1e-6) << k;

  // The command: the policy's action mapped to the limits, then one control period's rate
  // limit from the initial (cruise, 0, 0) and the maneuver limits.
  vehicle::Input wanted =
      learning::action_to_command(policy->act(expected), state, s.options.vehicle);
  const double climb_max = 0.9 * 10.0 * std::tan(s.options.vehicle.max_pitch_rad);
  wanted[2] = std::clamp(wanted[2], -climb_max, climb_max);
  const Vec3 max_change = s.options.max_command_rate * s.options.control_period_s;
  const vehicle::Input initial(s.options.vehicle.cruise_speed_m_s, 0.0, 0.0);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(step.command[i],
                std::clamp(wanted[i], initial[i] - max_change[i], initial[i] + max_change[i]), 1e-9)
        << i;
  EXPECT_EQ(step.mode, swarm::AgentMode::kTracking);
}

TEST(DdpgAgent, TargetsAreFlownInTurn) {
  const AgentSetup s = make_setup();
  DdpgAgent agent(s.options, world::SafetyLimits{}, some_policy(), s.reference, s.terrain);
  vehicle::State state;
  state << 395, 5, 100, 0.0, 10, 0, 0;  // inside target a's radius
  agent.control(10.0, state, Vec3::Zero());
  EXPECT_EQ(agent.targets_inspected(), 1);
  const learning::Observation o = agent.observe(10.0, state, Vec3::Zero());
  // Now target b, 395 m to the left (north when heading east), 20 m up.
  EXPECT_NEAR(o[3], 0.0, 0.02);
  EXPECT_NEAR(o[4], 1.0, 1e-3);
  EXPECT_NEAR(o[6], 0.2, 1e-6);
}

TEST(DdpgAgent, WithoutAPolicyIsAClearError) {
  const AgentSetup s = make_setup();
  try {
    DdpgAgent agent(s.options, world::SafetyLimits{}, nullptr, s.reference, s.terrain);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "ddpg_model");
  }
}

}  // namespace
}  // namespace ridgeline::baselines
