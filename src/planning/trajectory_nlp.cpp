#include "planning/trajectory_nlp.hpp"

#include <ceres/jet.h>
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>

#include "planning/psd_projection.hpp"

namespace ridgeline::planning::detail {
namespace {

// ε of h = √(d_x² + d_y² + ε²): keeps norms and their derivatives finite at d = 0.
constexpr double kNormEps_m = 1e-3;
// ε_c of the smooth climb σ(d_z) = ½(d_z + √(d_z² + ε_c²)).
constexpr double kClimbEps_m = 0.1;
constexpr double kInf = 1e19;  // Ipopt's default "infinity"

// Second-order forward-mode automatic differentiation: value, gradient and Hessian of an
// expression in N seed variables. Only the operations the element functions use.
template <int N>
struct Dual2 {
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, N, N>;
  double v = 0.0;
  Vec g = Vec::Zero();
  Mat H = Mat::Zero();

  Dual2() = default;
  Dual2(double value) : v(value) {}  // NOLINT: constants mix freely with variables
  static Dual2 variable(double value, int k) {
    Dual2 d(value);
    d.g[k] = 1.0;
    return d;
  }
  Dual2& operator+=(const Dual2& o) {
    v += o.v;
    g += o.g;
    H += o.H;
    return *this;
  }
  friend Dual2 operator+(Dual2 a, const Dual2& b) { return a += b; }
  friend Dual2 operator+(Dual2 a, double b) {
    a.v += b;
    return a;
  }
  friend Dual2 operator+(double a, Dual2 b) { return b + a; }
  friend Dual2 operator-(Dual2 a) {
    a.v = -a.v;
    a.g = -a.g;
    a.H = -a.H;
    return a;
  }
  friend Dual2 operator-(const Dual2& a, const Dual2& b) { return a + (-b); }
  friend Dual2 operator-(Dual2 a, double b) {
    a.v -= b;
    return a;
  }
  friend Dual2 operator-(double a, const Dual2& b) { return (-b) + a; }
  friend Dual2 operator*(Dual2 a, double b) {
    a.v *= b;
    a.g *= b;
    a.H *= b;
    return a;
  }
  friend Dual2 operator*(double a, Dual2 b) { return b * a; }
  friend Dual2 operator*(const Dual2& a, const Dual2& b) {
    Dual2 r;
    r.v = a.v * b.v;
    r.g = a.v * b.g + b.v * a.g;
    r.H = a.v * b.H + b.v * a.H + a.g * b.g.transpose() + b.g * a.g.transpose();
    return r;
  }
  friend Dual2 operator/(const Dual2& a, double b) { return a * (1.0 / b); }
  friend Dual2 operator/(const Dual2& a, const Dual2& b) {
    Dual2 inv;  // 1/b
    inv.v = 1.0 / b.v;
    inv.g = -b.g * (inv.v * inv.v);
    inv.H = -b.H * (inv.v * inv.v) + (2.0 * inv.v * inv.v * inv.v) * (b.g * b.g.transpose());
    return a * inv;
  }
  friend Dual2 sqrt(const Dual2& a) {
    Dual2 r;
    r.v = std::sqrt(a.v);
    r.g = a.g / (2.0 * r.v);
    r.H = a.H / (2.0 * r.v) - (a.g * a.g.transpose()) / (4.0 * r.v * r.v * r.v);
    return r;
  }
};

// The point of segment [a, b] nearest to q; *interior says whether it lies strictly between
// the ends (then the squared distance has Hessian 2(I − u uᵀ), else 2I).
Vec3 nearest_on_segment(const Vec3& q, const Vec3& a, const Vec3& b, bool* interior) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  *interior = false;
  if (length2 < 1e-18) return a;
  const double s = (q - a).dot(ab) / length2;
  if (s <= 0.0) return a;
  if (s >= 1.0) return b;
  *interior = true;
  return a + s * ab;
}

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat9 = Eigen::Matrix<double, 9, 9>;

struct ElementParams {
  double nominal_m = 1.0;  // ℓ
  double climb_current = 0.0;
  double turn_current = 0.0;
  double speed_current = 0.0;
};

// Segment a → b: parts[0] = (I/I0)·L without the turn share (eq. 22), parts[1] = ℓ·tan²θ.
template <typename T>
void segment_parts(const T* a, const T* b, const ElementParams& q, T* parts) {
  using std::sqrt;
  const T dx = b[0] - a[0];
  const T dy = b[1] - a[1];
  const T dz = b[2] - a[2];
  const T h2 = dx * dx + dy * dy + T(kNormEps_m * kNormEps_m);
  const T h = sqrt(h2);
  const T length = sqrt(h2 + dz * dz);
  const T climb = 0.5 * (dz + sqrt(dz * dz + T(kClimbEps_m * kClimbEps_m)));
  const T deviation = h / q.nominal_m - 1.0;
  parts[0] = length + q.climb_current * climb + q.speed_current * length * deviation * deviation;
  parts[1] = dz * dz / q.nominal_m;  // ℓ·(d_z/ℓ)²: the grade at the nominal length
}

// cos φ between the horizontal steps u = b − a and v = c − b.
template <typename T>
T turn_cosine_of_steps(const T& ux, const T& uy, const T& vx, const T& vy) {
  using std::sqrt;
  const T eps2 = T(kNormEps_m * kNormEps_m);
  return (ux * vx + uy * vy) / (sqrt(ux * ux + uy * uy + eps2) * sqrt(vx * vx + vy * vy + eps2));
}

// cos φ between the horizontal directions of a → b and b → c (only x, y are read).
template <typename T>
T turn_cosine(const T* a, const T* b, const T* c) {
  return turn_cosine_of_steps<T>(b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1]);
}

// Vertex b between a and c, cos φ = turn_cosine(a, b, c) given: parts[0] = κ_turn·τ·½(L_ab + L_bc)
// (the turn share of eq. 22), parts[1] = ℓ·τ, τ = 1 − cos φ.
template <typename T>
void vertex_parts(const T* a, const T* b, const T* c, const T& cosine, const ElementParams& q,
                  T* parts) {
  using std::sqrt;
  const T tau = 1.0 - cosine;
  const T eps2 = T(kNormEps_m * kNormEps_m);
  T l_ab = eps2;
  T l_bc = eps2;
  for (int d = 0; d < 3; ++d) {
    l_ab += (b[d] - a[d]) * (b[d] - a[d]);
    l_bc += (c[d] - b[d]) * (c[d] - b[d]);
  }
  parts[0] = q.turn_current * tau * 0.5 * (sqrt(l_ab) + sqrt(l_bc));
  parts[1] = q.nominal_m * tau;
}

}  // namespace

TrajectoryNlp::TrajectoryNlp(NlpSetup setup) : setup_(std::move(setup)) {
  const auto& o = setup_.options;
  const int n_uav = static_cast<int>(setup_.uavs.size());
  point_base_.resize(n_uav);
  pitch_slack_base_.resize(n_uav);
  turn_slack_base_.resize(n_uav);
  for (int i = 0; i < n_uav; ++i) {
    point_base_[i] = num_points_;
    num_points_ += static_cast<int>(setup_.uavs[i].guess_m.size());
    max_index_ = std::max(max_index_, setup_.uavs[i].segments());
  }
  num_variables_ = 3 * num_points_;
  for (int i = 0; i < n_uav; ++i) {
    pitch_slack_base_[i] = setup_.uavs[i].pitch_rows ? num_variables_ : -1;
    if (setup_.uavs[i].pitch_rows) num_variables_ += setup_.uavs[i].segments();
  }
  for (int i = 0; i < n_uav; ++i) {
    turn_slack_base_[i] = num_variables_;
    num_variables_ += std::max(0, setup_.uavs[i].segments() - 1);
  }

  const double floor_m = setup_.limits.clearance_floor_m(*setup_.terrain);
  const double cos_turn = std::cos(o.max_turn_angle_rad);
  for (int i = 0; i < n_uav; ++i) {
    const GridUav& u = setup_.uavs[i];
    const int n = u.segments();
    segment_rows_.emplace_back(n);
    turn_rows_.emplace_back(std::max(n, 1), -1);
    for (int k = 0; k < n; ++k) {
      const int p0 = point(i, k);
      const int p1 = point(i, k + 1);
      // A segment between two fixed points has constant speed and climb rows: left out (the
      // local re-plan's junctions with the old reference are such segments).
      const bool both_fixed = u.fixed[k] && u.fixed[k + 1];
      segment_rows_[i][k][0] = both_fixed ? -1 : static_cast<int>(rows_.size());
      Row speed(RowKind::kSpeed, i, -1, k);
      speed.lower = u.min_length_m[k] * u.min_length_m[k];
      speed.upper = u.max_length_m * u.max_length_m;
      if (!both_fixed) add_row(speed, {3 * p0, 3 * p0 + 1, 3 * p1, 3 * p1 + 1});
      if (o.enforce_climb_rate && !both_fixed) {
        Row climb(RowKind::kClimb, i, -1, k);
        climb.lower = -u.max_climb_m;
        climb.upper = u.max_climb_m;
        add_row(climb, {3 * p0 + 2, 3 * p1 + 2});
      }
      segment_rows_[i][k][1] = segment_rows_[i][k][2] = segment_rows_[i][k][3] = -1;
      if (!both_fixed && !setup_.grade_rows.empty() && setup_.grade_rows[i][k]) {
        // |d_z| ≤ G·|d_xy| on the segment's actual horizontal length (the speed band keeps
        // |d_xy| > 0), squared so that the row is smooth: G²·|d_xy|² − d_z² ≥ 0.
        segment_rows_[i][k][3] = static_cast<int>(rows_.size());
        Row grade(RowKind::kGrade, i, -1, k);
        grade.lower = 0.0;
        grade.upper = kInf;
        add_row(grade, {3 * p0, 3 * p0 + 1, 3 * p0 + 2, 3 * p1, 3 * p1 + 1, 3 * p1 + 2});
      }
      if (u.pitch_rows)
        for (RowKind kind : {RowKind::kPitchUp, RowKind::kPitchDown}) {
          segment_rows_[i][k][kind == RowKind::kPitchUp ? 1 : 2] = static_cast<int>(rows_.size());
          Row pitch(kind, i, -1, k);
          pitch.lower = 0.0;
          pitch.upper = kInf;
          add_row(pitch, {pitch_slack(i, k), 3 * p0 + 2, 3 * p1 + 2});
        }
    }
    for (int k = 1; k < n; ++k) {
      const int pa = point(i, k - 1);
      const int pb = point(i, k);
      const int pc = point(i, k + 1);
      turn_rows_[i][k] = static_cast<int>(rows_.size());
      Row turn(RowKind::kTurn, i, -1, k);
      turn.lower = cos_turn;
      turn.upper = kInf;
      add_row(turn, {turn_slack(i, k), 3 * pa, 3 * pa + 1, 3 * pb, 3 * pb + 1, 3 * pc, 3 * pc + 1});
    }
    // Terrain clearance (eq. 19–20) at free waypoints and interior points of every segment.
    auto fixed_slack = [&](int k) {
      const Vec3& p = u.guess_m[k];
      return std::max(0.0, p.z() - setup_.terrain->height(p.x(), p.y()) - floor_m);
    };
    for (int k = 0; k <= n; ++k) {
      if (u.fixed[k]) continue;
      add_terrain_row(i, k, 0.0, floor_m + o.clearance_margin_m + setup_.clearance_extra_m[i][k]);
    }
    for (int k = 0; k < n; ++k) {
      double margin = o.clearance_margin_m +
                      std::max(setup_.clearance_extra_m[i][k], setup_.clearance_extra_m[i][k + 1]);
      // Next to a fixed point (start, target) the margin cannot exceed that point's own slack,
      // or the rows next to it would be infeasible by construction.
      if (u.fixed[k]) margin = std::min(margin, fixed_slack(k));
      if (u.fixed[k + 1]) margin = std::min(margin, fixed_slack(k + 1));
      const int s = u.fixed[k] && u.fixed[k + 1] ? 0 : setup_.terrain_samples[i][k];
      for (int j = 1; j <= s; ++j)
        add_terrain_row(i, k, static_cast<double>(j) / (s + 1), floor_m + margin);
    }
  }

  // Separation (eq. 21) for the candidates.
  auto is_fixed = [&](int uav, int k) {
    const GridUav& u = setup_.uavs[uav];
    return u.fixed[std::min(k, u.segments())] != 0;
  };
  for (const SeparationCandidate& c : setup_.candidates) {
    const double d = setup_.limits.separation_m + o.separation_margin_m + c.margin_m;
    auto add = [&](double tau) {
      Row row(RowKind::kSeparation, c.uav_a, c.uav_b, c.k, tau);
      row.lower = d * d;
      row.upper = kInf;
      const int k1 = std::min(c.k + 1, max_index_);
      const Term raw[4] = {{point(c.uav_a, c.k), 1.0 - tau},
                           {point(c.uav_a, k1), tau},
                           {point(c.uav_b, c.k), -(1.0 - tau)},
                           {point(c.uav_b, k1), -tau}};
      for (const Term& t : raw) {
        if (t.weight == 0.0) continue;
        int m = 0;
        while (m < row.num_terms && row.terms[m].point != t.point) ++m;
        if (m == row.num_terms) row.terms[row.num_terms++] = Term{t.point, 0.0};
        row.terms[m].weight += t.weight;
      }
      const bool all_fixed = is_fixed(c.uav_a, c.k) && is_fixed(c.uav_b, c.k) &&
                             (tau == 0.0 || (is_fixed(c.uav_a, k1) && is_fixed(c.uav_b, k1)));
      if (all_fixed) return;
      std::vector<int> cols;
      for (int m = 0; m < row.num_terms; ++m)
        for (int d3 = 0; d3 < 3; ++d3) cols.push_back(3 * row.terms[m].point + d3);
      add_row(row, cols);
      ++separation_rows_;
    };
    add(0.0);
    if (c.k < max_index_)
      for (int j = 1; j <= c.interior_samples; ++j)
        add(static_cast<double>(j) / (c.interior_samples + 1));
  }

  // Constant obstacles (local re-plan: swept threats, other UAVs' references).
  for (int m = 0; m < static_cast<int>(setup_.obstacles.size()); ++m) {
    const ObstacleRow& ob = setup_.obstacles[m];
    const GridUav& u = setup_.uavs[ob.uav];
    const int k1 = std::min(ob.k + 1, u.segments());
    if (u.fixed[ob.k] && (ob.tau == 0.0 || u.fixed[k1])) continue;  // constant row
    Row row(RowKind::kObstacle, ob.uav, m, ob.k, ob.tau);
    row.lower = ob.min_distance_m * ob.min_distance_m;
    row.upper = kInf;
    row.terms[row.num_terms++] = Term{point(ob.uav, ob.k), 1.0 - ob.tau};
    if (ob.tau > 0.0) row.terms[row.num_terms++] = Term{point(ob.uav, k1), ob.tau};
    std::vector<int> cols;
    for (int t = 0; t < row.num_terms; ++t)
      for (int d = 0; d < 3; ++d) cols.push_back(3 * row.terms[t].point + d);
    add_row(row, cols);
    ++obstacle_rows_;
  }

  // Hessian structure: record the element loop's entries once and merge duplicates.
  std::vector<std::pair<int, int>> entries;
  std::vector<double> x0(num_variables_);
  initial_point(x0.data());
  const std::vector<double> zeros(rows_.size(), 0.0);
  hessian_loop(x0.data(), 1.0, zeros.data(),
               [&](int r, int c, double) { entries.emplace_back(r, c); });
  std::vector<std::pair<int, int>> unique = entries;
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  for (const auto& [r, c] : unique) {
    hess_rows_.push_back(r);
    hess_cols_.push_back(c);
  }
  hess_slot_.reserve(entries.size());
  for (const auto& e : entries)
    hess_slot_.push_back(
        static_cast<int>(std::lower_bound(unique.begin(), unique.end(), e) - unique.begin()));
}

TrajectoryNlp::RowKey TrajectoryNlp::row_key(int row) const {
  const Row& r = rows_[static_cast<std::size_t>(row)];
  if (r.kind == RowKind::kObstacle) {
    // By what the obstacle is, not by its index in this setup.
    const ObstacleRow& ob = setup_.obstacles[static_cast<std::size_t>(r.other)];
    return RowKey{static_cast<int>(r.kind), r.uav, 2 * ob.source + (ob.threat ? 1 : 0), r.k, r.tau};
  }
  return RowKey{static_cast<int>(r.kind), r.uav, r.other, r.k, r.tau};
}

int TrajectoryNlp::point(int uav, int k) const {
  return point_base_[uav] + std::min(k, setup_.uavs[uav].segments());
}

void TrajectoryNlp::add_row(Row row, const std::vector<int>& cols) {
  row.col_begin = static_cast<int>(cols_.size());
  cols_.insert(cols_.end(), cols.begin(), cols.end());
  row.col_end = static_cast<int>(cols_.size());
  rows_.push_back(row);
}

void TrajectoryNlp::add_terrain_row(int uav, int k, double tau, double required_m) {
  Row row(RowKind::kTerrain, uav, -1, k, tau);
  row.lower = required_m;
  row.upper = kInf;
  row.terms[row.num_terms++] = Term{point(uav, k), 1.0 - tau};
  if (tau > 0.0) row.terms[row.num_terms++] = Term{point(uav, k + 1), tau};
  std::vector<int> cols;
  for (int m = 0; m < row.num_terms; ++m)
    for (int d = 0; d < 3; ++d) cols.push_back(3 * row.terms[m].point + d);
  add_row(row, cols);
}

void TrajectoryNlp::bounds(double* x_l, double* x_u, double* g_l, double* g_u) const {
  const world::AltitudeBand& band = setup_.limits.altitude;
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i) {
    const GridUav& u = setup_.uavs[i];
    for (int k = 0; k <= u.segments(); ++k) {
      const int v = 3 * point(i, k);
      for (int d = 0; d < 3; ++d) {
        if (u.fixed[k]) {
          x_l[v + d] = x_u[v + d] = u.guess_m[k][d];
        } else if (d == 2) {
          x_l[v + d] = band.min_m;  // eq. 14
          x_u[v + d] = band.max_m;
        } else {
          x_l[v + d] = -kInf;
          x_u[v + d] = kInf;
        }
      }
    }
  }
  for (int v = 3 * num_points_; v < num_variables_; ++v) {
    x_l[v] = 0.0;
    x_u[v] = kInf;
  }
  for (std::size_t r = 0; r < rows_.size(); ++r) {
    g_l[r] = rows_[r].lower;
    g_u[r] = rows_[r].upper;
  }
}

void TrajectoryNlp::row_scaling(double* scale) const {
  for (std::size_t r = 0; r < rows_.size(); ++r) {
    const Row& row = rows_[r];
    if (row.kind == RowKind::kSpeed || row.kind == RowKind::kGrade) {
      scale[r] = 1.0 / (2.0 * setup_.uavs[row.uav].nominal_length_m);
    } else if (row.kind == RowKind::kSeparation || row.kind == RowKind::kObstacle) {
      scale[r] = 1.0 / (2.0 * std::sqrt(std::max(row.lower, 1.0)));
    } else {
      scale[r] = 1.0;
    }
  }
}

void TrajectoryNlp::pack(const std::vector<std::vector<Vec3>>& waypoints_m, double* x) const {
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i)
    for (int k = 0; k <= setup_.uavs[i].segments(); ++k)
      for (int d = 0; d < 3; ++d) x[3 * point(i, k) + d] = waypoints_m[i][k][d];
  std::fill(x + 3 * num_points_, x + num_variables_, 0.0);
  // Each slack at the smallest value its rows allow.
  for (const Row& row : rows_) {
    if (row.kind != RowKind::kPitchUp && row.kind != RowKind::kPitchDown &&
        row.kind != RowKind::kTurn)
      continue;
    const int s = cols_[row.col_begin];
    const double saved = x[s];
    x[s] = 0.0;
    const double g = row_value(row, x);
    x[s] = std::max(saved, row.lower - g);
  }
}

void TrajectoryNlp::initial_point(double* x) const {
  std::vector<std::vector<Vec3>> guess;
  for (const GridUav& u : setup_.uavs) guess.push_back(u.guess_m);
  pack(guess, x);
}

std::vector<std::vector<Vec3>> TrajectoryNlp::unpack(const double* x) const {
  std::vector<std::vector<Vec3>> out(setup_.uavs.size());
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i)
    for (int k = 0; k <= setup_.uavs[i].segments(); ++k) {
      const int v = 3 * point(i, k);
      out[i].emplace_back(x[v], x[v + 1], x[v + 2]);
    }
  return out;
}

double TrajectoryNlp::objective(const double* x) const {
  double collision = 0.0;
  const std::vector<UavCost> costs_i = costs(x, &collision);
  const auto& o = setup_.options;
  double f = o.lambda_collision * collision;
  for (const UavCost& c : costs_i) f += o.lambda_individual * c.total;
  return f;
}

std::vector<UavCost> TrajectoryNlp::costs(const double* x, double* collision_cost) const {
  const auto& o = setup_.options;
  const world::Terrain& terrain = *setup_.terrain;
  std::vector<UavCost> out(setup_.uavs.size());
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i) {
    const GridUav& u = setup_.uavs[i];
    UavCost& c = out[i];
    const ElementParams q{u.nominal_length_m, o.climb_current, o.turn_current, o.speed_current};
    const int n = u.segments();
    for (int k = 0; k < n; ++k) {
      const double* a = x + 3 * point(i, k);
      const double* b = x + 3 * point(i, k + 1);
      double parts[2];
      segment_parts(a, b, q, parts);
      c.range += parts[0];
      c.pitch += parts[1];
      const double s = u.pitch_rows ? x[pitch_slack(i, k)] : 0.0;
      c.pitch_penalty += q.nominal_m * o.pitch_penalty * s;
      const Vec3 d(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
      c.length_m += d.norm();
      c.max_pitch_rad = std::max(c.max_pitch_rad, std::atan2(std::abs(d.z()), d.head<2>().norm()));
    }
    for (int k = 1; k < n; ++k) {
      const double* a = x + 3 * point(i, k - 1);
      const double* b = x + 3 * point(i, k);
      const double* cc = x + 3 * point(i, k + 1);
      double parts[2];
      vertex_parts(a, b, cc, turn_cosine(a, b, cc), q, parts);
      c.range += parts[0];
      c.turn += parts[1];
      c.turn_penalty += q.nominal_m * o.turn_penalty * x[turn_slack(i, k)];
      c.max_turn_rad =
          std::max(c.max_turn_rad, std::acos(std::clamp(turn_cosine(a, b, cc), -1.0, 1.0)));
    }
    for (int k = 0; k <= n; ++k) {
      const double* p = x + 3 * point(i, k);
      c.altitude += q.nominal_m * (p[2] - terrain.height(p[0], p[1])) / o.altitude_scale_m;
    }
    c.pitch += c.pitch_penalty;
    c.turn += c.turn_penalty;
    c.total = o.weight_range * c.range + o.weight_pitch * c.pitch + o.weight_turn * c.turn +
              o.weight_altitude * c.altitude;
  }
  double col = 0.0;
  const double dc2 = o.collision_soft_distance_m * o.collision_soft_distance_m;
  for (const SeparationCandidate& cand : setup_.candidates) {
    const double* a = x + 3 * point(cand.uav_a, cand.k);
    const double* b = x + 3 * point(cand.uav_b, cand.k);
    double r2 = 0.0;
    for (int d = 0; d < 3; ++d) r2 += (a[d] - b[d]) * (a[d] - b[d]);
    const double e = std::max(0.0, 1.0 - r2 / dc2);
    const double l =
        0.5 * (setup_.uavs[cand.uav_a].nominal_length_m + setup_.uavs[cand.uav_b].nominal_length_m);
    col += l * e * e;
  }
  if (collision_cost != nullptr) *collision_cost = col;
  return out;
}

void TrajectoryNlp::gradient(const double* x, double* grad) const {
  using Jet6 = ceres::Jet<double, 6>;
  using Jet9 = ceres::Jet<double, 9>;
  const auto& o = setup_.options;
  const world::Terrain& terrain = *setup_.terrain;
  std::fill(grad, grad + num_variables_, 0.0);
  const double l1 = o.lambda_individual;
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i) {
    const GridUav& u = setup_.uavs[i];
    const ElementParams q{u.nominal_length_m, o.climb_current, o.turn_current, o.speed_current};
    const int n = u.segments();
    for (int k = 0; k < n; ++k) {
      const int va = 3 * point(i, k);
      const int vb = 3 * point(i, k + 1);
      Jet6 a[3];
      Jet6 b[3];
      for (int d = 0; d < 3; ++d) {
        a[d] = Jet6(x[va + d], d);
        b[d] = Jet6(x[vb + d], 3 + d);
      }
      Jet6 parts[2];
      segment_parts(a, b, q, parts);
      const Jet6 f = l1 * (o.weight_range * parts[0] + o.weight_pitch * parts[1]);
      for (int d = 0; d < 3; ++d) {
        grad[va + d] += f.v[d];
        grad[vb + d] += f.v[3 + d];
      }
      if (u.pitch_rows)
        grad[pitch_slack(i, k)] += l1 * o.weight_pitch * q.nominal_m * o.pitch_penalty;
    }
    for (int k = 1; k < n; ++k) {
      const int v[3] = {3 * point(i, k - 1), 3 * point(i, k), 3 * point(i, k + 1)};
      Jet9 p[3][3];
      for (int m = 0; m < 3; ++m)
        for (int d = 0; d < 3; ++d) p[m][d] = Jet9(x[v[m] + d], 3 * m + d);
      Jet9 parts[2];
      vertex_parts(p[0], p[1], p[2], turn_cosine(p[0], p[1], p[2]), q, parts);
      const Jet9 f = l1 * (o.weight_range * parts[0] + o.weight_turn * parts[1]);
      for (int m = 0; m < 3; ++m)
        for (int d = 0; d < 3; ++d) grad[v[m] + d] += f.v[3 * m + d];
      grad[turn_slack(i, k)] += l1 * o.weight_turn * q.nominal_m * o.turn_penalty;
    }
    const double coef = l1 * o.weight_altitude * q.nominal_m / o.altitude_scale_m;
    for (int k = 0; k <= n; ++k) {
      const int vp = 3 * point(i, k);
      const Vec2 g = terrain.gradient(x[vp], x[vp + 1]);
      grad[vp] -= coef * g.x();
      grad[vp + 1] -= coef * g.y();
      grad[vp + 2] += coef;
    }
  }
  const double dc2 = o.collision_soft_distance_m * o.collision_soft_distance_m;
  for (const SeparationCandidate& cand : setup_.candidates) {
    const int va = 3 * point(cand.uav_a, cand.k);
    const int vb = 3 * point(cand.uav_b, cand.k);
    double r[3];
    double r2 = 0.0;
    for (int d = 0; d < 3; ++d) {
      r[d] = x[va + d] - x[vb + d];
      r2 += r[d] * r[d];
    }
    const double e = 1.0 - r2 / dc2;
    if (e <= 0.0) continue;
    const double l =
        0.5 * (setup_.uavs[cand.uav_a].nominal_length_m + setup_.uavs[cand.uav_b].nominal_length_m);
    // d/dr of l·e² = l·2e·(−2r/D_c²)
    const double c = o.lambda_collision * l * 2.0 * e * (-2.0 / dc2);
    for (int d = 0; d < 3; ++d) {
      grad[va + d] += c * r[d];
      grad[vb + d] -= c * r[d];
    }
  }
}

double TrajectoryNlp::row_value(const Row& row, const double* x) const {
  const GridUav& u = setup_.uavs[row.uav];
  switch (row.kind) {
    case RowKind::kSpeed: {
      const int* c = &cols_[row.col_begin];
      const double dx = x[c[2]] - x[c[0]];
      const double dy = x[c[3]] - x[c[1]];
      return dx * dx + dy * dy;
    }
    case RowKind::kClimb: {
      const int* c = &cols_[row.col_begin];
      return x[c[1]] - x[c[0]];
    }
    case RowKind::kGrade: {
      const int* c = &cols_[row.col_begin];
      const double dx = x[c[3]] - x[c[0]];
      const double dy = x[c[4]] - x[c[1]];
      const double dz = x[c[5]] - x[c[2]];
      return u.max_grade * u.max_grade * (dx * dx + dy * dy) - dz * dz;
    }
    case RowKind::kPitchUp:
    case RowKind::kPitchDown: {
      const int* c = &cols_[row.col_begin];
      const double dz = x[c[2]] - x[c[1]];
      const double sign = row.kind == RowKind::kPitchUp ? -1.0 : 1.0;
      return x[c[0]] + sign * dz / u.nominal_length_m + u.tan_max_pitch;
    }
    case RowKind::kTurn: {
      const int* c = &cols_[row.col_begin];
      const double a[2] = {x[c[1]], x[c[2]]};
      const double b[2] = {x[c[3]], x[c[4]]};
      const double cc[2] = {x[c[5]], x[c[6]]};
      return x[c[0]] + turn_cosine(a, b, cc);
    }
    case RowKind::kTerrain: {
      Vec3 q = Vec3::Zero();
      for (int m = 0; m < row.num_terms; ++m)
        q += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                        x[3 * row.terms[m].point + 2]);
      return q.z() - setup_.terrain->height(q.x(), q.y());
    }
    case RowKind::kSeparation: {
      Vec3 r = Vec3::Zero();
      for (int m = 0; m < row.num_terms; ++m)
        r += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                        x[3 * row.terms[m].point + 2]);
      return r.squaredNorm();
    }
    case RowKind::kObstacle: {
      const ObstacleRow& ob = setup_.obstacles[static_cast<std::size_t>(row.other)];
      Vec3 q = Vec3::Zero();
      for (int m = 0; m < row.num_terms; ++m)
        q += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                        x[3 * row.terms[m].point + 2]);
      bool interior = false;
      return (q - nearest_on_segment(q, ob.a_m, ob.b_m, &interior)).squaredNorm();
    }
  }
  return 0.0;
}

void TrajectoryNlp::constraints(const double* x, double* g) const {
  for (std::size_t r = 0; r < rows_.size(); ++r) g[r] = row_value(rows_[r], x);
}

void TrajectoryNlp::jacobian_structure(int* rows, int* cols) const {
  for (std::size_t r = 0; r < rows_.size(); ++r)
    for (int e = rows_[r].col_begin; e < rows_[r].col_end; ++e) {
      rows[e] = static_cast<int>(r);
      cols[e] = cols_[e];
    }
}

void TrajectoryNlp::jacobian_values(const double* x, double* values) const {
  using Jet6 = ceres::Jet<double, 6>;
  for (const Row& row : rows_) {
    const GridUav& u = setup_.uavs[row.uav];
    const int* c = &cols_[row.col_begin];
    double* v = values + row.col_begin;
    switch (row.kind) {
      case RowKind::kSpeed: {
        const double dx = x[c[2]] - x[c[0]];
        const double dy = x[c[3]] - x[c[1]];
        v[0] = -2.0 * dx;
        v[1] = -2.0 * dy;
        v[2] = 2.0 * dx;
        v[3] = 2.0 * dy;
        break;
      }
      case RowKind::kClimb:
        v[0] = -1.0;
        v[1] = 1.0;
        break;
      case RowKind::kGrade: {
        const double g2 = u.max_grade * u.max_grade;
        const double d[3] = {2.0 * g2 * (x[c[3]] - x[c[0]]), 2.0 * g2 * (x[c[4]] - x[c[1]]),
                             -2.0 * (x[c[5]] - x[c[2]])};
        for (int e = 0; e < 3; ++e) {
          v[e] = -d[e];
          v[3 + e] = d[e];
        }
        break;
      }
      case RowKind::kPitchUp:
      case RowKind::kPitchDown: {
        const double sign = row.kind == RowKind::kPitchUp ? -1.0 : 1.0;
        v[0] = 1.0;
        v[1] = -sign / u.nominal_length_m;
        v[2] = sign / u.nominal_length_m;
        break;
      }
      case RowKind::kTurn: {
        Jet6 a[2] = {Jet6(x[c[1]], 0), Jet6(x[c[2]], 1)};
        Jet6 b[2] = {Jet6(x[c[3]], 2), Jet6(x[c[4]], 3)};
        Jet6 cc[2] = {Jet6(x[c[5]], 4), Jet6(x[c[6]], 5)};
        const Jet6 cosine = turn_cosine(a, b, cc);
        v[0] = 1.0;
        for (int d = 0; d < 6; ++d) v[1 + d] = cosine.v[d];
        break;
      }
      case RowKind::kTerrain: {
        Vec3 q = Vec3::Zero();
        for (int m = 0; m < row.num_terms; ++m)
          q += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                          x[3 * row.terms[m].point + 2]);
        const Vec2 grad = setup_.terrain->gradient(q.x(), q.y());
        for (int m = 0; m < row.num_terms; ++m) {
          const double w = row.terms[m].weight;
          v[3 * m] = -w * grad.x();
          v[3 * m + 1] = -w * grad.y();
          v[3 * m + 2] = w;
        }
        break;
      }
      case RowKind::kSeparation: {
        Vec3 r = Vec3::Zero();
        for (int m = 0; m < row.num_terms; ++m)
          r += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                          x[3 * row.terms[m].point + 2]);
        for (int m = 0; m < row.num_terms; ++m)
          for (int d = 0; d < 3; ++d) v[3 * m + d] = 2.0 * row.terms[m].weight * r[d];
        break;
      }
      case RowKind::kObstacle: {
        const ObstacleRow& ob = setup_.obstacles[static_cast<std::size_t>(row.other)];
        Vec3 q = Vec3::Zero();
        for (int m = 0; m < row.num_terms; ++m)
          q += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                          x[3 * row.terms[m].point + 2]);
        bool interior = false;
        const Vec3 r = q - nearest_on_segment(q, ob.a_m, ob.b_m, &interior);
        for (int m = 0; m < row.num_terms; ++m)
          for (int d = 0; d < 3; ++d) v[3 * m + d] = 2.0 * row.terms[m].weight * r[d];
        break;
      }
    }
  }
}

template <typename Add>
void TrajectoryNlp::hessian_loop(const double* x, double sigma, const double* lambda,
                                 Add&& add) const {
  const auto& o = setup_.options;
  const world::Terrain& terrain = *setup_.terrain;
  const double l1 = sigma * o.lambda_individual;
  const bool convex = o.convexify_hessian;
  auto add_lower = [&](int a, int b, double value) {
    if (a >= b) {
      add(a, b, value);
    } else {
      add(b, a, value);
    }
  };
  for (int i = 0; i < static_cast<int>(setup_.uavs.size()); ++i) {
    const GridUav& u = setup_.uavs[i];
    const ElementParams q{u.nominal_length_m, o.climb_current, o.turn_current, o.speed_current};
    const int n = u.segments();
    for (int k = 0; k < n; ++k) {
      // Every term of a segment depends on its step d = p_{k+1} − p_k only, so its 6 × 6 block
      // is [G −G; −G G] = (v vᵀ) ⊗ G with v = (−1, 1) and G the 3 × 3 Hessian in d; v vᵀ has
      // the single non-zero eigenvalue 2, so the block's PSD projection is (v vᵀ) ⊗ P(G): AD in
      // the 3 components of d and a 3 × 3 projection give the same block as AD in all 6.
      using D = Dual2<3>;
      const int v0 = 3 * point(i, k);
      const int v1 = 3 * point(i, k + 1);
      const D origin[3];  // a = 0, b = d: segment_parts reads only b − a
      D step[3];
      for (int c = 0; c < 3; ++c) step[c] = D::variable(x[v1 + c] - x[v0 + c], c);
      D parts[2];
      segment_parts(origin, step, q, parts);
      D f = l1 * (o.weight_range * parts[0] + o.weight_pitch * parts[1]);
      const std::array<int, 4>& r = segment_rows_[i][k];
      // The speed row |d_xy|² and the grade row G²·|d_xy|² − d_z² (the pitch rows are linear).
      if (r[0] >= 0) f += lambda[r[0]] * (step[0] * step[0] + step[1] * step[1]);
      if (r[3] >= 0)
        f += lambda[r[3]] * (u.max_grade * u.max_grade * (step[0] * step[0] + step[1] * step[1]) -
                             step[2] * step[2]);
      Eigen::Matrix3d G = f.H;
      if (convex) project_to_psd(G);
      for (int m = 0; m < 3; ++m)
        for (int c = 0; c <= m; ++c) add(v0 + m, v0 + c, G(m, c));
      for (int m = 0; m < 3; ++m)
        for (int c = 0; c < 3; ++c) add(v1 + m, v0 + c, -G(m, c));
      for (int m = 0; m < 3; ++m)
        for (int c = 0; c <= m; ++c) add(v1 + m, v1 + c, G(m, c));
    }
    // The turn blocks: all G (or, convexified, all S = Kᵀ G K) first, so that the indefinite
    // ones are eigen-decomposed together (project_to_psd_batch, the same result as one by one).
    std::vector<Mat6> turn_blocks(static_cast<std::size_t>(std::max(n - 1, 0)));
    for (int k = 1; k < n; ++k) {
      // f = l1·(w1·κ_turn·τ·½(L_ab + L_bc) + w3·ℓ·τ) + λ·cos φ = τ·(A − λ) + λ with
      // τ = 1 − cos φ and A = l1·(w1·κ_turn·½(L_ab + L_bc) + w3·ℓ). Every term depends on the
      // steps u = b − a and w = c − b only, so the 9 × 9 block is Dᵀ G D with G the 6 × 6
      // Hessian in (u, w):
      //   G = (A − λ)∇²τ + τ∇²A + ∇τ∇Aᵀ + ∇A∇τᵀ,
      // τ by forward AD in (u_x, u_y, w_x, w_y), the lengths in closed form (∇L = d/L,
      // ∇²L = (I − d dᵀ/L²)/L on d). The 9 × 9 block and its projection: three_point_block().
      using D = Dual2<4>;
      const int va = 3 * point(i, k - 1);
      const int vb = 3 * point(i, k);
      const int vc = 3 * point(i, k + 1);
      const Vec3 d_ab(x[vb] - x[va], x[vb + 1] - x[va + 1], x[vb + 2] - x[va + 2]);
      const Vec3 d_bc(x[vc] - x[vb], x[vc + 1] - x[vb + 1], x[vc + 2] - x[vb + 2]);
      const D tau = 1.0 - turn_cosine_of_steps(D::variable(d_ab.x(), 0), D::variable(d_ab.y(), 1),
                                               D::variable(d_bc.x(), 2), D::variable(d_bc.y(), 3));
      const double row_lambda = lambda[turn_rows_[i][k]];
      const double c_len = l1 * o.weight_range * q.turn_current * 0.5;
      const double L_ab = std::sqrt(d_ab.squaredNorm() + kNormEps_m * kNormEps_m);
      const double L_bc = std::sqrt(d_bc.squaredNorm() + kNormEps_m * kNormEps_m);
      const double A = c_len * (L_ab + L_bc) + l1 * o.weight_turn * q.nominal_m;
      Vec6 grad_A;
      grad_A << c_len * d_ab / L_ab, c_len * d_bc / L_bc;
      constexpr int kXy[4] = {0, 1, 3, 4};  // u_x, u_y, w_x, w_y among (u, w)
      Vec6 grad_tau = Vec6::Zero();
      Mat6 G = Mat6::Zero();
      for (int m = 0; m < 4; ++m) {
        grad_tau[kXy[m]] = tau.g[m];
        for (int c = 0; c < 4; ++c) G(kXy[m], kXy[c]) = (A - row_lambda) * tau.H(m, c);
      }
      const double w = tau.v * c_len;
      G.block<3, 3>(0, 0) +=
          (w / L_ab) * (Eigen::Matrix3d::Identity() - d_ab * d_ab.transpose() / (L_ab * L_ab));
      G.block<3, 3>(3, 3) +=
          (w / L_bc) * (Eigen::Matrix3d::Identity() - d_bc * d_bc.transpose() / (L_bc * L_bc));
      G += grad_tau * grad_A.transpose() + grad_A * grad_tau.transpose();
      turn_blocks[k - 1] = convex ? three_point_reduce(G) : G;
    }
    if (convex) project_to_psd_batch(turn_blocks.data(), static_cast<int>(turn_blocks.size()));
    for (int k = 1; k < n; ++k) {
      const Mat9 H = convex ? three_point_expand(turn_blocks[k - 1])
                            : three_point_block(turn_blocks[k - 1], false);
      const int v[3] = {3 * point(i, k - 1), 3 * point(i, k), 3 * point(i, k + 1)};
      for (int m = 0; m < 9; ++m)
        for (int c = 0; c <= m; ++c) add(v[m / 3] + m % 3, v[c / 3] + c % 3, H(m, c));
    }
    const double coef = l1 * o.weight_altitude * q.nominal_m / o.altitude_scale_m;
    for (int k = 0; k <= n; ++k) {
      const int vp = 3 * point(i, k);
      Eigen::Matrix2d H = -coef * terrain.hessian(x[vp], x[vp + 1]);
      if (convex) project_to_psd(H);
      add(vp, vp, H(0, 0));
      add(vp + 1, vp, H(1, 0));
      add(vp + 1, vp + 1, H(1, 1));
    }
  }
  for (std::size_t ri = 0; ri < rows_.size(); ++ri) {
    const Row& row = rows_[ri];
    if (row.kind == RowKind::kTerrain) {
      Vec3 qp = Vec3::Zero();
      for (int m = 0; m < row.num_terms; ++m)
        qp += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                         x[3 * row.terms[m].point + 2]);
      // λ·∇²(z − H(q)) = −λ·∇²H on (x, y) of q = Σ w_m p_m: the block of points m, c is
      // w_m·w_c·(−λ∇²H), positive semidefinite when −λ∇²H is (w wᵀ is).
      Eigen::Matrix2d H = -lambda[ri] * terrain.hessian(qp.x(), qp.y());
      if (convex) project_to_psd(H);
      for (int m = 0; m < row.num_terms; ++m)
        for (int c = 0; c <= m; ++c) {
          const double w = row.terms[m].weight * row.terms[c].weight;
          const int pm = 3 * row.terms[m].point;
          const int pc = 3 * row.terms[c].point;
          for (int d = 0; d < 2; ++d)
            for (int e = 0; e < 2; ++e)
              if (m != c || e <= d) add_lower(pm + d, pc + e, w * H(d, e));
        }
    } else if (row.kind == RowKind::kObstacle) {
      // λ·∇²|q − π(q)|² = 2λ·(w wᵀ ⊗ P), P = I − u uᵀ where π(q) is inside the segment, else
      // I: positive semidefinite for λ ≥ 0 (P is a projector), dropped when λ < 0 and convex.
      const ObstacleRow& ob = setup_.obstacles[static_cast<std::size_t>(row.other)];
      Vec3 qp = Vec3::Zero();
      for (int m = 0; m < row.num_terms; ++m)
        qp += row.terms[m].weight * Vec3(x[3 * row.terms[m].point], x[3 * row.terms[m].point + 1],
                                         x[3 * row.terms[m].point + 2]);
      bool interior = false;
      nearest_on_segment(qp, ob.a_m, ob.b_m, &interior);
      Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
      if (interior) {
        const Vec3 axis = (ob.b_m - ob.a_m).normalized();
        P -= axis * axis.transpose();
      }
      const double scale = convex ? std::max(lambda[ri], 0.0) : lambda[ri];
      for (int m = 0; m < row.num_terms; ++m)
        for (int c = 0; c <= m; ++c) {
          const double w = 2.0 * scale * row.terms[m].weight * row.terms[c].weight;
          const int pm = 3 * row.terms[m].point;
          const int pc = 3 * row.terms[c].point;
          for (int d = 0; d < 3; ++d)
            for (int e = 0; e < 3; ++e)
              if (m != c || e <= d) add_lower(pm + d, pc + e, w * P(d, e));
        }
    } else if (row.kind == RowKind::kSeparation) {
      // λ·∇²|r|² = 2λ·(w wᵀ ⊗ I): positive semidefinite for λ ≥ 0, else dropped when convex.
      const double scale = convex ? std::max(lambda[ri], 0.0) : lambda[ri];
      for (int m = 0; m < row.num_terms; ++m)
        for (int c = 0; c <= m; ++c) {
          const double w = 2.0 * scale * row.terms[m].weight * row.terms[c].weight;
          for (int d = 0; d < 3; ++d)
            add_lower(3 * row.terms[m].point + d, 3 * row.terms[c].point + d, w);
        }
    }
  }
  const double dc2 = o.collision_soft_distance_m * o.collision_soft_distance_m;
  for (const SeparationCandidate& cand : setup_.candidates) {
    const int va = 3 * point(cand.uav_a, cand.k);
    const int vb = 3 * point(cand.uav_b, cand.k);
    const Vec3 r(x[va] - x[vb], x[va + 1] - x[vb + 1], x[va + 2] - x[vb + 2]);
    const double e = 1.0 - r.squaredNorm() / dc2;
    const double l =
        0.5 * (setup_.uavs[cand.uav_a].nominal_length_m + setup_.uavs[cand.uav_b].nominal_length_m);
    // ∇²_r of l·e² = l·(8 r rᵀ/D⁴ − 4e/D²·I) while e > 0, else 0.
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    if (e > 0.0)
      H = sigma * o.lambda_collision * l *
          (8.0 * r * r.transpose() / (dc2 * dc2) - 4.0 * e / dc2 * Eigen::Matrix3d::Identity());
    // The pair's block is [H −H; −H H] = [1 −1; −1 1] ⊗ H: positive semidefinite when H is.
    if (convex) project_to_psd(H);
    for (int d = 0; d < 3; ++d)
      for (int c = 0; c < 3; ++c) {
        if (c <= d) {
          add(va + d, va + c, H(d, c));
          add(vb + d, vb + c, H(d, c));
        }
        add_lower(va + d, vb + c, -H(d, c));
      }
  }
}

void TrajectoryNlp::hessian_structure(int* rows, int* cols) const {
  std::copy(hess_rows_.begin(), hess_rows_.end(), rows);
  std::copy(hess_cols_.begin(), hess_cols_.end(), cols);
}

void TrajectoryNlp::hessian_values(const double* x, double sigma, const double* lambda,
                                   double* values) const {
  std::fill(values, values + hess_rows_.size(), 0.0);
  std::size_t m = 0;
  hessian_loop(x, sigma, lambda, [&](int, int, double v) { values[hess_slot_[m++]] += v; });
}

std::string TrajectoryNlp::describe(const Row& row) const {
  const std::string& name = setup_.uavs[row.uav].name;
  const double dt = setup_.time_step_s;
  switch (row.kind) {
    case RowKind::kSpeed:
      return fmt::format("speed band (eq. 2) of UAV {} on segment {} (t = {:.1f} s)", name, row.k,
                         row.k * dt);
    case RowKind::kClimb:
      return fmt::format("climb rate (eq. 2) of UAV {} on segment {} (t = {:.1f} s)", name, row.k,
                         row.k * dt);
    case RowKind::kGrade:
      return fmt::format(
          "grade (pitch and climb limits, eq. 2) of UAV {} on segment {} (t = "
          "{:.1f} s)",
          name, row.k, row.k * dt);
    case RowKind::kPitchUp:
    case RowKind::kPitchDown:
      return fmt::format("pitch slack (eq. 16) of UAV {} on segment {}", name, row.k);
    case RowKind::kTurn:
      return fmt::format("turn slack (eq. 18) of UAV {} at waypoint {}", name, row.k);
    case RowKind::kTerrain:
      return fmt::format(
          "terrain clearance (eq. 19-20) of UAV {} on segment {} at {:.2f} of its "
          "length (t = {:.1f} s)",
          name, row.k, row.tau, (row.k + row.tau) * dt);
    case RowKind::kSeparation:
      return fmt::format("separation (eq. 21) of UAVs {} and {} at t = {:.1f} s", name,
                         setup_.uavs[row.other].name, (row.k + row.tau) * dt);
    case RowKind::kObstacle: {
      const ObstacleRow& ob = setup_.obstacles[static_cast<std::size_t>(row.other)];
      return fmt::format("{} {} of UAV {} at grid time {:.1f} s",
                         ob.threat ? "threat" : "separation from UAV", ob.source, name,
                         (row.k + row.tau) * dt);
    }
  }
  return "";
}

std::string TrajectoryNlp::worst_rows(const double* x, int max_lines) const {
  struct Miss {
    double amount;
    int row;
    Vec3 where;
  };
  std::vector<Miss> misses;
  for (int r = 0; r < static_cast<int>(rows_.size()); ++r) {
    const Row& row = rows_[r];
    const double g = row_value(row, x);
    const double amount = std::max(row.lower - g, g - row.upper);
    if (amount <= setup_.options.constraint_tolerance) continue;
    const int k1 = std::min(row.k + 1, setup_.uavs[row.uav].segments());
    const double* a = x + 3 * point(row.uav, row.k);
    const double* b = x + 3 * point(row.uav, k1);
    const Vec3 pa(a[0], a[1], a[2]);
    const Vec3 pb(b[0], b[1], b[2]);
    misses.push_back({amount, r, pa + row.tau * (pb - pa)});
  }
  std::sort(misses.begin(), misses.end(),
            [](const Miss& l, const Miss& r) { return l.amount > r.amount; });
  std::string out;
  for (int m = 0; m < static_cast<int>(misses.size()) && m < max_lines; ++m) {
    const Row& row = rows_[misses[m].row];
    const double g = row_value(row, x);
    if (!out.empty()) out += "; ";
    out += fmt::format("{} near ({:.1f}, {:.1f}, {:.1f}): value {:.3g} outside [{:.3g}, {:.3g}]",
                       describe(row), misses[m].where.x(), misses[m].where.y(), misses[m].where.z(),
                       g, row.lower, row.upper >= kInf ? INFINITY : row.upper);
  }
  return out;
}

}  // namespace ridgeline::planning::detail
