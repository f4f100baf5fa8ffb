// `ridgeline train ddpg --episodes N --seed S --out MODEL.pt [--task mountain|flat]
// [--hidden 128] [--checkpoint-every 50]`: trains the DDPG agent of comparison method [8]
// (learning/ddpg.hpp) on randomized episodes of the UAV environment
// (learning/uav_environment.hpp), progress on stderr; writes MODEL.pt and the learning curve
// beside it (MODEL.learning_curve.csv), both atomically, every checkpoint and at the end.
//
// `ridgeline train ddpg --evaluate MODEL.pt --episodes 100 --seed S2 [--task ...]`: flies the
// model without exploration noise on episodes drawn from the evaluation stream of seed S2
// (never a training episode) and prints the success, collision and timeout rates.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "apps/command_support.hpp"
#include "apps/commands.hpp"
#include "core/error.hpp"
#include "io/atomic_file.hpp"
#include "learning/ddpg.hpp"

namespace ridgeline::apps {
namespace {

std::filesystem::path curve_path(const std::filesystem::path& model) {
  std::filesystem::path p = model;
  p.replace_extension(".learning_curve.csv");
  return p;
}

}  // namespace

void register_train_command(CLI::App& app) {
  struct Args {
    int episodes = 1000;
    std::uint64_t seed = 1;
    std::string out;
    std::string evaluate;
    std::string task = "mountain";
    int hidden = 64;
    int checkpoint_every = 50;
    int noise_decay_episodes = 0;
    bool quiet = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* train = app.add_subcommand("train", "Train a learning comparison method");
  train->require_subcommand(1);
  CLI::App* ddpg = train->add_subcommand(
      "ddpg", "DDPG agent of comparison method [8] (libtorch): train, or --evaluate a model");
  ddpg->add_option("--episodes", args->episodes, "Training or evaluation episodes")
      ->capture_default_str()
      ->check(at_least(1));
  ddpg->add_option("--seed", args->seed, "Seed of the episodes, noise and initial weights")
      ->capture_default_str();
  ddpg->add_option("--out", args->out, "Model file to write (training)");
  ddpg->add_option("--evaluate", args->evaluate, "Model file to evaluate instead of training");
  ddpg->add_option("--task", args->task, "Episode distribution: mountain or flat")
      ->capture_default_str();
  ddpg->add_option("--hidden", args->hidden, "Units per hidden layer (2 layers)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  ddpg->add_option("--checkpoint-every", args->checkpoint_every,
                   "Write the model and curve every N episodes (0: only at the end)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  ddpg->add_option("--noise-decay-episodes", args->noise_decay_episodes,
                   "Episodes over which the exploration noise decays (0: --episodes); with a "
                   "larger value the run is the start of a longer one")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  ddpg->add_flag("--quiet", args->quiet, "No progress lines");
  ddpg->callback([args]() {
    const learning::EnvironmentOptions env =
        learning::task_environment(learning::parse_training_task(args->task));
    if (!args->evaluate.empty()) {
      if (!args->out.empty()) throw InputError("--out", "not used with --evaluate");
      const learning::DdpgPolicy policy = learning::DdpgPolicy::load(args->evaluate);
      const learning::EvaluationSummary s = learning::evaluate_policy(
          policy, env, args->episodes, args->seed, [&](int e, learning::EpisodeOutcome o) {
            if (!args->quiet)
              std::cerr << fmt::format("evaluation episode {:>4}: {}\n", e, learning::to_string(o));
          });
      std::cout << fmt::format(
          "evaluation of {} on {} held-out '{}' episodes (seed {}):\n"
          "  reached {} ({:.1f} %), collisions {} ({:.1f} %: terrain {}, threat {}, altitude {}),"
          " timeouts {}, mean return {:.2f}\n",
          args->evaluate, s.episodes, args->task, args->seed, s.reached, 100.0 * s.success_rate(),
          s.terrain_collisions + s.threat_collisions + s.altitude_violations,
          100.0 * s.collision_rate(), s.terrain_collisions, s.threat_collisions,
          s.altitude_violations, s.timeouts, s.mean_return);
      return;
    }
    if (args->out.empty()) throw InputError("--out", "a model file to write is required");
    learning::DdpgOptions options;
    options.seed = args->seed;
    options.hidden_units = args->hidden;
    if (learning::parse_training_task(args->task) == learning::TrainingTask::kFlat) {
      options.warmup_steps = 500;  // the short episodes of the flat task fill the buffer slowly
      options.batch_size = 64;
    }
    learning::DdpgTrainer trainer(options, env);
    std::vector<learning::TrainingEpisode> curve;
    const std::filesystem::path out = args->out;
    auto write = [&](const learning::DdpgPolicy& policy) {
      io::write_file_atomically(out, policy.serialize());
      io::write_file_atomically(curve_path(out), learning::learning_curve_csv(curve));
    };
    trainer.train(
        args->episodes,
        [&](const learning::TrainingEpisode& e) {
          curve.push_back(e);
          if (!args->quiet && (e.episode % 10 == 9 || e.episode + 1 == args->episodes))
            std::cerr << fmt::format(
                "episode {:>5}  return {:>8.1f}  {:<18} success(last 100) {:.2f}  "
                "collision {:.2f}  mean return {:>7.1f}  noise {:.3f}  steps {}  {:.0f} s\n",
                e.episode + 1, e.episode_return, learning::to_string(e.outcome),
                e.success_rate_last100, e.collision_rate_last100, e.mean_return_last100,
                e.exploration_std, trainer.environment_steps(), e.wall_time_s);
        },
        args->checkpoint_every, write, args->noise_decay_episodes);
    const learning::TrainingEpisode& last = curve.back();
    std::cout << fmt::format(
        "trained {} episodes ({} decisions, {} updates) in {:.0f} s; last 100: success {:.2f}, "
        "collision {:.2f}, mean return {:.1f}\nwrote {} and {}\n",
        curve.size(), trainer.environment_steps(), trainer.updates(), last.wall_time_s,
        last.success_rate_last100, last.collision_rate_last100, last.mean_return_last100,
        out.string(), curve_path(out).string());
  });
}

}  // namespace ridgeline::apps
