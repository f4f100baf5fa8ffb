// The learning curve's CSV and the held-out evaluation of a policy (ddpg.hpp).
#include <fmt/format.h>

#include "learning/ddpg.hpp"

namespace ridgeline::learning {

std::string learning_curve_csv(const std::vector<TrainingEpisode>& curve) {
  std::string out =
      "episode,return,outcome,steps,success_rate_last100,collision_rate_last100,"
      "mean_return_last100,exploration_std,wall_time_s\n";
  for (const TrainingEpisode& e : curve)
    out += fmt::format("{},{:.4f},{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.2f}\n", e.episode,
                       e.episode_return, to_string(e.outcome), e.steps, e.success_rate_last100,
                       e.collision_rate_last100, e.mean_return_last100, e.exploration_std,
                       e.wall_time_s);
  return out;
}

EvaluationSummary evaluate_policy(const DdpgPolicy& policy, const EnvironmentOptions& environment,
                                  int episodes, std::uint64_t seed,
                                  const std::function<void(int, EpisodeOutcome)>& progress) {
  EvaluationSummary s;
  UavEnvironment env(environment);
  double total = 0.0;
  for (int e = 0; e < episodes; ++e) {
    Observation o = env.reset(evaluation_episode_seed(seed, e));
    StepResult step;
    do {
      step = env.step(policy.act(o));
      total += step.reward.total();
      o = step.observation;
    } while (!step.done());
    ++s.episodes;
    switch (step.outcome) {
      case EpisodeOutcome::kReached:
        ++s.reached;
        break;
      case EpisodeOutcome::kTerrainCollision:
        ++s.terrain_collisions;
        break;
      case EpisodeOutcome::kThreatCollision:
        ++s.threat_collisions;
        break;
      case EpisodeOutcome::kAltitudeViolation:
        ++s.altitude_violations;
        break;
      default:
        ++s.timeouts;
        break;
    }
    if (progress) progress(e, step.outcome);
  }
  s.mean_return = s.episodes > 0 ? total / s.episodes : 0.0;
  return s;
}

}  // namespace ridgeline::learning
