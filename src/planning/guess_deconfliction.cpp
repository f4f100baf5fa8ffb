#include "planning/guess_deconfliction.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "core/error.hpp"

namespace ridgeline::planning {
namespace {

Vec3 at(const std::vector<Vec3>& path, int k) {
  return path[static_cast<std::size_t>(std::min(k, static_cast<int>(path.size()) - 1))];
}

// Closest approach of the linear motion r(τ) = r0 + τ·d, τ ∈ [0, 1].
double closest_tau(const Vec2& r0, const Vec2& d) {
  const double dd = d.squaredNorm();
  return dd > 0.0 ? std::clamp(-r0.dot(d) / dd, 0.0, 1.0) : 0.0;
}

struct Interval {
  double lo = 0.0;
  double hi = 0.0;
};

// Lifts Δ of a uniform raise that bring two points with horizontal distance h and vertical
// offset dz (raised minus other) closer than D: (−dz − v, −dz + v), v = √(D² − h²).
void add_forbidden(double h, double dz, double d, std::vector<Interval>& out) {
  if (h >= d) return;
  const double v = std::sqrt(d * d - h * h);
  out.push_back({-dz - v, -dz + v});
}

// Least x ≥ lower outside every open interval.
double least_outside(double lower, const std::vector<Interval>& intervals) {
  double x = lower;
  for (bool moved = true; moved;) {
    moved = false;
    for (const Interval& iv : intervals)
      if (iv.lo < x && x < iv.hi) {
        x = iv.hi;
        moved = true;
      }
  }
  return x;
}

// Conflicting steps of `path` against the done UAVs, and the first of them (−1: none).
int conflicts_of(const std::vector<Vec3>& path, const std::vector<GuessUav>& uavs,
                 const std::vector<int>& done, double d, int* first) {
  int count = 0;
  *first = -1;
  const int n = static_cast<int>(path.size()) - 1;
  for (int j : done)
    for (int k = 0; k < n; ++k)
      if (step_min_distance(path, uavs[static_cast<std::size_t>(j)].guess_m, k) < d) {
        ++count;
        if (*first < 0 || k < *first) *first = k;
      }
  return count;
}

// The guess `base` with a delay of m steps taken on the leg that starts at fixed index L:
// from L it flies at f times its guess's speed until it is m steps late, then at its guess's
// speed again (path time σ(q) = L + f·(q − L) on the slow part, q − m after); the points after
// the slow part, fixed ones included, move m indices later. Empty when the slow part would not
// end before the leg's next fixed point.
bool delayed(const GuessUav& base, int L, int m, double f, GuessUav& out) {
  const int n = static_cast<int>(base.guess_m.size()) - 1;
  int end = L + 1;
  while (end < n && base.fixed[end] == 0) ++end;
  const double slow_s = m / (1.0 - f);  // slow part in steps of the grid
  if (L + f * slow_s > end - 1 + 1e-9) return false;
  out = base;
  out.guess_m.clear();
  out.fixed.clear();
  for (int q = 0; q <= n + m; ++q) {
    double sigma = q;
    if (q > L) sigma = q - L <= slow_s ? L + f * (q - L) : q - m;
    const int k = std::min(static_cast<int>(std::floor(sigma)), n - 1);
    const double a = sigma - k;
    out.guess_m.push_back((1.0 - a) * base.guess_m[k] + a * base.guess_m[k + 1]);
    const bool integral = std::abs(a) < 1e-12 || std::abs(a - 1.0) < 1e-12;
    const int kk = std::abs(a - 1.0) < 1e-12 ? k + 1 : k;
    out.fixed.push_back(integral && (q <= L || q - L > slow_s) ? base.fixed[kk] : 0);
  }
  return true;
}

}  // namespace

double step_min_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b, int k) {
  const Vec3 r0 = at(a, k) - at(b, k);
  const Vec3 d = (at(a, k + 1) - at(b, k + 1)) - r0;
  const double dd = d.squaredNorm();
  const double tau = dd > 0.0 ? std::clamp(-r0.dot(d) / dd, 0.0, 1.0) : 0.0;
  return (r0 + tau * d).norm();
}

double min_guess_separation(const std::vector<GuessUav>& uavs, double separation_m,
                            int* conflicts) {
  double best = std::numeric_limits<double>::infinity();
  int count = 0;
  for (std::size_t a = 0; a < uavs.size(); ++a)
    for (std::size_t b = a + 1; b < uavs.size(); ++b) {
      const int steps =
          static_cast<int>(std::max(uavs[a].guess_m.size(), uavs[b].guess_m.size())) - 1;
      for (int k = 0; k < std::max(steps, 1); ++k) {
        const double d = step_min_distance(uavs[a].guess_m, uavs[b].guess_m, k);
        best = std::min(best, d);
        if (d < separation_m) ++count;
      }
    }
  if (conflicts != nullptr) *conflicts = count;
  return best;
}

// Altitude layering of one UAV against the done ones (file comment); returns its lift.
namespace {

std::vector<double> lift_against(GuessUav& u, const std::vector<GuessUav>& uavs,
                                 const std::vector<int>& done, double max_altitude_m,
                                 const GuessDeconflictionOptions& options) {
  const double D = options.separation_m;
  const std::vector<Vec3> base = u.guess_m;
  const int n = static_cast<int>(base.size()) - 1;
  // Slopes the climb budget leaves, and the cap U (zero at fixed points, H_max above).
  std::vector<double> slope(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    // A step is bounded by the climb per step and by the grade over its own horizontal length
    // (a delayed UAV's slow steps are shorter than the cruise steps the climb budget assumes).
    const double horizontal_m = (base[k + 1] - base[k]).head<2>().norm();
    const double budget_m = std::min(u.max_climb_step_m, u.max_grade * horizontal_m);
    slope[k] =
        std::max(0.0, options.slope_fraction * budget_m - std::abs(base[k + 1].z() - base[k].z()));
  }
  std::vector<double> cap(static_cast<std::size_t>(n) + 1);
  for (int k = 0; k <= n; ++k)
    cap[k] = u.fixed[k] != 0 ? 0.0 : std::max(0.0, max_altitude_m - base[k].z());
  for (int k = 1; k <= n; ++k) cap[k] = std::min(cap[k], cap[k - 1] + slope[k - 1]);
  for (int k = n - 1; k >= 0; --k) cap[k] = std::min(cap[k], cap[k + 1] + slope[k]);

  std::vector<double> lower(static_cast<std::size_t>(n) + 1, 0.0);
  std::vector<double> lift(static_cast<std::size_t>(n) + 1, 0.0);
  std::vector<Interval> intervals;
  for (int pass = 0; pass < options.max_passes && !done.empty(); ++pass) {
    // need_k: the least lift ≥ lower_k outside the forbidden intervals of point k and of its
    // two steps (at their horizontally closest times).
    std::vector<double> need(static_cast<std::size_t>(n) + 1, 0.0);
    for (int k = 0; k <= n; ++k) {
      intervals.clear();
      for (int j : done) {
        const std::vector<Vec3>& other = uavs[static_cast<std::size_t>(j)].guess_m;
        const Vec3 r = base[k] - at(other, k);
        add_forbidden(r.head<2>().norm(), r.z(), D, intervals);
        for (int step : {k - 1, k}) {
          if (step < 0 || step >= n) continue;
          const Vec3 r0 = base[step] - at(other, step);
          const Vec3 r1 = base[step + 1] - at(other, step + 1);
          const double tau = closest_tau(r0.head<2>(), (r1 - r0).head<2>());
          const Vec3 rt = r0 + tau * (r1 - r0);
          add_forbidden(rt.head<2>().norm(), rt.z(), D, intervals);
        }
      }
      need[k] = least_outside(lower[k], intervals);
    }
    // Least majorant with the step slopes, capped.
    lift = need;
    for (int k = 1; k <= n; ++k) lift[k] = std::max(lift[k], lift[k - 1] - slope[k - 1]);
    for (int k = n - 1; k >= 0; --k) lift[k] = std::max(lift[k], lift[k + 1] - slope[k]);
    for (int k = 0; k <= n; ++k) lift[k] = std::min(lift[k], cap[k]);

    for (int k = 0; k <= n; ++k) u.guess_m[k].z() = base[k].z() + lift[k];
    // Exact check of the lifted guess; a step still in conflict raises both ends.
    bool raised = false;
    for (int j : done) {
      const std::vector<Vec3>& other = uavs[static_cast<std::size_t>(j)].guess_m;
      for (int k = 0; k < n; ++k) {
        if (step_min_distance(u.guess_m, other, k) >= D) continue;
        const double target = std::max(lift[k], lift[k + 1]) + 0.5;
        for (int e : {k, k + 1})
          if (target > lower[e] && lower[e] < cap[e]) {
            lower[e] = std::min(target, cap[e]);
            raised = true;
          }
      }
    }
    if (!raised) break;
  }
  return lift;
}

}  // namespace

GuessDeconflictionSummary deconflict_guesses(std::vector<GuessUav>& uavs,
                                             const world::AltitudeBand& band,
                                             const GuessDeconflictionOptions& options) {
  if (!(options.separation_m > 0.0) || !std::isfinite(options.separation_m))
    throw InputError("guess_deconfliction.separation_m",
                     fmt::format("must be positive and finite, got {}", options.separation_m));
  if (!(options.slope_fraction > 0.0 && options.slope_fraction <= 1.0))
    throw InputError("guess_deconfliction.slope_fraction",
                     fmt::format("must be in (0, 1], got {}", options.slope_fraction));
  if (options.max_passes < 1)
    throw InputError("guess_deconfliction.max_passes",
                     fmt::format("must be >= 1, got {}", options.max_passes));
  if (options.max_delay_steps < 0)
    throw InputError("guess_deconfliction.max_delay_steps",
                     fmt::format("must be >= 0, got {}", options.max_delay_steps));
  if (!(options.slow_speed_ratio > 0.0 && options.slow_speed_ratio < 1.0))
    throw InputError("guess_deconfliction.slow_speed_ratio",
                     fmt::format("must be in (0, 1), got {}", options.slow_speed_ratio));
  for (std::size_t i = 0; i < uavs.size(); ++i) {
    const GuessUav& u = uavs[i];
    if (u.guess_m.size() < 2 || u.fixed.size() != u.guess_m.size())
      throw InputError(fmt::format("uavs[{}].guess_m", i),
                       "needs >= 2 points and one fixed flag per point");
    if (!(u.max_climb_step_m > 0.0))
      throw InputError(fmt::format("uavs[{}].max_climb_step_m", i), "must be positive");
    if (!(u.max_grade > 0.0))
      throw InputError(fmt::format("uavs[{}].max_grade", i), "must be positive");
    if (!(u.min_speed_ratio >= 0.0 && u.min_speed_ratio < 1.0))
      throw InputError(fmt::format("uavs[{}].min_speed_ratio", i), "must be in [0, 1)");
  }

  const double D = options.separation_m;
  GuessDeconflictionSummary summary;
  summary.min_separation_before_m = min_guess_separation(uavs, D, &summary.conflicts_before);

  std::vector<int> order(uavs.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return uavs[static_cast<std::size_t>(a)].guess_m.size() <
           uavs[static_cast<std::size_t>(b)].guess_m.size();
  });

  std::vector<int> done;
  for (int i : order) {
    GuessUav& u = uavs[static_cast<std::size_t>(i)];
    // Lift; while conflicts remain, try delays of 1 … max_delay_steps on the leg of the first
    // one (each lifted again), and keep the best.
    GuessUav best = u;
    std::vector<double> best_lift = lift_against(best, uavs, done, band.max_m, options);
    int first = -1;
    int best_conflicts = conflicts_of(best.guess_m, uavs, done, D, &first);
    int best_delay = 0;
    bool was_delayed = false;
    const double f = std::max(options.slow_speed_ratio, u.min_speed_ratio + 0.05);
    for (int round = 0; round < 3 && best_conflicts > 0 && f < 1.0; ++round) {
      const GuessUav from = u;  // the unlifted guess with the delays taken so far
      int L = std::min(first, static_cast<int>(from.guess_m.size()) - 2);
      while (L > 0 && from.fixed[L] == 0) --L;
      GuessUav round_best;
      bool improved = false;
      for (int m = 1; m <= options.max_delay_steps; ++m) {
        GuessUav candidate;
        if (!delayed(from, L, m, f, candidate)) break;
        const GuessUav unlifted = candidate;
        std::vector<double> lift = lift_against(candidate, uavs, done, band.max_m, options);
        int candidate_first = -1;
        const int c = conflicts_of(candidate.guess_m, uavs, done, D, &candidate_first);
        if (c < best_conflicts) {
          best_conflicts = c;
          best = candidate;
          best_lift = lift;
          best_delay = m;
          first = candidate_first;
          round_best = unlifted;
          improved = true;
          if (c == 0) break;
        }
      }
      if (!improved) break;
      summary.delay_steps += best_delay;
      was_delayed = true;
      u = round_best;  // further rounds delay later legs of this guess
    }
    if (was_delayed) ++summary.delayed_uavs;
    u = best;
    const double max_lift = *std::max_element(best_lift.begin(), best_lift.end());
    if (max_lift > 0.0) ++summary.lifted_uavs;
    summary.max_lift_m = std::max(summary.max_lift_m, max_lift);
    done.push_back(i);
  }
  summary.min_separation_after_m = min_guess_separation(uavs, D, &summary.conflicts_after);
  return summary;
}

}  // namespace ridgeline::planning
