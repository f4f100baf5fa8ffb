// DdpgOptions' validation and the episode seeds (ddpg.hpp): compiled into the learning layer
// and into the torch module (src/learning/torch/), which trains with them.
#include "core/error.hpp"
#include "learning/ddpg.hpp"

namespace ridgeline::learning {

void validate(const DdpgOptions& o) {
  auto require = [](bool ok, const char* field, const char* reason) {
    if (!ok) throw InputError(field, reason);
  };
  require(o.hidden_units >= 1 && o.hidden_units <= 4096, "hidden_units", "must be in [1, 4096]");
  require(o.hidden_layers >= 1 && o.hidden_layers <= 8, "hidden_layers", "must be in [1, 8]");
  require(o.actor_learning_rate > 0.0 && o.critic_learning_rate > 0.0, "learning_rate",
          "must be positive");
  require(o.discount >= 0.0 && o.discount < 1.0, "discount", "must be in [0, 1)");
  require(o.soft_update > 0.0 && o.soft_update <= 1.0, "soft_update", "must be in (0, 1]");
  require(o.batch_size >= 1, "batch_size", "must be at least 1");
  require(o.replay_capacity >= o.batch_size, "replay_capacity", "must be at least batch_size");
  require(o.warmup_steps >= o.batch_size, "warmup_steps", "must be at least batch_size");
  require(o.updates_per_step >= 1, "updates_per_step", "must be at least 1");
  require(o.exploration_std >= 0.0 && o.exploration_std_final >= 0.0, "exploration_std",
          "must not be negative");
  require(o.gradient_clip_norm > 0.0, "gradient_clip_norm", "must be positive");
}

std::uint64_t training_episode_seed(std::uint64_t seed, int episode) {
  return derive_seed(derive_seed(seed, 0x545241494E), static_cast<std::uint64_t>(episode));
}

std::uint64_t evaluation_episode_seed(std::uint64_t seed, int episode) {
  return derive_seed(derive_seed(seed, 0x4556414C), static_cast<std::uint64_t>(episode));
}

}  // namespace ridgeline::learning
