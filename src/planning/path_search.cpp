#include "planning/path_search.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "core/error.hpp"

namespace ridgeline::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A loop insertion adds exactly the length the pitch limit asked for, but the new loop's own
// terrain can ask for more; a few rounds settle it or show the leg cannot be flown.
constexpr int kMaxLoopInsertions = 3;

void require(bool ok, const char* field, double value, const char* rule) {
  if (!ok)
    throw InputError(fmt::format("path_search.{}", field), fmt::format("{} {}", value, rule));
}

void validate_options(const PathSearchOptions& o) {
  auto finite = [](double v) { return std::isfinite(v); };
  require(finite(o.cell_size_m) && o.cell_size_m > 0.0, "cell_size_m", o.cell_size_m,
          "must be finite and > 0");
  require(finite(o.turn_margin_m) && o.turn_margin_m >= 0.0, "turn_margin_m", o.turn_margin_m,
          "must be finite and >= 0");
  require(o.max_pitch_rad > 0.0 && o.max_pitch_rad < kPi / 2, "max_pitch_rad", o.max_pitch_rad,
          "must be in (0, pi/2)");
  require(finite(o.climb_penalty) && o.climb_penalty >= 0.0, "climb_penalty", o.climb_penalty,
          "must be finite and >= 0");
  require(finite(o.turn_penalty_m) && o.turn_penalty_m >= 0.0, "turn_penalty_m", o.turn_penalty_m,
          "must be finite and >= 0");
  require(o.footprint_sample_m > 0.0 && o.footprint_sample_m <= 5.0, "footprint_sample_m",
          o.footprint_sample_m, "must be in (0, 5]");
  require(o.profile_step_m > 0.0 && o.profile_step_m <= 5.0, "profile_step_m", o.profile_step_m,
          "must be in (0, 5]");
  require(finite(o.profile_pad_m) && o.profile_pad_m >= 0.0, "profile_pad_m", o.profile_pad_m,
          "must be finite and >= 0");
  require(o.check_step_m > 0.0 && o.check_step_m <= 5.0, "check_step_m", o.check_step_m,
          "must be in (0, 5]");
}

double elapsed_ms(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// One leg's search over the grid: Lazy Theta* from start_xy to goal_xy.
class LegSearch {
 public:
  LegSearch(const ClearanceGrid& grid, const Vec2& start_xy, const Vec2& goal_xy)
      : grid_(grid),
        o_(grid.options()),
        start_xy_(start_xy),
        goal_xy_(goal_xy),
        start_(grid.cell_of(start_xy.x(), start_xy.y())),
        goal_(grid.cell_of(goal_xy.x(), goal_xy.y())) {
    const int n = grid_.rows() * grid_.cols();
    z_.resize(n);
    for (int c = 0; c < n; ++c) {
      z_[c] = grid_.blocked(c) && c != start_ && c != goal_
                  ? kInf
                  : std::min(grid_.required_altitude_m(c), grid_.limits().altitude.max_m);
    }
    z_goal_ = z_[goal_];
  }

  // Returns the horizontal polyline (start … goal) or an empty vector when unreachable.
  std::vector<Vec2> run() {
    if (start_ == goal_) return {start_xy_, goal_xy_};
    const int n = grid_.rows() * grid_.cols();
    g_.assign(n, kInf);
    parent_.assign(n, -1);
    state_.assign(n, 0);
    using Entry = std::pair<double, int>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
    g_[start_] = 0.0;
    parent_[start_] = start_;
    open.emplace(heuristic(start_), start_);
    while (!open.empty()) {
      const auto [f, s] = open.top();
      open.pop();
      if (state_[s] == kClosed || f > g_[s] + heuristic(s) + 1e-9) continue;  // stale entry
      if (s != start_) set_vertex(s);
      state_[s] = kClosed;
      ++expanded_;
      if (s == goal_) break;
      const int row = s / grid_.cols(), col = s % grid_.cols();
      const int p = parent_[s];
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          if (dr == 0 && dc == 0) continue;
          const int r = row + dr, c = col + dc;
          if (r < 0 || c < 0 || r >= grid_.rows() || c >= grid_.cols()) continue;
          const int nb = grid_.index(r, c);
          if (state_[nb] == kClosed || !passable(nb)) continue;
          // No corner cutting: a diagonal step needs both side cells free.
          if (dr != 0 && dc != 0 &&
              (!passable(grid_.index(row, c)) || !passable(grid_.index(r, col))))
            continue;
          // Lazy Theta*: assume the grandparent sees nb (checked when nb is expanded).
          const double cand = g_[p] + estimate(p, nb) + turn_cost(parent_[p], p, nb);
          if (cand < g_[nb]) {
            g_[nb] = cand;
            parent_[nb] = p;
            open.emplace(cand + heuristic(nb), nb);
          }
        }
      }
    }
    if (state_[goal_] != kClosed) return {};
    std::vector<Vec2> path;
    for (int c = goal_;; c = parent_[c]) {
      path.push_back(position(c));
      if (c == start_) break;
    }
    std::reverse(path.begin(), path.end());
    return path;
  }

  int expanded() const { return expanded_; }
  int closed_count() const { return expanded_; }

  // Size of the free region around the goal (8-connected, same rules), counted up to `limit`.
  int goal_region_size(int limit) const {
    std::vector<char> seen(grid_.rows() * grid_.cols(), 0);
    std::vector<int> stack{goal_};
    seen[goal_] = 1;
    int count = 0;
    while (!stack.empty() && count < limit) {
      const int s = stack.back();
      stack.pop_back();
      ++count;
      const int row = s / grid_.cols(), col = s % grid_.cols();
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = row + dr, c = col + dc;
          if (r < 0 || c < 0 || r >= grid_.rows() || c >= grid_.cols()) continue;
          const int nb = grid_.index(r, c);
          if (seen[nb] || !passable(nb)) continue;
          if (dr != 0 && dc != 0 &&
              (!passable(grid_.index(row, c)) || !passable(grid_.index(r, col))))
            continue;
          seen[nb] = 1;
          stack.push_back(nb);
        }
      }
    }
    return count;
  }

 private:
  static constexpr char kClosed = 2;

  // z_[cell]: the altitude the search assumes, min(z_req, H_max); +inf for a blocked cell. One
  // flat array so the line-of-sight trace, the inner loop, does a single load per cell.
  bool passable(int cell) const { return z_[cell] < kInf; }
  double altitude(int cell) const { return z_[cell]; }
  Vec2 position(int cell) const {
    if (cell == start_) return start_xy_;
    if (cell == goal_) return goal_xy_;
    return grid_.cell_centre(cell);
  }
  // Admissible: a path's cost Σ(√(L_k² + V_k²) + k·A_k) is at least √(d² + Δz²) + k·max(0, Δz)
  // by Minkowski's inequality, with d, Δz the horizontal distance and height change to the goal.
  double heuristic(int cell) const {
    const double d = (goal_xy_ - position(cell)).norm();
    const double dz = z_goal_ - z_[cell];
    return std::sqrt(d * d + dz * dz) + o_.climb_penalty * std::max(0.0, dz);
  }

  double estimate(int a, int b) const {
    const double length = (position(b) - position(a)).norm();
    const double dz = altitude(b) - altitude(a);
    return std::sqrt(length * length + dz * dz) + o_.climb_penalty * std::max(0.0, dz);
  }

  double turn_cost(int before, int at, int after) const {
    if (before == at || o_.turn_penalty_m == 0.0) return 0.0;
    const Vec2 d1 = position(at) - position(before);
    const Vec2 d2 = position(after) - position(at);
    if (d1.squaredNorm() == 0.0 || d2.squaredNorm() == 0.0) return 0.0;
    const double cross = d1.x() * d2.y() - d1.y() * d2.x();
    return o_.turn_penalty_m * std::abs(std::atan2(cross, d1.dot(d2)));
  }

  // Exact segment cost a → b by tracing the cells it crosses (Amanatides–Woo); +inf if any
  // crossed cell (or a side cell at an exact corner crossing) is blocked.
  double segment_cost(int a, int b) const {
    const Vec2 pa = position(a), pb = position(b);
    const double cell = o_.cell_size_m;
    const Vec2 origin = grid_.area().min_m;
    const double ua = (pa.x() - origin.x()) / cell, va = (pa.y() - origin.y()) / cell;
    const double du = (pb.x() - pa.x()) / cell, dv = (pb.y() - pa.y()) / cell;
    int col = a % grid_.cols(), row = a / grid_.cols();
    const int end_col = b % grid_.cols(), end_row = b / grid_.cols();
    const int step_c = du > 0 ? 1 : -1, step_r = dv > 0 ? 1 : -1;
    double t_max_c = du > 0 ? (col + 1 - ua) / du : du < 0 ? (ua - col) / -du : kInf;
    double t_max_r = dv > 0 ? (row + 1 - va) / dv : dv < 0 ? (va - row) / -dv : kInf;
    const double t_delta_c = du != 0 ? 1.0 / std::abs(du) : kInf;
    const double t_delta_r = dv != 0 ? 1.0 / std::abs(dv) : kInf;
    double z_prev = altitude(a), vertical = 0.0, ascent = 0.0;
    auto in_grid = [&](int r, int c) {
      return r >= 0 && c >= 0 && r < grid_.rows() && c < grid_.cols();
    };
    const int max_steps = 2 * (grid_.rows() + grid_.cols()) + 4;
    for (int k = 0; k < max_steps && (col != end_col || row != end_row); ++k) {
      constexpr double kCornerTolerance = 1e-9;
      if (std::abs(t_max_c - t_max_r) <= kCornerTolerance) {
        // Through a corner: both side cells must be free too (no squeezing between blocks).
        if (in_grid(row, col + step_c) && !passable(grid_.index(row, col + step_c))) return kInf;
        if (in_grid(row + step_r, col) && !passable(grid_.index(row + step_r, col))) return kInf;
        col += step_c;
        row += step_r;
        t_max_c += t_delta_c;
        t_max_r += t_delta_r;
      } else if (t_max_c < t_max_r) {
        col += step_c;
        t_max_c += t_delta_c;
      } else {
        row += step_r;
        t_max_r += t_delta_r;
      }
      if (!in_grid(row, col)) return kInf;  // numerically left the grid: treat as no sight
      const int cell_index = grid_.index(row, col);
      const double z = altitude(cell_index);
      if (z == kInf) return kInf;
      vertical += std::abs(z - z_prev);
      ascent += std::max(0.0, z - z_prev);
      z_prev = z;
    }
    if (col != end_col || row != end_row) return kInf;
    const double length = (pb - pa).norm();
    return std::sqrt(length * length + vertical * vertical) + o_.climb_penalty * ascent;
  }

  // Lazy Theta*'s SetVertex: with line of sight to the assumed parent, g(s) becomes its exact
  // cost; without, s takes the best closed neighbour (one exists: s was reached from it).
  void set_vertex(int s) {
    const int p = parent_[s];
    const double via_parent = segment_cost(p, s);
    if (via_parent < kInf) {
      g_[s] = g_[p] + via_parent + turn_cost(parent_[p], p, s);
      return;
    }
    double best = kInf;
    int best_parent = p;
    const int row = s / grid_.cols(), col = s % grid_.cols();
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        if (dr == 0 && dc == 0) continue;
        const int r = row + dr, c = col + dc;
        if (r < 0 || c < 0 || r >= grid_.rows() || c >= grid_.cols()) continue;
        const int nb = grid_.index(r, c);
        if (state_[nb] != kClosed) continue;
        const double cand = g_[nb] + segment_cost(nb, s) + turn_cost(parent_[nb], nb, s);
        if (cand < best) {
          best = cand;
          best_parent = nb;
        }
      }
    }
    g_[s] = best;
    parent_[s] = best_parent;
  }

  const ClearanceGrid& grid_;
  const PathSearchOptions& o_;
  Vec2 start_xy_, goal_xy_;
  int start_, goal_;
  std::vector<double> z_;
  double z_goal_ = 0.0;
  std::vector<double> g_;
  std::vector<int> parent_;
  std::vector<char> state_;
  int expanded_ = 0;
};

std::string describe(const NamedPoint& p, const char* role) {
  return fmt::format("{} '{}' at ({:.1f}, {:.1f}, {:.1f})", role, p.name, p.position_m.x(),
                     p.position_m.y(), p.position_m.z());
}

// Empty if the point may be a pin of the path, else the reason.
std::string check_point(const ClearanceGrid& grid, const NamedPoint& p, const char* role) {
  const world::AltitudeBand& band = grid.limits().altitude;
  const Vec3& x = p.position_m;
  if (!x.allFinite()) return describe(p, role) + ": position is not finite";
  if (!grid.contains(x.x(), x.y())) return describe(p, role) + ": outside the search area";
  if (x.z() < band.min_m || x.z() > band.max_m) {
    return describe(p, role) +
           fmt::format(": altitude outside the band [{}, {}] m", band.min_m, band.max_m);
  }
  const double ground = grid.terrain().height(x.x(), x.y());
  const double needed = grid.limits().clearance_floor_m(grid.terrain());
  if (x.z() < ground) {
    return describe(p, role) + fmt::format(": inside the terrain (ground at {:.1f} m)", ground);
  }
  if (x.z() - ground < needed) {
    return describe(p, role) + fmt::format(
                                   ": inside the terrain's safety envelope ({:.1f} m above ground "
                                   "at {:.1f} m, needs {:.1f} m)",
                                   x.z() - ground, ground, needed);
  }
  return {};
}

struct ProfileSample {
  double s = 0.0;
  Vec2 xy;
  double floor = 0.0;  // q(s)
  bool keep = false;   // polyline corner or pin
};

// What profile_leg found: an error (no profile can exist), or the loiter length still needed at
// either end for the pitch limit, or success (out filled).
struct LegProfile {
  std::string error;
  double loop_a_m = 0.0;  // extra horizontal path needed at the leg's start
  double loop_b_m = 0.0;  // … at its end
  bool needs_loop() const { return loop_a_m > 0.0 || loop_b_m > 0.0; }
};

// Builds the taut-string profile of one leg (file comment) into `out` (first = a, last = b).
LegProfile profile_leg(const ClearanceGrid& grid, const std::vector<Vec2>& poly, double z_a,
                       double z_b, double pad_m, const std::string& target_name,
                       std::vector<Vec3>& out) {
  LegProfile result;
  const auto& o = grid.options();
  const world::Terrain& terrain = grid.terrain();
  const double slope = std::tan(o.max_pitch_rad) * (1.0 - 1e-9);  // strictly inside θ_max
  const double hard_offset = grid.limits().clearance_floor_m(terrain);
  std::vector<ProfileSample> samples;
  double s = 0.0;
  for (std::size_t k = 0; k + 1 < poly.size(); ++k) {
    const Vec2 d = poly[k + 1] - poly[k];
    const double len = d.norm();
    const int n = std::max(1, static_cast<int>(std::ceil(len / o.profile_step_m)));
    for (int i = 0; i < n; ++i) {
      samples.push_back({s + len * i / n, poly[k] + d * (static_cast<double>(i) / n), 0.0, i == 0});
    }
    s += len;
  }
  samples.push_back({s, poly.back(), 0.0, true});
  const double total = s;
  // Climbing or descending more than the pitch limit allows over the leg: loiter at the lower
  // end, where every loop altitude is above the lower pin.
  if (z_b - z_a > slope * total) result.loop_a_m = (z_b - z_a) / slope - total;
  if (z_a - z_b > slope * total) result.loop_b_m = (z_a - z_b) / slope - total;
  if (result.needs_loop()) return result;
  for (auto& smp : samples) {
    const double cone = std::min(z_a + slope * smp.s, z_b + slope * (total - smp.s));
    const double upper = std::min(cone, grid.limits().altitude.max_m);
    // The pad covers terrain curvature between samples; near a pin it shrinks so that a pin at
    // exactly the required clearance stays reachable.
    const double pad = std::min(pad_m, slope * std::min(smp.s, total - smp.s));
    const double hard = terrain.height(smp.xy.x(), smp.xy.y()) + hard_offset + pad;
    if (hard > grid.limits().altitude.max_m) {
      result.error = fmt::format(
          "target '{}': terrain at ({:.1f}, {:.1f}) on its leg needs altitude >= {:.1f} m, above "
          "the max altitude {:.1f} m",
          target_name, smp.xy.x(), smp.xy.y(), hard, grid.limits().altitude.max_m);
      return result;
    }
    if (hard > z_a + slope * smp.s + 1e-9) {
      result.loop_a_m = std::max(result.loop_a_m, (hard - z_a) / slope - smp.s);
    }
    if (hard > z_b + slope * (total - smp.s) + 1e-9) {
      result.loop_b_m = std::max(result.loop_b_m, (hard - z_b) / slope - (total - smp.s));
    }
    const int cell = grid.cell_of(smp.xy.x(), smp.xy.y());
    smp.floor = std::max(hard, std::min(grid.required_altitude_m(cell), upper));
  }
  if (result.needs_loop()) return result;
  samples.front().floor = z_a;
  samples.back().floor = z_b;
  // Least concave majorant (upper hull, monotone chain in s).
  std::vector<int> hull;
  for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
    while (hull.size() >= 2) {
      const auto& p0 = samples[hull[hull.size() - 2]];
      const auto& p1 = samples[hull.back()];
      const auto& p2 = samples[i];
      const double cross =
          (p1.s - p0.s) * (p2.floor - p0.floor) - (p1.floor - p0.floor) * (p2.s - p0.s);
      if (cross >= 0.0) {
        hull.pop_back();
      } else {
        break;
      }
    }
    hull.push_back(i);
  }
  for (int h : hull) samples[h].keep = true;
  std::size_t seg = 0;
  for (const auto& smp : samples) {
    if (!smp.keep) continue;
    while (seg + 2 < hull.size() && samples[hull[seg + 1]].s < smp.s) ++seg;
    const auto& h0 = samples[hull[seg]];
    const auto& h1 = samples[hull[std::min(seg + 1, hull.size() - 1)]];
    const double z =
        h1.s > h0.s ? h0.floor + (h1.floor - h0.floor) * (smp.s - h0.s) / (h1.s - h0.s) : h0.floor;
    out.emplace_back(smp.xy.x(), smp.xy.y(), z);
  }
  out.front().z() = z_a;
  out.back().z() = z_b;
  return result;
}

// Inserts loiter loops at one end of a leg's horizontal polyline (at_start: at poly.front()):
// regular 16-gons of radius ρ = max(2·turn_margin, cell) through the pin, on the side of the
// leg with the lower terrain, enough turns to add `length_m` of horizontal path.
void insert_loops(const ClearanceGrid& grid, std::vector<Vec2>& poly, bool at_start,
                  double length_m) {
  const auto& o = grid.options();
  const double radius = std::max(2.0 * o.turn_margin_m, o.cell_size_m);
  constexpr int kSides = 16;
  const double perimeter = kSides * 2.0 * radius * std::sin(kPi / kSides);
  const int turns = std::max(1, static_cast<int>(std::ceil(length_m * 1.02 / perimeter)));
  const Vec2 pin = at_start ? poly.front() : poly.back();
  Vec2 dir =
      at_start ? Vec2(poly[1] - poly[0]) : Vec2(poly[poly.size() - 1] - poly[poly.size() - 2]);
  dir = dir.norm() > 0.0 ? Vec2(dir.normalized()) : Vec2(1.0, 0.0);
  const Vec2 normal(-dir.y(), dir.x());
  auto loop_points = [&](double side) {
    const Vec2 centre = pin + side * radius * normal;
    std::vector<Vec2> pts;
    for (int i = 1; i < kSides; ++i) {
      const double a = side * 2.0 * kPi * i / kSides;
      const Vec2 r = pin - centre;
      pts.push_back(centre + Vec2(std::cos(a) * r.x() - std::sin(a) * r.y(),
                                  std::sin(a) * r.x() + std::cos(a) * r.y()));
    }
    pts.push_back(pin);
    return pts;
  };
  auto highest = [&](const std::vector<Vec2>& pts) {
    double h = -kInf;
    for (const auto& p : pts) h = std::max(h, grid.terrain().height(p.x(), p.y()));
    return h;
  };
  const std::vector<Vec2> left = loop_points(1.0), right = loop_points(-1.0);
  const std::vector<Vec2>& loop = highest(right) < highest(left) ? right : left;
  std::vector<Vec2> all;
  for (int t = 0; t < turns; ++t) all.insert(all.end(), loop.begin(), loop.end());
  if (at_start) {
    poly.insert(poly.begin() + 1, all.begin(), all.end());
  } else {
    poly.insert(poly.end(), all.begin(), all.end());
  }
}

}  // namespace

std::string_view to_string(PathStatus status) {
  switch (status) {
    case PathStatus::kFound:
      return "found";
    case PathStatus::kUnreachable:
      return "unreachable";
    case PathStatus::kInvalidInput:
      return "invalid input";
    case PathStatus::kVerificationFailed:
      return "verification failed";
  }
  return "unknown";
}

ClearanceGrid::ClearanceGrid(const world::Terrain& terrain, const SearchArea& area,
                             const world::SafetyLimits& limits, const PathSearchOptions& options)
    : terrain_(terrain), area_(area), limits_(limits), options_(options) {
  const auto t0 = std::chrono::steady_clock::now();
  world::validate(limits_);
  validate_options(options_);
  if (!area.min_m.allFinite() || !area.max_m.allFinite() || !(area.max_m.x() > area.min_m.x()) ||
      !(area.max_m.y() > area.min_m.y())) {
    throw InputError("area", "must be finite with max > min in x and y");
  }
  const double cell = options_.cell_size_m;
  cols_ = std::max(1, static_cast<int>(std::ceil((area.max_m.x() - area.min_m.x()) / cell - 1e-9)));
  rows_ = std::max(1, static_cast<int>(std::ceil((area.max_m.y() - area.min_m.y()) / cell - 1e-9)));
  if (static_cast<double>(rows_) * cols_ > 2.5e7) {
    throw InputError("path_search.cell_size_m",
                     fmt::format("{} gives more than 25 million cells", cell));
  }
  // Terrain lattice over every footprint (cells grown by the margin), spacing ≤ footprint_sample_m.
  const double margin = options_.turn_margin_m;
  const Vec2 lattice_origin = area.min_m - Vec2(margin, margin);
  const double extent_x = cols_ * cell + 2 * margin, extent_y = rows_ * cell + 2 * margin;
  const int nx = static_cast<int>(std::ceil(extent_x / options_.footprint_sample_m)) + 1;
  const int ny = static_cast<int>(std::ceil(extent_y / options_.footprint_sample_m)) + 1;
  const double step_x = extent_x / (nx - 1), step_y = extent_y / (ny - 1);
  // Lattice index ranges covering [lo, hi] (in lattice coordinates), points just outside included.
  auto range = [](double lo, double hi, double step, int n) {
    const int a = std::clamp(static_cast<int>(std::floor(lo / step + 1e-9)), 0, n - 1);
    const int b = std::clamp(static_cast<int>(std::ceil(hi / step - 1e-9)), 0, n - 1);
    return std::pair<int, int>(a, b);
  };
  // Separable max: first over each cell's x-range per lattice row, then over its y-range.
  std::vector<double> row_max(static_cast<std::size_t>(ny) * cols_, -kInf);
  std::vector<double> line(nx);
  for (int j = 0; j < ny; ++j) {
    const double y = lattice_origin.y() + j * step_y;
    for (int i = 0; i < nx; ++i) line[i] = terrain.height(lattice_origin.x() + i * step_x, y);
    for (int c = 0; c < cols_; ++c) {
      const auto [a, b] = range(c * cell, (c + 1) * cell + 2 * margin, step_x, nx);
      row_max[static_cast<std::size_t>(j) * cols_ + c] =
          *std::max_element(line.begin() + a, line.begin() + b + 1);
    }
  }
  const double offset = limits_.clearance_floor_m(terrain);
  required_m_.assign(static_cast<std::size_t>(rows_) * cols_, 0.0);
  for (int r = 0; r < rows_; ++r) {
    const auto [a, b] = range(r * cell, (r + 1) * cell + 2 * margin, step_y, ny);
    for (int c = 0; c < cols_; ++c) {
      double top = -kInf;
      for (int j = a; j <= b; ++j)
        top = std::max(top, row_max[static_cast<std::size_t>(j) * cols_ + c]);
      required_m_[index(r, c)] = std::max(limits_.altitude.min_m, top + offset);  // eq. 14, 19–20
    }
  }
  build_time_ms_ = elapsed_ms(t0);
}

int ClearanceGrid::cell_of(double x_m, double y_m) const {
  const int c = std::clamp(
      static_cast<int>(std::floor((x_m - area_.min_m.x()) / options_.cell_size_m)), 0, cols_ - 1);
  const int r = std::clamp(
      static_cast<int>(std::floor((y_m - area_.min_m.y()) / options_.cell_size_m)), 0, rows_ - 1);
  return index(r, c);
}

Vec2 ClearanceGrid::cell_centre(int cell) const {
  const int r = cell / cols_, c = cell % cols_;
  return area_.min_m + options_.cell_size_m * Vec2(c + 0.5, r + 0.5);
}

bool ClearanceGrid::contains(double x_m, double y_m) const {
  return x_m >= area_.min_m.x() && x_m <= area_.max_m.x() && y_m >= area_.min_m.y() &&
         y_m <= area_.max_m.y();
}

PathCheck check_path(const world::Terrain& terrain, const std::vector<Vec3>& waypoints_m,
                     double step_m) {
  PathCheck check;
  check.min_clearance_m = kInf;
  check.min_altitude_m = kInf;
  check.max_altitude_m = -kInf;
  auto sample = [&](const Vec3& p) {
    check.min_clearance_m = std::min(check.min_clearance_m, p.z() - terrain.height(p.x(), p.y()));
    check.min_altitude_m = std::min(check.min_altitude_m, p.z());
    check.max_altitude_m = std::max(check.max_altitude_m, p.z());
  };
  if (!waypoints_m.empty()) sample(waypoints_m.front());
  for (std::size_t k = 0; k + 1 < waypoints_m.size(); ++k) {
    const Vec3 d = waypoints_m[k + 1] - waypoints_m[k];
    const double horizontal = d.head<2>().norm();
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / step_m)));
    for (int i = 1; i <= n; ++i) sample(waypoints_m[k] + d * (static_cast<double>(i) / n));
    check.max_pitch_rad = std::max(check.max_pitch_rad, std::atan2(std::abs(d.z()), horizontal));
  }
  return check;
}

PathResult plan_initial_path(const ClearanceGrid& grid, const NamedPoint& start,
                             const std::vector<NamedPoint>& targets) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto& o = grid.options();
  PathResult result;
  auto fail = [&](PathStatus status, std::string message, const std::string& name) {
    result.status = status;
    result.message = std::move(message);
    result.failed_point = name;
    result.waypoints_m.clear();
    result.target_waypoint_index.clear();
    result.search_time_ms = elapsed_ms(t0);
    return result;
  };
  if (auto e = check_point(grid, start, "start"); !e.empty())
    return fail(PathStatus::kInvalidInput, e, start.name);
  if (targets.empty())
    return fail(PathStatus::kInvalidInput, "targets: no target to fly to", start.name);
  for (const auto& t : targets) {
    if (auto e = check_point(grid, t, "target"); !e.empty())
      return fail(PathStatus::kInvalidInput, e, t.name);
  }

  // Horizontal legs.
  std::vector<std::vector<Vec2>> legs;
  const NamedPoint* from = &start;
  for (const auto& t : targets) {
    LegSearch search(grid, from->position_m.head<2>(), t.position_m.head<2>());
    std::vector<Vec2> poly = search.run();
    result.nodes_expanded += search.expanded();
    if (poly.empty()) {
      // Name the enclosed end: the one whose free region is smaller.
      const int start_region = search.closed_count();
      const int goal_region = search.goal_region_size(start_region + 1);
      if (goal_region <= start_region) {
        return fail(
            PathStatus::kUnreachable,
            fmt::format("target '{}' is unreachable from '{}': it is enclosed by terrain above the "
                        "altitude band (max {:.0f} m); its free region is {} cells",
                        t.name, from->name, grid.limits().altitude.max_m, goal_region),
            t.name);
      }
      return fail(PathStatus::kUnreachable,
                  fmt::format("start '{}' is enclosed by terrain above the altitude band (max "
                              "{:.0f} m; free region {} cells): target '{}' is unreachable",
                              from->name, grid.limits().altitude.max_m, start_region, t.name),
                  from->name);
    }
    // Drop repeated points (a start and goal in the same cell centre, etc.).
    std::vector<Vec2> clean{poly.front()};
    for (std::size_t k = 1; k < poly.size(); ++k) {
      if ((poly[k] - clean.back()).norm() > 1e-9) clean.push_back(poly[k]);
    }
    if (clean.size() == 1) clean.push_back(poly.back());
    legs.push_back(std::move(clean));
    from = &t;
  }

  // Vertical profile, verified; the pad grows if the dense check finds terrain between samples.
  const double required = grid.limits().clearance_floor_m(grid.terrain());
  double pad = o.profile_pad_m;
  for (int attempt = 0; attempt < 4; ++attempt, pad = std::max(1.0, 4.0 * pad)) {
    std::vector<Vec3> waypoints{start.position_m};
    std::vector<int> target_index;
    double z_from = start.position_m.z();
    for (std::size_t k = 0; k < legs.size(); ++k) {
      std::vector<Vec3> leg;
      LegProfile profile;
      for (int loops = 0; loops <= kMaxLoopInsertions; ++loops) {
        leg.clear();
        profile = profile_leg(grid, legs[k], z_from, targets[k].position_m.z(), pad,
                              targets[k].name, leg);
        if (!profile.error.empty())
          return fail(PathStatus::kUnreachable, profile.error, targets[k].name);
        if (!profile.needs_loop()) break;
        if (profile.loop_a_m > 0.0) insert_loops(grid, legs[k], true, profile.loop_a_m);
        if (profile.loop_b_m > 0.0) insert_loops(grid, legs[k], false, profile.loop_b_m);
      }
      if (profile.needs_loop()) {
        return fail(PathStatus::kUnreachable,
                    fmt::format("target '{}': cannot meet the pitch limit {:.1f} deg on its leg "
                                "even with loiter loops (still {:.0f} m short near the {})",
                                targets[k].name, rad_to_deg(o.max_pitch_rad),
                                std::max(profile.loop_a_m, profile.loop_b_m),
                                profile.loop_a_m > 0.0 ? "leg's start" : "target"),
                    targets[k].name);
      }
      leg.back() = targets[k].position_m;  // exactly the target
      waypoints.insert(waypoints.end(), leg.begin() + 1, leg.end());
      target_index.push_back(static_cast<int>(waypoints.size()) - 1);
      z_from = targets[k].position_m.z();
    }
    const PathCheck check = check_path(grid.terrain(), waypoints, o.check_step_m);
    result.min_clearance_m = check.min_clearance_m;
    result.max_pitch_rad = check.max_pitch_rad;
    constexpr double kTolerance_m = 1e-6;  // round-off of the profile arithmetic
    const bool band_ok = check.min_altitude_m >= grid.limits().altitude.min_m - kTolerance_m &&
                         check.max_altitude_m <= grid.limits().altitude.max_m + kTolerance_m;
    const bool pitch_ok = check.max_pitch_rad <= o.max_pitch_rad + 1e-9;
    if (check.min_clearance_m >= required - kTolerance_m && band_ok && pitch_ok) {
      result.status = PathStatus::kFound;
      result.waypoints_m = std::move(waypoints);
      result.target_waypoint_index = std::move(target_index);
      result.length_m = 0.0;
      for (std::size_t k = 0; k + 1 < result.waypoints_m.size(); ++k) {
        result.length_m += (result.waypoints_m[k + 1] - result.waypoints_m[k]).norm();
      }
      result.search_time_ms = elapsed_ms(t0);
      return result;
    }
    if (!band_ok || !pitch_ok) break;  // not a sampling effect: more pad would not help
  }
  return fail(
      PathStatus::kVerificationFailed,
      fmt::format(
          "path from '{}': dense check found clearance {:.2f} m (needs {:.2f}), pitch {:.2f} deg",
          start.name, result.min_clearance_m, required, rad_to_deg(result.max_pitch_rad)),
      start.name);
}

}  // namespace ridgeline::planning
