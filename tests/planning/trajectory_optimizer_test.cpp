#include "planning/trajectory_optimizer.hpp"

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "planning/plan_validation.hpp"
#include "planning/time_parametrization.hpp"
#include "planning/trajectory_nlp.hpp"
#include "planning/team_scenarios.hpp"

namespace ridgeline::planning {
namespace {


using world::Peak;
using world::PeakCombination;
using world::PeakTerrain;
using world::PeakTerrainConfig;

// An independent dense check, finer than the optimizer's own (2 m, 0.02 s).
PlanValidationReport fine_check(const world::Terrain& terrain, const TrajectoryResult& r,
                                const world::SafetyLimits& limits) {
  PlanValidationOptions v;
  v.terrain_step_m = 0.5;
  v.separation_period_s = 0.005;
  return validate_plan(terrain, r.paths, limits, v);
}

// A small NLP with every row and cost kind active: three UAVs of different lengths (one holds at
// its end), an intermediate target, candidates with interior separation samples and J_col, and
// waypoints perturbed so pitch/turn slacks and the speed term are away from their kinks.
struct FdFixture {
  PeakTerrain terrain = default_like_terrain(PeakCombination::kSum);  // smooth: no max kinks
  detail::NlpSetup setup;
  std::vector<double> x;

  FdFixture() {
    TrajectoryOptimizerOptions o;
    o.weight_altitude = 0.7;
    o.collision_soft_distance_m = 200.0;  // J_col active for most candidate pairs
    o.convexify_hessian = false;          // the exact Hessian, checked by differences below
    setup.terrain = &terrain;
    setup.time_step_s = 2.0;
    setup.options = o;
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 3.0);
    std::uniform_real_distribution<double> slack(0.01, 0.2);
    const int lengths[3] = {8, 6, 9};
    for (int i = 0; i < 3; ++i) {
      detail::GridUav u;
      u.name = fmt::format("u{}", i);
      u.nominal_length_m = 20.0;
      u.max_length_m = 30.0;
      u.max_climb_m = 6.0;
      u.tan_max_pitch = std::tan(deg_to_rad(30.0));
      u.max_grade = 0.5;
      for (int k = 0; k <= lengths[i]; ++k) {
        u.guess_m.emplace_back(400.0 + 19.0 * k + 25.0 * i, 300.0 + 8.0 * k * (i - 1) + 10.0 * i,
                               150.0 + 4.0 * k);
        u.fixed.push_back(k == 0 || k == lengths[i] || (i == 2 && k == 4));
      }
      u.min_length_m.assign(lengths[i], 10.0);
      setup.uavs.push_back(u);
      setup.terrain_samples.emplace_back(lengths[i], 2);
      setup.clearance_extra_m.emplace_back(lengths[i] + 1, 0.3);
      // Grade rows on every segment of u0, every other one of u1, none on u2.
      setup.grade_rows.emplace_back(lengths[i], 0);
      for (int k = 0; k < lengths[i]; ++k) setup.grade_rows[i][k] = i == 0 || (i == 1 && k % 2 == 0);
    }
    for (int k = 0; k <= 9; ++k) {
      setup.candidates.push_back({0, 1, k, 2, 0.0});
      setup.candidates.push_back({1, 2, k, 1, 0.5});
    }
    // Obstacle rows (the local re-plan's): capsules (swept threats) and a point (another UAV's
    // reference), at grid points and interior samples.
    setup.obstacles.push_back(
        {0, 3, 0.0, Vec3(450.0, 320.0, 150.0), Vec3(500.0, 260.0, 190.0), 40.0, true, 0});
    setup.obstacles.push_back(
        {0, 5, 0.4, Vec3(480.0, 320.0, 150.0), Vec3(500.0, 360.0, 160.0), 30.0, true, 0});
    setup.obstacles.push_back(
        {1, 2, 0.5, Vec3(470.0, 310.0, 170.0), Vec3(470.0, 310.0, 170.0), 12.0, false, 2});
    setup.obstacles.push_back(
        {2, 6, 0.0, Vec3(600.0, 360.0, 160.0), Vec3(660.0, 350.0, 200.0), 25.0, true, 1});
    const detail::TrajectoryNlp nlp(setup);
    x.resize(nlp.num_variables());
    nlp.initial_point(x.data());
    const int coordinates = 3 * (lengths[0] + lengths[1] + lengths[2] + 3);
    for (int v = 0; v < nlp.num_variables(); ++v) x[v] += v < coordinates ? noise(rng) : slack(rng);
  }
};

// Central differences with step h have truncation error O(h²·f''') and round-off
// O(ε·|f|/h): with h = 1e-4 m and |f| ~ 1e4 both stay below 1e-5, so 1e-4 (absolute, plus
// 1e-6 relative) separates a wrong derivative from numerical noise.
constexpr double kFdStep = 1e-4;
constexpr double kFdAbsTol = 1e-4;
constexpr double kFdRelTol = 1e-6;

TEST(TrajectoryNlp, GradientMatchesCentralDifferences) {
  FdFixture f;
  const detail::TrajectoryNlp nlp(f.setup);
  ASSERT_GT(nlp.separation_rows(), 0);
  ASSERT_EQ(nlp.obstacle_rows(), 4);
  std::vector<double> grad(nlp.num_variables());
  nlp.gradient(f.x.data(), grad.data());
  double collision = 0.0;
  nlp.costs(f.x.data(), &collision);
  ASSERT_GT(collision, 0.0) << "J_col must be active for the check to cover it";
  int checked = 0;
  for (int v = 0; v < nlp.num_variables(); ++v) {
    std::vector<double> xp = f.x;
    std::vector<double> xm = f.x;
    xp[v] += kFdStep;
    xm[v] -= kFdStep;
    const double fd = (nlp.objective(xp.data()) - nlp.objective(xm.data())) / (2.0 * kFdStep);
    EXPECT_NEAR(grad[v], fd, kFdAbsTol + kFdRelTol * std::abs(fd)) << "variable " << v;
    ++checked;
  }
  EXPECT_EQ(checked, nlp.num_variables());
}

TEST(TrajectoryNlp, JacobianMatchesCentralDifferences) {
  FdFixture f;
  const detail::TrajectoryNlp nlp(f.setup);
  const int m = nlp.num_constraints();
  const int nnz = nlp.jacobian_nonzeros();
  std::vector<int> rows(nnz);
  std::vector<int> cols(nnz);
  std::vector<double> values(nnz);
  nlp.jacobian_structure(rows.data(), cols.data());
  nlp.jacobian_values(f.x.data(), values.data());
  // Dense reference by central differences, and the sparse values scattered into a dense matrix:
  // entries outside the structure must be zero in the reference.
  MatX sparse = MatX::Zero(m, nlp.num_variables());
  for (int e = 0; e < nnz; ++e) {
    EXPECT_EQ(sparse(rows[e], cols[e]), 0.0) << "duplicate entry " << rows[e] << "," << cols[e];
    sparse(rows[e], cols[e]) += values[e];
  }
  std::vector<double> gp(m);
  std::vector<double> gm(m);
  for (int v = 0; v < nlp.num_variables(); ++v) {
    std::vector<double> xp = f.x;
    std::vector<double> xm = f.x;
    xp[v] += kFdStep;
    xm[v] -= kFdStep;
    nlp.constraints(xp.data(), gp.data());
    nlp.constraints(xm.data(), gm.data());
    for (int r = 0; r < m; ++r) {
      const double fd = (gp[r] - gm[r]) / (2.0 * kFdStep);
      EXPECT_NEAR(sparse(r, v), fd, kFdAbsTol + kFdRelTol * std::abs(fd))
          << "row " << r << " variable " << v;
    }
  }
}

// ∇²L = σ∇²f + Σ λ_r ∇²g_r against central differences of the exact gradient ∇L = σ∇f + Jᵀλ.
// The terrain part of the Hessian is itself a difference of Terrain::gradient (1e-3 m step), so
// the tolerance is looser than for the first derivatives: 1e-3 absolute + 1e-4 relative.
TEST(TrajectoryNlp, HessianOfLagrangianMatchesDifferencesOfTheGradient) {
  FdFixture f;
  const detail::TrajectoryNlp nlp(f.setup);
  const int n = nlp.num_variables();
  const int m = nlp.num_constraints();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> multiplier(-3.0, 3.0);
  std::vector<double> lambda(m);
  for (double& l : lambda) l = multiplier(rng);
  const double sigma = 0.7;
  auto lagrangian_gradient = [&](const std::vector<double>& x) {
    std::vector<double> g(n);
    nlp.gradient(x.data(), g.data());
    VecX out = sigma * Eigen::Map<VecX>(g.data(), n);
    std::vector<int> rows(nlp.jacobian_nonzeros());
    std::vector<int> cols(nlp.jacobian_nonzeros());
    std::vector<double> values(nlp.jacobian_nonzeros());
    nlp.jacobian_structure(rows.data(), cols.data());
    nlp.jacobian_values(x.data(), values.data());
    for (int e = 0; e < nlp.jacobian_nonzeros(); ++e) out[cols[e]] += lambda[rows[e]] * values[e];
    return out;
  };
  const int nnz = nlp.hessian_nonzeros();
  std::vector<int> rows(nnz);
  std::vector<int> cols(nnz);
  std::vector<double> values(nnz);
  nlp.hessian_structure(rows.data(), cols.data());
  nlp.hessian_values(f.x.data(), sigma, lambda.data(), values.data());
  MatX H = MatX::Zero(n, n);
  for (int e = 0; e < nnz; ++e) {
    ASSERT_GE(rows[e], cols[e]) << "lower triangle only";
    EXPECT_EQ(H(rows[e], cols[e]), 0.0) << "duplicate entry";
    H(rows[e], cols[e]) = values[e];
    H(cols[e], rows[e]) = values[e];
  }
  for (int v = 0; v < n; ++v) {
    std::vector<double> xp = f.x;
    std::vector<double> xm = f.x;
    xp[v] += kFdStep;
    xm[v] -= kFdStep;
    const VecX fd = (lagrangian_gradient(xp) - lagrangian_gradient(xm)) / (2.0 * kFdStep);
    for (int r = 0; r < n; ++r)
      EXPECT_NEAR(H(r, v), fd[r], 1e-3 + 1e-4 * std::abs(fd[r])) << "entry " << r << "," << v;
  }
}

// The convexified Hessian (the default) must be positive semidefinite for any multipliers, and
// differ from the exact one only by added curvature (H_c − H_exact ⪰ 0): each element block is
// replaced by its projection onto the PSD cone, which only lifts negative eigenvalues to zero.
// Tolerances: eigenvalues of matrices with entries up to ~1e3, computed in double precision,
// are accurate to ~1e-9 relative to the largest, so −1e-8·max|λ| separates a real negative
// eigenvalue from round-off.
TEST(TrajectoryNlp, ConvexifiedHessianIsPositiveSemidefiniteAndOnlyAddsCurvature) {
  FdFixture f;
  detail::NlpSetup convex_setup = f.setup;
  convex_setup.options.convexify_hessian = true;
  const detail::TrajectoryNlp exact(f.setup);
  const detail::TrajectoryNlp convex(convex_setup);
  const int n = exact.num_variables();
  ASSERT_EQ(convex.num_variables(), n);
  ASSERT_EQ(convex.hessian_nonzeros(), exact.hessian_nonzeros());
  auto dense = [&](const detail::TrajectoryNlp& nlp, const std::vector<double>& lambda) {
    const int nnz = nlp.hessian_nonzeros();
    std::vector<int> rows(nnz);
    std::vector<int> cols(nnz);
    std::vector<double> values(nnz);
    nlp.hessian_structure(rows.data(), cols.data());
    nlp.hessian_values(f.x.data(), 1.0, lambda.data(), values.data());
    MatX H = MatX::Zero(n, n);
    for (int e = 0; e < nnz; ++e) {
      H(rows[e], cols[e]) = values[e];
      H(cols[e], rows[e]) = values[e];
    }
    return H;
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> multiplier(-3.0, 3.0);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> lambda(exact.num_constraints());
    for (double& l : lambda) l = multiplier(rng);
    const MatX He = dense(exact, lambda);
    const MatX Hc = dense(convex, lambda);
    const Eigen::SelfAdjointEigenSolver<MatX> exact_eigen(He);
    ASSERT_LT(exact_eigen.eigenvalues().minCoeff(), -1e-3) << "the exact Hessian must be indefinite";
    const double scale = std::max(1.0, Hc.cwiseAbs().maxCoeff());
    const Eigen::SelfAdjointEigenSolver<MatX> convex_eigen(Hc);
    EXPECT_GE(convex_eigen.eigenvalues().minCoeff(), -1e-8 * scale) << "trial " << trial;
    const Eigen::SelfAdjointEigenSolver<MatX> added(MatX(Hc - He));
    EXPECT_GE(added.eigenvalues().minCoeff(), -1e-8 * scale) << "trial " << trial;
  }
}

TrajectoryUav straight_uav(const std::string& name, const world::Terrain& terrain, const Vec3& a,
                           const Vec3& b) {
  TrajectoryUav u;
  u.name = name;
  u.initial_path_m = lifted_line(terrain, a, b);
  return u;
}

int count_if_kind(const TimeParametrizationResult& r, LimitKind kind) {
  return static_cast<int>(std::count_if(r.violations.begin(), r.violations.end(),
                                        [&](const LimitViolation& v) { return v.kind == kind; }));
}

// The guesses timed at cruise along their polylines (for "the guess is unsafe" preconditions).
std::vector<TimedPath> timed_at_cruise(const TrajectoryProblem& p) {
  std::vector<TimedPath> out;
  for (const TrajectoryUav& u : p.uavs) {
    TimedPath t;
    t.name = u.name;
    double time = 0.0;
    for (std::size_t k = 0; k < u.initial_path_m.size(); ++k) {
      if (k > 0) time += (u.initial_path_m[k] - u.initial_path_m[k - 1]).norm() / u.vehicle.cruise_speed_m_s;
      t.waypoints_m.push_back(u.initial_path_m[k]);
      t.times_s.push_back(time);
    }
    out.push_back(t);
  }
  return out;
}

TEST(TrajectoryOptimizer, SingleUavCrossesARidgeWithClearance) {
  PeakTerrainConfig c;
  c.peaks = {Peak{1000.0, 1000.0, 200.0, 60.0, 500.0}};  // a north-south ridge across the route
  const PeakTerrain terrain(c);
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  problem.uavs.push_back(straight_uav("solo", terrain, Vec3(300.0, 1000.0, 60.0), Vec3(1700.0, 1000.0, 60.0)));
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 40;  // test time; the bench runs the full sizes
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  const PlanValidationReport check = fine_check(terrain, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
  EXPECT_GE(check.min_clearance_m, problem.limits.terrain_clearance_m);
  // Where it crosses the ridge's axis x = 1000 it is at least h_safe above the ridge there: it
  // climbs over the crest (200 m), detours to where the ridge is lower (H falls as
  // exp(−((y − 1000)/500)²)), or both; which one is the optimizer's trade-off of J_L and J_H.
  const auto& w = r.paths[0].waypoints_m;
  int crossings = 0;
  for (std::size_t k = 0; k + 1 < w.size(); ++k) {
    if ((w[k].x() - 1000.0) * (w[k + 1].x() - 1000.0) > 0.0) continue;
    const double s = (1000.0 - w[k].x()) / (w[k + 1].x() - w[k].x());
    const Vec3 p = w[k] + s * (w[k + 1] - w[k]);
    EXPECT_GE(p.z() - terrain.height(p.x(), p.y()), problem.limits.terrain_clearance_m)
        << "crossing at y " << p.y();
    ++crossings;
  }
  EXPECT_GE(crossings, 1);
  // The guess, a line lifted over the ridge, climbs steeper than the vehicle flies; the solution
  // must be flyable as timed (grade rows), so its J is not compared with the guess's.
  const TimeParametrizationResult flown = time_parametrize_timed(
      r.paths[0].waypoints_m, r.paths[0].times_s, problem.uavs[0].vehicle);
  EXPECT_EQ(count_if_kind(flown, LimitKind::kPitch) + count_if_kind(flown, LimitKind::kClimbRate), 0);
  EXPECT_NEAR((w.back() - problem.uavs[0].initial_path_m.back()).norm(), 0.0, 1e-9);
  EXPECT_NEAR((w.front() - problem.uavs[0].initial_path_m.front()).norm(), 0.0, 1e-9);
}

TEST(TrajectoryOptimizer, CrossingUavsAreSeparatedAtEqualTimes) {
  const PeakTerrain flat(PeakTerrainConfig{});
  TrajectoryProblem problem;
  problem.terrain = &flat;
  // Straight lines that cross at (500, 500) at the same time (50 s at 10 m/s).
  problem.uavs.push_back(straight_uav("east", flat, Vec3(0.0, 500.0, 100.0), Vec3(1000.0, 500.0, 100.0)));
  problem.uavs.push_back(straight_uav("north", flat, Vec3(500.0, 0.0, 100.0), Vec3(500.0, 1000.0, 100.0)));
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 50;
  ASSERT_LT(validate_plan(flat, timed_at_cruise(problem), problem.limits).min_separation_m, 1.0)
      << "the guesses must collide for this test to mean anything";
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  EXPECT_GT(r.separation_rows, 0);
  const PlanValidationReport check = fine_check(flat, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
  EXPECT_GE(check.min_separation_m, problem.limits.separation_m);
  // At the grid times themselves the rows hold with the margin (up to Ipopt's tolerance).
  for (std::size_t k = 0; k < r.paths[0].waypoints_m.size() && k < r.paths[1].waypoints_m.size(); ++k)
    EXPECT_GE((r.paths[0].waypoints_m[k] - r.paths[1].waypoints_m[k]).norm(),
              problem.limits.separation_m + o.separation_margin_m - 1e-4);
}

// The per-solve iteration limit is max(max_iterations, iterations_per_uav × UAVs): the crossing
// pair stops at a limit of 3 iterations, and solves when the per-UAV share lifts it to 500.
TEST(TrajectoryOptimizer, IterationLimitGrowsWithTheTeam) {
  const PeakTerrain flat(PeakTerrainConfig{});
  TrajectoryProblem problem;
  problem.terrain = &flat;
  problem.uavs.push_back(
      straight_uav("east", flat, Vec3(0.0, 500.0, 100.0), Vec3(1000.0, 500.0, 100.0)));
  problem.uavs.push_back(
      straight_uav("north", flat, Vec3(500.0, 0.0, 100.0), Vec3(500.0, 1000.0, 100.0)));
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 30;
  o.max_iterations = 3;
  o.iterations_per_uav = 0;
  const TrajectoryResult limited = optimize_trajectories(problem, o);
  EXPECT_EQ(limited.status, TrajectoryStatus::kIterationLimit) << limited.message;
  EXPECT_TRUE(limited.paths.empty());
  o.iterations_per_uav = 250;
  const TrajectoryResult scaled = optimize_trajectories(problem, o);
  EXPECT_TRUE(scaled.ok()) << to_string(scaled.status) << ": " << scaled.message;
  EXPECT_GT(scaled.ipopt_iterations, 3);
  o.iterations_per_uav = -1;
  EXPECT_EQ(optimize_trajectories(problem, o).status, TrajectoryStatus::kInvalidInput);
}

TEST(TrajectoryOptimizer, ThreeUavsOnDefaultLikeTerrainPassDenseValidation) {
  const PeakTerrain terrain = default_like_terrain();
  const TrajectoryProblem problem = straight_line_team(terrain, 3);
  TrajectoryOptimizerOptions o;
  // 50 rather than the scenario's 100 waypoints keeps the test short on a loaded 2-core machine;
  // bench/trajectory_optimizer_bench.cpp measures 3 × 100 (its median is the figure to quote).
  o.waypoints_per_uav = 50;
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  ASSERT_EQ(r.paths.size(), 3u);
  EXPECT_TRUE(r.validation.passed());
  const PlanValidationReport check = fine_check(terrain, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
  ASSERT_EQ(r.costs.size(), 3u);
  for (const UavCost& c : r.costs) {
    EXPECT_GT(c.range, 0.0);
    EXPECT_NEAR(c.total, o.weight_range * c.range + o.weight_pitch * c.pitch + o.weight_turn * c.turn +
                             o.weight_altitude * c.altitude, 1e-6 * std::abs(c.total));
  }
  std::printf("3 UAVs x %d: %d vars, %d rows (%d separation), %d iterations, %d solves, solve "
              "%.3f s, total %.3f s, min clearance %.2f m, min separation %.2f m, J %.1f\n",
              o.waypoints_per_uav, r.variables, r.constraints, r.separation_rows, r.ipopt_iterations,
              r.solves, r.solve_time_s, r.total_time_s, r.validation.min_clearance_m,
              r.validation.min_separation_m, r.objective);
}

// Without interior terrain samples and margin the first solution only keeps clearance at the
// waypoints; narrow peaks between them break it. The dense check must catch that and the
// refinement must repair it — the result is never returned unvalidated.
TEST(TrajectoryOptimizer, DenseValidationFailureIsRefinedAndResolved) {
  PeakTerrainConfig c;
  for (int m = 0; m < 6; ++m) c.peaks.push_back(Peak{400.0 + 150.0 * m, 1000.0 + 20.0 * (m % 2), 120.0, 12.0, 12.0});
  const PeakTerrain terrain(c);
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  problem.uavs.push_back(straight_uav("bumpy", terrain, Vec3(200.0, 1000.0, 60.0), Vec3(1500.0, 1000.0, 60.0)));
  // 120 m spikes 12 m wide: no 30° airframe flies over them on this line; a steep one
  // (75°, 20 m/s climb) isolates what is tested here, the terrain refinement.
  problem.uavs[0].vehicle.max_pitch_rad = deg_to_rad(75.0);
  problem.uavs[0].vehicle.max_climb_rate_m_s = 20.0;
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 40;
  o.terrain_samples_per_segment = 0;
  o.clearance_margin_m = 0.0;
  o.weight_altitude = 2.0;  // pull the path down onto the clearance floor
  const TrajectoryResult r = optimize_trajectories(problem, o);
  ASSERT_TRUE(r.ok()) << to_string(r.status) << ": " << r.message;
  EXPECT_EQ(r.status, TrajectoryStatus::kSolvedAfterRefinement);
  EXPECT_GE(r.solves, 2);
  const PlanValidationReport check = fine_check(terrain, r, problem.limits);
  EXPECT_TRUE(check.passed()) << check.summary();
}

TEST(TrajectoryOptimizer, TwoUavsForcedToTheSameFinalPointFailWithTheConstraintAndPlace) {
  const PeakTerrain flat(PeakTerrainConfig{});
  TrajectoryProblem problem;
  problem.terrain = &flat;
  problem.uavs.push_back(straight_uav("a", flat, Vec3(0.0, 0.0, 100.0), Vec3(800.0, 800.0, 100.0)));
  problem.uavs.push_back(straight_uav("b", flat, Vec3(800.0, 0.0, 100.0), Vec3(800.0, 800.0, 100.0)));
  const TrajectoryResult r = optimize_trajectories(problem, TrajectoryOptimizerOptions{});
  EXPECT_EQ(r.status, TrajectoryStatus::kInfeasible);
  EXPECT_TRUE(r.paths.empty());
  EXPECT_NE(r.message.find("separation (eq. 21)"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("(800.0, 800.0, 100.0)"), std::string::npos) << r.message;
}

TEST(TrajectoryOptimizer, TargetWalledInAboveTheCeilingFailsWithoutAPath) {
  // A ring of 700 m peaks (above H_max = 500 m) around the target.
  PeakTerrainConfig c;
  for (int m = 0; m < 24; ++m) {
    const double a = 2.0 * kPi * m / 24;
    c.peaks.push_back(Peak{1000.0 + 250.0 * std::cos(a), 1000.0 + 250.0 * std::sin(a), 700.0, 60.0, 60.0});
  }
  const PeakTerrain terrain(c);
  TrajectoryProblem problem;
  problem.terrain = &terrain;
  TrajectoryUav u;
  u.name = "walled";
  u.initial_path_m = lifted_line(terrain, Vec3(200.0, 200.0, 100.0), Vec3(1000.0, 1000.0, 100.0));
  problem.uavs.push_back(u);
  TrajectoryOptimizerOptions o;
  o.waypoints_per_uav = 40;
  o.max_iterations = 300;
  o.time_budget_s = 5.0;
  const TrajectoryResult r = optimize_trajectories(problem, o);
  EXPECT_FALSE(r.ok()) << to_string(r.status);
  EXPECT_TRUE(r.paths.empty());
  EXPECT_TRUE(r.message.find("terrain clearance") != std::string::npos ||
              r.message.find("altitude") != std::string::npos)
      << r.message;
  EXPECT_NE(r.message.find("walled"), std::string::npos) << r.message;
}

TEST(TrajectoryOptimizer, BadInputNamesTheField) {
  const PeakTerrain flat(PeakTerrainConfig{});
  TrajectoryProblem problem;
  problem.terrain = &flat;
  problem.uavs.push_back(straight_uav("low", flat, Vec3(0.0, 0.0, 100.0), Vec3(500.0, 0.0, 10.0)));
  TrajectoryResult r = optimize_trajectories(problem, TrajectoryOptimizerOptions{});
  EXPECT_EQ(r.status, TrajectoryStatus::kInvalidInput);
  EXPECT_NE(r.message.find("uavs[0].initial_path_m["), std::string::npos) << r.message;

  problem.uavs[0] = straight_uav("ok", flat, Vec3(0.0, 0.0, 100.0), Vec3(500.0, 0.0, 100.0));
  problem.uavs[0].target_indices = {3, 2};
  r = optimize_trajectories(problem, TrajectoryOptimizerOptions{});
  EXPECT_EQ(r.status, TrajectoryStatus::kInvalidInput);
  EXPECT_NE(r.message.find("uavs[0].target_indices"), std::string::npos) << r.message;

  problem.uavs[0].target_indices.clear();
  TrajectoryOptimizerOptions bad;
  bad.validation_terrain_step_m = 6.0;
  r = optimize_trajectories(problem, bad);
  EXPECT_EQ(r.status, TrajectoryStatus::kInvalidInput);
  EXPECT_NE(r.message.find("options.validation_terrain_step_m"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace ridgeline::planning
