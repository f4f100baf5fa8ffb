// The transcription of the joint trajectory problem (trajectory_optimizer.hpp, eq. 14–24) into
// a sparse NLP  min f(x)  s.t.  g_l ≤ g(x) ≤ g_u,  x_l ≤ x ≤ x_u, independent of any solver.
// The optimizer wraps it in an Ipopt TNLP; tests evaluate it directly (finite-difference checks
// of the gradient and the Jacobian). The mathematics is documented in trajectory_optimizer.hpp.
#pragma once

#include <array>
#include <compare>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "planning/trajectory_optimizer.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning::detail {

/// One UAV on the shared grid: waypoints k = 0 … n (the initial guess) and their data.
struct GridUav {
  std::string name;
  std::vector<Vec3> guess_m;   ///< n + 1 waypoints at t_k = k·Δt
  std::vector<char> fixed;     ///< per waypoint: 1 if fixed at its guess (start, targets)
  double nominal_length_m = 0.0;  ///< ℓ = v0·Δt
  std::vector<double> min_length_m;  ///< per segment: lower bound of the horizontal length
  double max_length_m = 0.0;         ///< (v0 + Δv)·Δt
  double max_climb_m = 0.0;          ///< w_max·Δt (used when options.enforce_climb_rate)
  double tan_max_pitch = 0.0;        ///< tan θ_max
  /// G of the hard grade rows |d_z| ≤ G·|d_xy| (NlpSetup::grade_rows): a share of the flyable
  /// grade min(tan θ_max, w_max/(v0 − Δv)), leaving room for the corners the time
  /// parametrization rounds.
  double max_grade = 0.0;
  /// False when the climb limit already implies the pitch limit at the nominal length
  /// (enforce_climb_rate and w_max·Δt ≤ tan θ_max·ℓ): the penalty is then identically zero and
  /// its slacks and rows are left out.
  bool pitch_rows = true;
  int segments() const { return static_cast<int>(guess_m.size()) - 1; }
};

/// A pair whose separation is constrained at grid index k (and on the step k → k+1 at
/// interior_samples interior times, when k is not the last index).
struct SeparationCandidate {
  int uav_a = 0;
  int uav_b = 0;  ///< > uav_a
  int k = 0;
  int interior_samples = 0;
  double margin_m = 0.0;  ///< added to d_safe + separation_margin_m
};

/// A constant obstacle of one UAV's point q = (1 − τ)·p_k + τ·p_{k+1}: the segment [a, b] (a
/// point when a = b) that q must keep min_distance_m from,
///   |q − π(q)|² ≥ d²,  π(q) the point of [a, b] nearest to q.
/// The local re-plan (local_replan.hpp) uses it for a moving threat swept over a time interval
/// (a capsule: the centre's track, d = R + r_safe) and for another UAV's fixed reference at the
/// row's time (a point, d = d_safe). |q − π(q)|² is C¹ in q (the squared distance to a convex
/// set), with gradient 2(q − π(q)) and Hessian 2(I − u uᵀ) where π(q) is inside the segment (u
/// its direction), 2I beyond its ends.
struct ObstacleRow {
  int uav = 0;
  int k = 0;
  double tau = 0.0;  ///< in [0, 1); τ > 0 needs k < segments
  Vec3 a_m = Vec3::Zero();
  Vec3 b_m = Vec3::Zero();
  double min_distance_m = 0.0;  ///< > 0
  bool threat = true;           ///< a threat (else another UAV's reference)
  int source = 0;               ///< the threat's or the other UAV's index (messages, row keys)
};

struct NlpSetup {
  const world::Terrain* terrain = nullptr;
  std::vector<GridUav> uavs;
  double time_step_s = 1.0;
  world::SafetyLimits limits;
  TrajectoryOptimizerOptions options;
  std::vector<std::vector<int>> terrain_samples;       ///< per UAV, per segment (interior points)
  std::vector<std::vector<double>> clearance_extra_m;  ///< per UAV, per waypoint: extra margin
  /// Per UAV, per segment: 1 where the grade is a hard row G²·|d_xy|² − d_z² ≥ 0 (G =
  /// GridUav::max_grade); empty: no grade rows.
  std::vector<std::vector<char>> grade_rows;
  std::vector<SeparationCandidate> candidates;
  std::vector<ObstacleRow> obstacles;
};

class TrajectoryNlp {
 public:
  /// Builds the rows and the Jacobian structure. The setup must be consistent (the optimizer
  /// builds it); an inconsistent one is a programming error.
  explicit TrajectoryNlp(NlpSetup setup);

  int num_variables() const { return num_variables_; }
  int num_constraints() const { return static_cast<int>(rows_.size()); }
  int jacobian_nonzeros() const { return static_cast<int>(cols_.size()); }
  int separation_rows() const { return separation_rows_; }
  int obstacle_rows() const { return obstacle_rows_; }
  int max_grid_index() const { return max_index_; }

  void bounds(double* x_l, double* x_u, double* g_l, double* g_u) const;
  /// x from per-UAV waypoints (same sizes as the grid); slacks at their smallest feasible value.
  void pack(const std::vector<std::vector<Vec3>>& waypoints_m, double* x) const;
  void initial_point(double* x) const;
  std::vector<std::vector<Vec3>> unpack(const double* x) const;

  double objective(const double* x) const;
  void gradient(const double* x, double* grad) const;
  void constraints(const double* x, double* g) const;
  void jacobian_structure(int* rows, int* cols) const;
  void jacobian_values(const double* x, double* values) const;

  /// Suggested scaling of each row for the solver (rows in m² — speed band and separation —
  /// divided by 2·their length scale, so that all rows read in metres near their bounds).
  void row_scaling(double* scale) const;

  /// Hessian of the Lagrangian σ·∇²f + Σ_r λ_r·∇²g_r, lower triangle (row ≥ col), sparse.
  /// Exact for every term except the terrain's second derivatives ∇²H, which are central
  /// differences of Terrain::gradient (step hessian_terrain_step_m).
  int hessian_nonzeros() const { return static_cast<int>(hess_rows_.size()); }
  void hessian_structure(int* rows, int* cols) const;
  void hessian_values(const double* x, double sigma, const double* lambda, double* values) const;

  /// Cost breakdown (eq. 15–24) at x.
  std::vector<UavCost> costs(const double* x, double* collision_cost) const;
  /// The most violated rows at x (by how much they miss their bounds, in the row's units), one
  /// line each, worst first, at most max_lines.
  std::string worst_rows(const double* x, int max_lines) const;

  const NlpSetup& setup() const { return setup_; }

  /// What a row constrains, independent of its position in this NLP: a refined NLP (more
  /// samples, more candidates) keeps the keys of the rows it shares with the previous one, so
  /// their multipliers can warm-start the next solve.
  struct RowKey {
    int kind = 0;
    int uav = 0;
    int other = -1;
    int k = 0;
    double tau = 0.0;
    auto operator<=>(const RowKey&) const = default;
  };
  RowKey row_key(int row) const;

 private:
  enum class RowKind {
    kSpeed,
    kClimb,
    kGrade,
    kPitchUp,
    kPitchDown,
    kTurn,
    kTerrain,
    kSeparation,
    kObstacle
  };
  struct Term {
    int point = 0;   ///< global point index
    double weight = 0.0;
  };
  struct Row {
    Row(RowKind kind_in, int uav_in, int other_in, int k_in, double tau_in = 0.0)
        : kind(kind_in), uav(uav_in), other(other_in), k(k_in), tau(tau_in) {}
    RowKind kind = RowKind::kSpeed;
    int uav = 0;
    int other = -1;     ///< kSeparation: the other UAV; kObstacle: index into setup.obstacles
    int k = 0;          ///< segment, vertex or grid index
    double tau = 0.0;   ///< fraction along the segment/step
    double lower = 0.0;
    double upper = 0.0;
    int col_begin = 0;  ///< into cols_
    int col_end = 0;
    Term terms[4];  ///< kTerrain, kSeparation, kObstacle: point combination
    int num_terms = 0;
  };

  int point(int uav, int k) const;  ///< global point index of UAV uav at grid index k (holds)
  int pitch_slack(int uav, int k) const { return pitch_slack_base_[uav] + k; }
  int turn_slack(int uav, int k) const { return turn_slack_base_[uav] + k - 1; }
  void add_row(Row row, const std::vector<int>& cols);
  void add_terrain_row(int uav, int k, double tau, double required_m);
  std::string describe(const Row& row) const;
  double row_value(const Row& row, const double* x) const;

  NlpSetup setup_;
  std::vector<int> point_base_;        ///< first global point index of each UAV
  std::vector<int> pitch_slack_base_;  ///< variable index of each UAV's first pitch slack
  std::vector<int> turn_slack_base_;
  int num_points_ = 0;
  int num_variables_ = 0;
  int max_index_ = 0;
  int separation_rows_ = 0;
  int obstacle_rows_ = 0;
  std::vector<Row> rows_;
  std::vector<int> cols_;

  // Rows of each UAV's segments (speed, pitch up, pitch down, grade; −1: none) and vertices
  // (turn), for the Hessian's element loops.
  std::vector<std::vector<std::array<int, 4>>> segment_rows_;
  std::vector<std::vector<int>> turn_rows_;
  // Hessian: the element loop (hessian_loop) visits entries in a fixed order; slot m of that
  // order accumulates into hess_slot_[m] of the lower-triangle structure (hess_rows_, hess_cols_).
  template <typename Add>
  void hessian_loop(const double* x, double sigma, const double* lambda, Add&& add) const;
  std::vector<int> hess_rows_;
  std::vector<int> hess_cols_;
  std::vector<int> hess_slot_;
};

}  // namespace ridgeline::planning::detail
