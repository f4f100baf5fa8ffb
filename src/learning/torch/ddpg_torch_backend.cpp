// The DDPG torch module, libridgeline_ddpg.so (ddpg_backend.hpp): networks, replay, training
// and the policy's file format. The only translation unit that includes libtorch (its headers
// compile slowly); no program links it, the learning layer loads it on first use.
#include <fmt/format.h>
#include <torch/torch.h>

#include <chrono>
#include <deque>
#include <sstream>

#include "core/error.hpp"
#include "learning/ddpg.hpp"
#include "learning/ddpg_backend.hpp"

namespace ridgeline::learning {
namespace {

// Model file format: version 1 = meta [version, observation size, action size, hidden units,
// hidden layers, action period] + the actor's parameters.
constexpr double kFormatVersion = 1.0;

torch::nn::Sequential make_mlp(int inputs, int outputs, int hidden, int layers, bool tanh_out) {
  torch::nn::Sequential net;
  int width = inputs;
  for (int i = 0; i < layers; ++i) {
    net->push_back(torch::nn::Linear(width, hidden));
    net->push_back(torch::nn::ReLU());
    width = hidden;
  }
  auto last = torch::nn::Linear(width, outputs);
  // Small final weights: the first actions are near the centre of the limits and the first
  // values near zero (as in the DDPG paper).
  {
    torch::NoGradGuard no_grad;
    last->weight.uniform_(-3e-3, 3e-3);
    last->bias.uniform_(-3e-3, 3e-3);
  }
  net->push_back(last);
  if (tanh_out) net->push_back(torch::nn::Tanh());
  return net;
}

void copy_parameters(const torch::nn::Sequential& from, torch::nn::Sequential& to) {
  torch::NoGradGuard no_grad;
  const auto src = from->parameters();
  auto dst = to->parameters();
  for (std::size_t i = 0; i < src.size(); ++i) dst[i].copy_(src[i]);
}

torch::Tensor observation_tensor(const Observation& o) {
  return torch::from_blob(const_cast<float*>(o.data()), {1, kObservationSize}, torch::kFloat32)
      .clone();
}

Vec3 forward_action(torch::nn::Sequential& actor, const Observation& o) {
  torch::NoGradGuard no_grad;
  const torch::Tensor a = actor->forward(observation_tensor(o));
  const auto acc = a.accessor<float, 2>();
  return Vec3(acc[0][0], acc[0][1], acc[0][2]);
}

// ---------------------------------------------------------------------------------------------
// Policy

class TorchPolicy final : public ddpg_backend::PolicyBackend {
 public:
  int hidden_units = 0;
  int hidden_layers = 0;
  double period_s = 0.2;
  // torch's forward() is not const, though a forward pass in eval mode changes nothing.
  mutable torch::nn::Sequential actor{nullptr};

  Vec3 act(const Observation& observation) const override {
    return forward_action(actor, observation);
  }

  double action_period_s() const override { return period_s; }

  std::string serialize() const override {
    torch::serialize::OutputArchive archive;
    archive.write("meta",
                  torch::tensor({kFormatVersion, double(kObservationSize), double(kActionSize),
                                 double(hidden_units), double(hidden_layers), period_s},
                                torch::kFloat64));
    torch::serialize::OutputArchive actor_archive;
    actor->save(actor_archive);
    archive.write("actor", actor_archive);
    std::ostringstream out;
    archive.save_to(out);
    return out.str();
  }
};

std::unique_ptr<ddpg_backend::PolicyBackend> deserialize_policy(const std::string& bytes,
                                                                const std::string& source) {
  auto impl = std::make_unique<TorchPolicy>();
  torch::set_num_threads(1);  // tiny networks: one thread is fastest and deterministic
  try {
    std::istringstream in(bytes);
    torch::serialize::InputArchive archive;
    archive.load_from(in);
    torch::Tensor meta;
    archive.read("meta", meta);
    if (meta.numel() != 6 || meta.scalar_type() != torch::kFloat64)
      throw InputError(source, "not a Ridgeline DDPG model (bad meta record)");
    const auto m = meta.accessor<double, 1>();
    if (m[0] != kFormatVersion)
      throw InputError(source, fmt::format("model format version {} (this build reads {})", m[0],
                                           kFormatVersion));
    if (m[1] != kObservationSize || m[2] != kActionSize)
      throw InputError(source, fmt::format("model has {} observations and {} actions; this build "
                                           "uses {} and {}",
                                           m[1], m[2], kObservationSize, kActionSize));
    impl->hidden_units = static_cast<int>(m[3]);
    impl->hidden_layers = static_cast<int>(m[4]);
    impl->period_s = m[5];
    if (impl->hidden_units < 1 || impl->hidden_units > 4096 || impl->hidden_layers < 1 ||
        impl->hidden_layers > 8 || !(impl->period_s > 0.0 && impl->period_s < 10.0))
      throw InputError(source, "model's shape or action period is out of range");
    impl->actor =
        make_mlp(kObservationSize, kActionSize, impl->hidden_units, impl->hidden_layers, true);
    torch::serialize::InputArchive actor;
    archive.read("actor", actor);
    impl->actor->load(actor);
  } catch (const c10::Error& e) {
    throw InputError(source,
                     fmt::format("not a readable DDPG model ({})", e.what_without_backtrace()));
  }
  impl->actor->eval();
  return impl;
}

// ---------------------------------------------------------------------------------------------
// Trainer

class TorchTrainer final : public ddpg_backend::TrainerBackend {
 public:
  DdpgOptions options;
  EnvironmentOptions environment_options;
  UavEnvironment environment;
  Rng rng;
  torch::nn::Sequential actor{nullptr}, critic{nullptr}, actor_target{nullptr},
      critic_target{nullptr};
  std::unique_ptr<torch::optim::Adam> actor_optimizer, critic_optimizer;
  // Replay buffer (ring), row-major.
  std::vector<float> obs, next_obs, actions, rewards, terminals;
  long long stored = 0;
  long long steps = 0;
  long long update_count = 0;
  int episodes_done = 0;
  std::deque<TrainingEpisode> recent;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  // Minibatch staging.
  std::vector<float> b_obs, b_next, b_act, b_rew, b_term;

  TorchTrainer(const DdpgOptions& o, const EnvironmentOptions& e)
      : options(o), environment_options(e), environment(e), rng(derive_seed(o.seed, 0x444450)) {
    validate(o);
    torch::set_num_threads(1);
    torch::manual_seed(o.seed);
    actor = make_mlp(kObservationSize, kActionSize, o.hidden_units, o.hidden_layers, true);
    critic = make_mlp(kObservationSize + kActionSize, 1, o.hidden_units, o.hidden_layers, false);
    actor_target = make_mlp(kObservationSize, kActionSize, o.hidden_units, o.hidden_layers, true);
    critic_target =
        make_mlp(kObservationSize + kActionSize, 1, o.hidden_units, o.hidden_layers, false);
    copy_parameters(actor, actor_target);
    copy_parameters(critic, critic_target);
    actor_optimizer = std::make_unique<torch::optim::Adam>(
        actor->parameters(), torch::optim::AdamOptions(o.actor_learning_rate));
    critic_optimizer = std::make_unique<torch::optim::Adam>(
        critic->parameters(), torch::optim::AdamOptions(o.critic_learning_rate));
    const auto cap = static_cast<std::size_t>(o.replay_capacity);
    obs.resize(cap * kObservationSize);
    next_obs.resize(cap * kObservationSize);
    actions.resize(cap * kActionSize);
    rewards.resize(cap);
    terminals.resize(cap);
    const auto b = static_cast<std::size_t>(o.batch_size);
    b_obs.resize(b * kObservationSize);
    b_next.resize(b * kObservationSize);
    b_act.resize(b * kActionSize);
    b_rew.resize(b);
    b_term.resize(b);
  }

  void store(const Observation& o, const Vec3& a, double r, const Observation& o2, bool terminal) {
    const auto i = static_cast<std::size_t>(stored % options.replay_capacity);
    std::copy(o.begin(), o.end(), obs.begin() + static_cast<long>(i * kObservationSize));
    std::copy(o2.begin(), o2.end(), next_obs.begin() + static_cast<long>(i * kObservationSize));
    for (int k = 0; k < kActionSize; ++k) actions[i * kActionSize + k] = static_cast<float>(a[k]);
    rewards[i] = static_cast<float>(r);
    terminals[i] = terminal ? 1.0f : 0.0f;
    ++stored;
  }

  Vec3 act(const Observation& o) { return forward_action(actor, o); }

  void update() {
    const long long size = std::min<long long>(stored, options.replay_capacity);
    const int b = options.batch_size;
    for (int j = 0; j < b; ++j) {
      const auto i = static_cast<std::size_t>(std::min<long long>(
          size - 1, static_cast<long long>(rng.uniform() * static_cast<double>(size))));
      const auto jj = static_cast<std::size_t>(j);
      std::copy_n(obs.begin() + static_cast<long>(i * kObservationSize), kObservationSize,
                  b_obs.begin() + static_cast<long>(jj * kObservationSize));
      std::copy_n(next_obs.begin() + static_cast<long>(i * kObservationSize), kObservationSize,
                  b_next.begin() + static_cast<long>(jj * kObservationSize));
      std::copy_n(actions.begin() + static_cast<long>(i * kActionSize), kActionSize,
                  b_act.begin() + static_cast<long>(jj * kActionSize));
      b_rew[jj] = rewards[i];
      b_term[jj] = terminals[i];
    }
    const torch::Tensor s = torch::from_blob(b_obs.data(), {b, kObservationSize});
    const torch::Tensor s2 = torch::from_blob(b_next.data(), {b, kObservationSize});
    const torch::Tensor a = torch::from_blob(b_act.data(), {b, kActionSize});
    const torch::Tensor r = torch::from_blob(b_rew.data(), {b, 1});
    const torch::Tensor d = torch::from_blob(b_term.data(), {b, 1});

    torch::Tensor y;
    {
      torch::NoGradGuard no_grad;
      const torch::Tensor q2 =
          critic_target->forward(torch::cat({s2, actor_target->forward(s2)}, 1));
      y = r + options.discount * (1.0 - d) * q2;
    }
    const torch::Tensor q = critic->forward(torch::cat({s, a}, 1));
    const torch::Tensor critic_loss = torch::mse_loss(q, y);
    critic_optimizer->zero_grad();
    critic_loss.backward();
    torch::nn::utils::clip_grad_norm_(critic->parameters(), options.gradient_clip_norm);
    critic_optimizer->step();

    const torch::Tensor actor_loss = -critic->forward(torch::cat({s, actor->forward(s)}, 1)).mean();
    actor_optimizer->zero_grad();
    actor_loss.backward();
    torch::nn::utils::clip_grad_norm_(actor->parameters(), options.gradient_clip_norm);
    actor_optimizer->step();

    torch::NoGradGuard no_grad;
    const double tau = options.soft_update;
    auto soft = [tau](const torch::nn::Sequential& net, torch::nn::Sequential& target) {
      const auto p = net->parameters();
      auto t = target->parameters();
      for (std::size_t i = 0; i < p.size(); ++i) t[i].mul_(1.0 - tau).add_(p[i], tau);
    };
    soft(actor, actor_target);
    soft(critic, critic_target);
    ++update_count;
  }

  TrainingEpisode run_episode(int episode, int total_episodes) override {
    torch::set_num_threads(1);
    const double f =
        total_episodes > 1 ? std::min(1.0, double(episode) / (total_episodes - 1)) : 1.0;
    const double noise_std =
        options.exploration_std + f * (options.exploration_std_final - options.exploration_std);
    Observation o = environment.reset(training_episode_seed(options.seed, episodes_done));
    TrainingEpisode row;
    row.episode = episodes_done;
    row.exploration_std = noise_std;
    for (;;) {
      Vec3 a;
      if (steps < options.warmup_steps) {
        a = Vec3(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
      } else {
        a = act(o);
        for (int k = 0; k < 3; ++k) a[k] = std::clamp(a[k] + noise_std * rng.normal(), -1.0, 1.0);
      }
      const StepResult step = environment.step(a);
      const double reward = step.reward.total();
      const bool terminal = step.done() && step.outcome != EpisodeOutcome::kTimeout;
      store(o, a, reward, step.observation, terminal);
      row.episode_return += reward;
      ++row.steps;
      ++steps;
      if (steps >= options.warmup_steps)
        for (int u = 0; u < options.updates_per_step; ++u) update();
      o = step.observation;
      if (step.done()) {
        row.outcome = step.outcome;
        break;
      }
    }
    ++episodes_done;
    recent.push_back(row);
    if (recent.size() > 100) recent.pop_front();
    int reached = 0, collided = 0;
    double sum = 0.0;
    for (const TrainingEpisode& e : recent) {
      reached += e.outcome == EpisodeOutcome::kReached;
      collided += is_collision(e.outcome);
      sum += e.episode_return;
    }
    const double n = static_cast<double>(recent.size());
    row.success_rate_last100 = reached / n;
    row.collision_rate_last100 = collided / n;
    row.mean_return_last100 = sum / n;
    row.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return row;
  }

  std::unique_ptr<ddpg_backend::PolicyBackend> snapshot() const override {
    auto impl = std::make_unique<TorchPolicy>();
    impl->hidden_units = options.hidden_units;
    impl->hidden_layers = options.hidden_layers;
    impl->period_s = environment_options.action_period_s;
    impl->actor =
        make_mlp(kObservationSize, kActionSize, options.hidden_units, options.hidden_layers, true);
    copy_parameters(actor, impl->actor);
    impl->actor->eval();
    return impl;
  }

  long long environment_steps() const override { return steps; }
  long long updates() const override { return update_count; }
};

class TorchBackend final : public ddpg_backend::Backend {
 public:
  std::unique_ptr<ddpg_backend::PolicyBackend> deserialize(
      const std::string& bytes, const std::string& source) const override {
    return deserialize_policy(bytes, source);
  }
  std::unique_ptr<ddpg_backend::TrainerBackend> make_trainer(
      const DdpgOptions& options, const EnvironmentOptions& environment) const override {
    return std::make_unique<TorchTrainer>(options, environment);
  }
};

}  // namespace
}  // namespace ridgeline::learning

/// The module's one exported symbol (ddpg_backend::kBackendEntrySymbol).
extern "C" __attribute__((visibility("default")))
const ridgeline::learning::ddpg_backend::BackendEntry*
ridgeline_ddpg_backend_entry() {
  using namespace ridgeline::learning;
  static const TorchBackend backend;
  static const ddpg_backend::BackendEntry entry{ddpg_backend::kAbiVersion,
                                                ddpg_backend::layout_size(), &backend};
  return &entry;
}
static_assert(std::is_same_v<decltype(&ridgeline_ddpg_backend_entry),
                             ridgeline::learning::ddpg_backend::EntryFunction>);
