// DdpgPolicy and DdpgTrainer: handles to objects of the torch module (ddpg_backend.hpp), which
// is loaded on first use. This file includes no torch header and links no torch.
#include "learning/ddpg.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "learning/ddpg_backend.hpp"

namespace ridgeline::learning {

// ---------------------------------------------------------------------------------------------
// Policy

struct DdpgPolicy::Impl {
  std::unique_ptr<const ddpg_backend::PolicyBackend> backend;
};

DdpgPolicy::DdpgPolicy(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DdpgPolicy::DdpgPolicy(DdpgPolicy&&) noexcept = default;
DdpgPolicy& DdpgPolicy::operator=(DdpgPolicy&&) noexcept = default;
DdpgPolicy::~DdpgPolicy() = default;

Vec3 DdpgPolicy::act(const Observation& observation) const {
  return impl_->backend->act(observation);
}

double DdpgPolicy::action_period_s() const { return impl_->backend->action_period_s(); }

std::string DdpgPolicy::serialize() const { return impl_->backend->serialize(); }

DdpgPolicy DdpgPolicy::deserialize(const std::string& bytes, const std::string& source) {
  auto impl = std::make_unique<Impl>();
  impl->backend = ddpg_backend::backend().deserialize(bytes, source);
  return DdpgPolicy(std::move(impl));
}

DdpgPolicy DdpgPolicy::load(const std::string& path) {
  // The file is checked before the module is loaded: a missing model is reported as such.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path,
                     "DDPG model file not found (train one with 'ridgeline train ddpg' "
                     "or pass --ddpg-model FILE)");
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (!in) throw InputError(path, "cannot read the DDPG model file");
  return deserialize(buffer.str(), path);
}

// ---------------------------------------------------------------------------------------------
// Trainer

struct DdpgTrainer::Impl {
  std::unique_ptr<ddpg_backend::TrainerBackend> backend;

  DdpgPolicy snapshot() const {
    auto impl = std::make_unique<DdpgPolicy::Impl>();
    impl->backend = backend->snapshot();
    return DdpgPolicy(std::move(impl));
  }
};

DdpgTrainer::DdpgTrainer(const DdpgOptions& options, const EnvironmentOptions& environment)
    : impl_(std::make_unique<Impl>()) {
  impl_->backend = ddpg_backend::backend().make_trainer(options, environment);
}
DdpgTrainer::~DdpgTrainer() = default;

std::vector<TrainingEpisode> DdpgTrainer::train(
    int episodes, const std::function<void(const TrainingEpisode&)>& progress, int checkpoint_every,
    const std::function<void(const DdpgPolicy&)>& checkpoint, int noise_decay_episodes) {
  if (episodes < 1) throw InputError("episodes", "must be at least 1");
  const int schedule = noise_decay_episodes > 0 ? noise_decay_episodes : episodes;
  std::vector<TrainingEpisode> curve;
  // The loop is on this side of the seam, so the callbacks never run inside the module.
  for (int e = 0; e < episodes; ++e) {
    curve.push_back(impl_->backend->run_episode(e, schedule));
    if (progress) progress(curve.back());
    const bool last = e + 1 == episodes;
    if (checkpoint && (last || (checkpoint_every > 0 && (e + 1) % checkpoint_every == 0)))
      checkpoint(impl_->snapshot());
  }
  return curve;
}

DdpgPolicy DdpgTrainer::policy() const { return impl_->snapshot(); }
long long DdpgTrainer::environment_steps() const { return impl_->backend->environment_steps(); }
long long DdpgTrainer::updates() const { return impl_->backend->updates(); }

}  // namespace ridgeline::learning
