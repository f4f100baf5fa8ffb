// DDPG (learning/ddpg.hpp): a short training run on the flat task raises the return on
// held-out episodes; a saved model reloads and gives bit-identical actions; training is
// deterministic for a seed; a missing or corrupt model file is one clear error naming it.
#include "learning/ddpg.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "core/error.hpp"
#include "support/temp_dir.hpp"

namespace ridgeline::learning {
namespace {

DdpgOptions small_options(std::uint64_t seed) {
  DdpgOptions o;
  o.seed = seed;
  o.hidden_units = 64;
  o.batch_size = 64;
  o.warmup_steps = 500;
  o.exploration_std = 0.3;
  o.exploration_std_final = 0.1;
  return o;
}

Observation random_observation(Rng& rng) {
  Observation o{};
  for (float& v : o) v = static_cast<float>(rng.uniform(-2.0, 2.0));
  return o;
}

TEST(Ddpg, ShortTrainingOnTheFlatTaskRaisesTheHeldOutReturn) {
  const EnvironmentOptions env = task_environment(TrainingTask::kFlat);
  DdpgTrainer trainer(small_options(3), env);
  // Before training the actor's outputs are near zero (small final layer): it flies straight
  // on at cruise speed from a random heading and reaches few targets.
  const EvaluationSummary before = evaluate_policy(trainer.policy(), env, 12, 99);
  const std::vector<TrainingEpisode> curve = trainer.train(30);
  ASSERT_EQ(curve.size(), 30u);
  EXPECT_GT(trainer.updates(), 0);
  const EvaluationSummary after = evaluate_policy(trainer.policy(), env, 12, 99);
  // The flat task's return is about the number of 2 m steps of progress (75–150) plus 50 on
  // reaching: a trained policy turns towards the target and gains tens of points per episode.
  EXPECT_GT(after.mean_return, before.mean_return + 20.0)
      << "before " << before.mean_return << " after " << after.mean_return;
  EXPECT_GT(after.reached, before.reached);
  EXPECT_GE(after.success_rate(), 0.5);
}

TEST(Ddpg, SavedModelReloadsWithIdenticalActions) {
  const EnvironmentOptions env = task_environment(TrainingTask::kFlat);
  DdpgTrainer trainer(small_options(5), env);
  trainer.train(2);  // some updates, so the weights are not the initial ones
  const DdpgPolicy policy = trainer.policy();
  const std::filesystem::path file = testing_support::fresh_test_dir() / "model.pt";
  {
    std::ofstream out(file, std::ios::binary);
    out << policy.serialize();
  }
  const DdpgPolicy reloaded = DdpgPolicy::load(file.string());
  EXPECT_DOUBLE_EQ(reloaded.action_period_s(), env.action_period_s);
  Rng rng(17);
  for (int k = 0; k < 50; ++k) {
    const Observation o = random_observation(rng);
    const Vec3 a = policy.act(o), b = reloaded.act(o);
    EXPECT_EQ(a, b);  // bit-identical: the same float weights, the same single thread
    EXPECT_LE(a.cwiseAbs().maxCoeff(), 1.0);
  }
}

TEST(Ddpg, TrainingIsDeterministicForASeed) {
  const EnvironmentOptions env = task_environment(TrainingTask::kFlat);
  DdpgTrainer a(small_options(8), env), b(small_options(8), env);
  const auto ca = a.train(3), cb = b.train(3);
  ASSERT_GT(a.updates(), 0);
  for (std::size_t i = 0; i < ca.size(); ++i) {
    EXPECT_EQ(ca[i].episode_return, cb[i].episode_return);
    EXPECT_EQ(ca[i].steps, cb[i].steps);
  }
  Rng rng(3);
  const Observation o = random_observation(rng);
  EXPECT_EQ(a.policy().act(o), b.policy().act(o));
}

TEST(Ddpg, MissingOrCorruptModelFileIsAnErrorNamingIt) {
  const std::filesystem::path dir = testing_support::fresh_test_dir();
  const std::string missing = (dir / "no_such_model.pt").string();
  try {
    DdpgPolicy::load(missing);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), missing);
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos);
  }
  const std::string corrupt = (dir / "corrupt.pt").string();
  {
    std::ofstream out(corrupt);
    out << "this is not a torch archive";
  }
  try {
    DdpgPolicy::load(corrupt);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), corrupt);
  }
}

TEST(Ddpg, InvalidOptionsNameTheField) {
  DdpgOptions o;
  o.discount = 1.0;
  try {
    validate(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "discount");
  }
}

}  // namespace
}  // namespace ridgeline::learning
