// The joint optimizer's building blocks (trajectory_optimizer.hpp), shared with its priority
// decomposition (priority_decomposition.hpp): the team's shared time grid and guesses, the
// separation-aware guess, the flown check (time parametrization and dense validation of a
// solution), and the refinement of the transcription where that check failed.
#pragma once

#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "planning/guess_deconfliction.hpp"
#include "planning/plan_validation.hpp"
#include "planning/time_parametrization.hpp"
#include "planning/trajectory_ipopt.hpp"
#include "planning/trajectory_nlp.hpp"
#include "planning/trajectory_optimizer.hpp"

namespace ridgeline::planning::detail {

/// The shared time grid: every UAV's route on steps of dt from its legs' cruise times.
struct TeamGrid {
  std::vector<GridUav> uavs;
  double dt = 0.0;
  int max_index = 0;  ///< the largest segment count over the team
  std::string error;  ///< a route the grid cannot carry, or empty
};

using Candidates = std::map<std::tuple<int, int, int>, SeparationCandidate>;

/// A UAV whose solution the time parametrization cannot fly within its pitch or climb limit
/// (eq. 2), and by how much: the flown grade over the flyable one (> 1).
struct GradeExcess {
  int uav = 0;
  double ratio = 1.0;
  std::string description;
};

/// A solution as stage 4 of the global planner flies it: per UAV its timed reference, the UAVs
/// whose grade it cannot fly, and the dense check of those references (violations placed on the
/// grid step of their time, the worst one per kind, UAV(s) and step).
struct FlownCheck {
  std::vector<TimeParametrizationResult> timing;  // per UAV
  std::vector<GradeExcess> steep;
  PlanValidationReport validation;
};

/// The problem's and options' first error, or empty.
std::string check_problem(const TrajectoryProblem& problem,
                          const TrajectoryOptimizerOptions& options);
TeamGrid make_team_grid(const TrajectoryProblem& problem, const TrajectoryOptimizerOptions& options);
/// The separation-aware guesses (options.deconflict_guesses), or only their measure.
GuessDeconflictionSummary deconflict_team(const TrajectoryProblem& problem,
                                          const TrajectoryOptimizerOptions& options,
                                          TeamGrid& team);
/// The first pair of points fixed at the same time closer than separation_m, or empty.
std::string fixed_points_too_close(const TeamGrid& team, double separation_m);
/// Waypoints at t_k = k·dt, named as the grid's UAVs.
std::vector<TimedPath> timed_paths(const std::vector<GridUav>& grid,
                                   const std::vector<std::vector<Vec3>>& waypoints, double dt);
/// `paths` (UAV i of `problem` each) timed and checked densely (FlownCheck).
FlownCheck check_flown(const TrajectoryProblem& problem, const std::vector<TimedPath>& paths,
                       const TrajectoryOptimizerOptions& options, const TeamGrid& team,
                       const PlanValidationOptions& validation);
/// More terrain samples and margin on a violated segment and its neighbours; more separation
/// candidates, samples and margin around a violated step.
void refine_where_broken(const PlanValidationReport& validation, const TeamGrid& team,
                         const TrajectoryOptimizerOptions& options, NlpSetup& setup,
                         Candidates& candidates);
/// Grade rows for UAVs whose grade the timing cannot fly (a tighter G if they had them).
void bound_grades(const std::vector<GradeExcess>& excesses, NlpSetup& setup);
/// A refinement's warm start: it keeps every row and adds some, so the shared rows start from
/// their last multipliers (by row key) and the new ones from zero; the bound multipliers carry
/// over when the variables are the same.
Multipliers warm_start(const TrajectoryNlp& nlp, const Multipliers& previous_bounds,
                       const std::map<TrajectoryNlp::RowKey, double>& previous_lambda);

}  // namespace ridgeline::planning::detail
