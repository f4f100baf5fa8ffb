// Deep deterministic policy gradient (DDPG; Lillicrap et al. 2016), the learning method of the
// paper's comparison [8], on the UAV environment (uav_environment.hpp). libtorch (Debian
// libtorch-dev) does the networks, in the module libridgeline_ddpg.so (src/learning/torch/),
// which the first DdpgPolicy or DdpgTrainer loads (ddpg_backend.hpp); no program links torch,
// and this header keeps it out of every file that includes it (pimpl). A missing or unloadable
// module is an InputError naming where it was looked for.
//
//   actor   μ(o) = tanh(MLP(o)) ∈ [−1, 1]³           critic  Q(o, a) = MLP([o, a])
//   critic: minimise (Q(o, a) − y)²,  y = r + γ·(1 − terminal)·Q'(o', μ'(o'))
//           (a timeout is not terminal: the value beyond it is bootstrapped)
//   actor:  maximise Q(o, μ(o))
//   targets μ', Q' track the networks by soft updates θ' ← (1 − τ)·θ' + τ·θ
// with a uniform replay buffer, Gaussian exploration noise on the action (its standard deviation
// decays linearly over the episodes), the gradients' global norm clipped, Adam for both.
// Deterministic for a seed: one torch thread (torch::set_num_threads(1)), torch's generator
// and every draw of ours (episodes, noise, minibatches) seeded.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "learning/uav_environment.hpp"

namespace ridgeline::learning {

struct DdpgOptions {
  int hidden_units = 64;  ///< per hidden layer, actor and critic
  int hidden_layers = 2;
  double actor_learning_rate = 3e-4;
  double critic_learning_rate = 1e-3;
  double discount = 0.98;      ///< γ per decision (0.4 s): a horizon of about 20 s
  double soft_update = 0.005;  ///< τ
  int batch_size = 64;
  int replay_capacity = 300000;
  int warmup_steps = 5000;  ///< uniform random actions before the first update
  int updates_per_step = 1;
  double exploration_std = 0.3;         ///< at the first episode
  double exploration_std_final = 0.05;  ///< at the last episode
  double gradient_clip_norm = 1.0;
  std::uint64_t seed = 1;
};

/// Throws InputError naming the field.
void validate(const DdpgOptions& options);

/// One row of the learning curve.
struct TrainingEpisode {
  int episode = 0;
  double episode_return = 0.0;
  EpisodeOutcome outcome = EpisodeOutcome::kRunning;
  int steps = 0;
  double success_rate_last100 = 0.0;  ///< over the last (up to) 100 episodes
  double collision_rate_last100 = 0.0;
  double mean_return_last100 = 0.0;
  double exploration_std = 0.0;
  double wall_time_s = 0.0;  ///< since training started
};

/// learning-curve CSV: header then one row per episode.
std::string learning_curve_csv(const std::vector<TrainingEpisode>& curve);

/// The trained actor: what flies. Copyable by value semantics of its weights (clone()).
class DdpgPolicy {
 public:
  DdpgPolicy(DdpgPolicy&&) noexcept;
  DdpgPolicy& operator=(DdpgPolicy&&) noexcept;
  ~DdpgPolicy();

  /// The action in [−1, 1]³ for an observation (no exploration noise).
  Vec3 act(const Observation& observation) const;
  /// The decision period the policy was trained with (s).
  double action_period_s() const;
  /// The model file's bytes (a torch archive: the actor's weights and its shape).
  std::string serialize() const;
  /// Reads a model from bytes; `source` names them in errors. Throws InputError.
  static DdpgPolicy deserialize(const std::string& bytes, const std::string& source);
  /// Reads a model file; throws InputError naming the file when it is missing or not a model.
  static DdpgPolicy load(const std::string& path);

 private:
  friend class DdpgTrainer;
  struct Impl;
  explicit DdpgPolicy(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

class DdpgTrainer {
 public:
  DdpgTrainer(const DdpgOptions& options, const EnvironmentOptions& environment);
  ~DdpgTrainer();

  /// Trains for `episodes` episodes. The exploration noise decays linearly over
  /// `noise_decay_episodes` episodes (0: over `episodes`), so a run stopped early is the same
  /// as the first episodes of a longer one. `progress` is called after every episode; every
  /// `checkpoint_every` episodes (and at the end) `checkpoint` gets the current policy.
  std::vector<TrainingEpisode> train(
      int episodes, const std::function<void(const TrainingEpisode&)>& progress = {},
      int checkpoint_every = 0, const std::function<void(const DdpgPolicy&)>& checkpoint = {},
      int noise_decay_episodes = 0);

  /// A copy of the current actor.
  DdpgPolicy policy() const;
  long long environment_steps() const;
  long long updates() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Held-out evaluation: `episodes` episodes drawn from `seed` (a stream the trainer never uses),
/// flown without noise.
struct EvaluationSummary {
  int episodes = 0;
  int reached = 0;
  int terrain_collisions = 0;
  int threat_collisions = 0;
  int altitude_violations = 0;
  int timeouts = 0;
  double mean_return = 0.0;
  double success_rate() const { return episodes > 0 ? double(reached) / episodes : 0.0; }
  double collision_rate() const {
    return episodes > 0
               ? double(terrain_collisions + threat_collisions + altitude_violations) / episodes
               : 0.0;
  }
};
EvaluationSummary evaluate_policy(const DdpgPolicy& policy, const EnvironmentOptions& environment,
                                  int episodes, std::uint64_t seed,
                                  const std::function<void(int, EpisodeOutcome)>& progress = {});

/// The seed of training episode `episode` and of evaluation episode `episode` (different
/// sub-streams, so an evaluation seed equal to the training seed still draws other worlds).
std::uint64_t training_episode_seed(std::uint64_t seed, int episode);
std::uint64_t evaluation_episode_seed(std::uint64_t seed, int episode);

}  // namespace ridgeline::learning
