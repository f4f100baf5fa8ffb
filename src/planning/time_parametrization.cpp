#include "planning/time_parametrization.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include "core/error.hpp"

namespace ridgeline::planning {

std::string_view to_string(TimeParametrizationStatus status) {
  switch (status) {
    case TimeParametrizationStatus::kOk:
      return "ok";
    case TimeParametrizationStatus::kLimitViolated:
      return "limit violated";
    case TimeParametrizationStatus::kTimingMissed:
      return "timing missed";
    case TimeParametrizationStatus::kInvalidInput:
      return "invalid input";
  }
  return "unknown";
}

std::string_view to_string(LimitKind kind) {
  switch (kind) {
    case LimitKind::kTurnRadius:
      return "turn radius";
    case LimitKind::kClimbRate:
      return "climb rate";
    case LimitKind::kPitch:
      return "pitch";
    case LimitKind::kLateralAccel:
      return "lateral acceleration";
  }
  return "unknown";
}

namespace {

// Pieces shorter than this (m) carry no motion; they only keep the waypoint bookkeeping.
constexpr double kTinyLength_m = 1e-9;

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }
Vec2 left_normal(const Vec2& d) { return Vec2(-d.y(), d.x()); }
double angle_of(const Vec2& v) { return std::atan2(v.y(), v.x()); }

// One piece of the horizontal curve with a constant grade: a line or an arc.
struct Piece {
  bool is_arc = false;
  Vec2 start = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();  // line: unit direction
  Vec2 centre = Vec2::Zero();      // arc
  double radius_m = 0.0;           // arc
  double phase0_rad = 0.0;         // arc: angle of the start point seen from the centre
  double sigma = 1.0;              // arc: +1 counter-clockwise (left turn), −1 clockwise
  double length_m = 0.0;           // horizontal arc length
  double z0_m = 0.0;
  double grade = 0.0;         // dz/ds
  bool level = false;         // part of a reversal loop: flown at its vertex's height
  double heading0_rad = 0.0;  // unwrapped tangent heading at the start
  int waypoint = 0;           // input index (segment's first point or corner vertex)
  double cap_m_s = 0.0;       // speed cap v̄
};

double curvature(const Piece& p) { return p.is_arc ? 1.0 / p.radius_m : 0.0; }
double heading_at(const Piece& p, double s) {
  return p.is_arc ? p.heading0_rad + p.sigma * s / p.radius_m : p.heading0_rad;
}
Vec3 position_at(const Piece& p, double s) {
  Vec2 xy;
  if (p.is_arc) {
    const double phi = p.phase0_rad + p.sigma * s / p.radius_m;
    xy = p.centre + p.radius_m * Vec2(std::cos(phi), std::sin(phi));
  } else {
    xy = p.start + s * p.direction;
  }
  return Vec3(xy.x(), xy.y(), p.z0_m + p.grade * s);
}

struct Violation {
  LimitKind kind;
  int waypoint;
  double value;
  double limit;
  int piece_begin;  // piece range [begin, end); begin == end: at the boundary `begin`
  int piece_end;
  std::string description;
};

struct Geometry {
  std::vector<Piece> pieces;
  std::vector<int> kept_of_input;     // input waypoint → kept waypoint
  std::vector<int> input_of_kept;     // kept waypoint → input waypoint
  std::vector<int> boundary_of_kept;  // kept waypoint → piece boundary where it is passed
  std::vector<Vec3> kept_points;
  std::vector<Violation> violations;
  int corners_rounded = 0;
  int corners_tightened = 0;
  int reversal_loops = 0;
  int duplicates_removed = 0;
};

void append_arc(std::vector<Piece>& pieces, const Vec2& centre, double radius, const Vec2& from,
                double sigma, double sweep_rad, int waypoint, bool level = false) {
  Piece p;
  p.is_arc = true;
  p.centre = centre;
  p.radius_m = radius;
  p.phase0_rad = angle_of(from - centre);
  p.start = from;
  p.sigma = sigma;
  p.length_m = radius * sweep_rad;
  p.level = level;
  p.heading0_rad = p.phase0_rad + sigma * 0.5 * kPi;
  p.waypoint = waypoint;
  pieces.push_back(p);
}

// Positive angle (0, 2π] swept from a to b about a centre, turning in direction sigma.
double sweep_between(const Vec2& a, const Vec2& b, double sigma) {
  double d = sigma * (angle_of(b) - angle_of(a));
  d = std::fmod(d, 2.0 * kPi);
  if (d <= 1e-12) d += 2.0 * kPi;
  return d;
}

Geometry build_geometry(const std::vector<Vec3>& w, const vehicle::VehicleParams& vp,
                        const TimeParametrizationOptions& o) {
  Geometry g;
  const int n = static_cast<int>(w.size());
  g.kept_of_input.assign(n, 0);
  g.kept_points.push_back(w[0]);
  g.input_of_kept.push_back(0);
  for (int i = 1; i < n; ++i) {
    const Vec3& last = g.kept_points.back();
    if ((w[i] - last).head<2>().norm() >= o.merge_tolerance_m) {
      g.kept_points.push_back(w[i]);
      g.input_of_kept.push_back(i);
      g.kept_of_input[i] = static_cast<int>(g.kept_points.size()) - 1;
      continue;
    }
    ++g.duplicates_removed;
    const double dz = std::abs(w[i].z() - last.z());
    if (dz > o.merge_tolerance_m) {
      g.violations.push_back({LimitKind::kPitch, i - 1, 0.5 * kPi, vp.max_pitch_rad,
                              static_cast<int>(g.kept_points.size()) - 1, -1,
                              "waypoints " + std::to_string(i - 1) + "→" + std::to_string(i) +
                                  " form a vertical segment (" + std::to_string(dz) +
                                  " m): merged, the height change moves to the next segment"});
    }
    // The final waypoint is where the mission ends: keep it rather than its duplicate.
    if (i == n - 1 && g.kept_points.size() > 1) {
      g.kept_points.back() = w[i];
      g.input_of_kept.back() = i;
    }
    g.kept_of_input[i] = static_cast<int>(g.kept_points.size()) - 1;
  }
  const int m = static_cast<int>(g.kept_points.size());
  if (m < 2) {
    throw InputError("waypoints_m",
                     "all waypoints coincide horizontally (within merge_tolerance_m): the path "
                     "has no horizontal extent to fly at a speed in the band");
  }
  const auto& P = g.kept_points;

  // Segments (kept indices j → j+1).
  std::vector<Vec2> dir(m - 1);
  std::vector<double> len(m - 1);
  for (int j = 0; j + 1 < m; ++j) {
    const Vec2 d = (P[j + 1] - P[j]).head<2>();
    len[j] = d.norm();
    dir[j] = d / len[j];
  }

  // Corner plans at interior vertices.
  enum class CornerType { kNone, kArc, kLoop };
  struct Corner {
    CornerType type = CornerType::kNone;
    double radius = 0.0;
    double tangent = 0.0;  // L_t
    double turn = 0.0;     // signed φ
  };
  std::vector<Corner> corners(m);
  const double r_target = o.turn_radius_safety_factor * vp.min_turn_radius_m;
  for (int i = 1; i + 1 < m; ++i) {
    Corner& c = corners[i];
    c.turn = std::atan2(cross2(dir[i - 1], dir[i]), dir[i - 1].dot(dir[i]));
    const double phi = std::abs(c.turn);
    if (phi < 1e-9) continue;
    const double avail_in = i - 1 == 0 ? len[i - 1] : 0.5 * len[i - 1];
    const double avail_out = i == m - 2 ? len[i] : 0.5 * len[i];
    const double avail = std::min(avail_in, avail_out);
    const double t_half = std::tan(0.5 * phi);
    double radius = o.corner_rounding == CornerRounding::kWidest ? avail / t_half : r_target;
    if (radius < r_target || radius * t_half > avail) {
      if (phi >= o.loop_turn_angle_rad) {
        c.type = CornerType::kLoop;
        c.radius = r_target;
        continue;
      }
      radius = avail / t_half;
      if (radius < r_target) ++g.corners_tightened;
    }
    c.type = CornerType::kArc;
    c.radius = radius;
    c.tangent = std::min(radius * t_half, avail);
  }

  // Emit pieces: segment j's line part, then the corner at vertex j+1.
  g.boundary_of_kept.assign(m, 0);
  auto& pieces = g.pieces;
  for (int j = 0; j + 1 < m; ++j) {
    const double trim0 = corners[j].type == CornerType::kArc ? corners[j].tangent : 0.0;
    const double trim1 = corners[j + 1].type == CornerType::kArc ? corners[j + 1].tangent : 0.0;
    const double line_len = std::max(0.0, len[j] - trim0 - trim1);
    if (line_len > kTinyLength_m) {
      Piece p;
      p.start = P[j].head<2>() + trim0 * dir[j];
      p.direction = dir[j];
      p.length_m = line_len;
      p.heading0_rad = angle_of(dir[j]);
      p.waypoint = g.input_of_kept[j];
      pieces.push_back(p);
    }
    const int v = j + 1;
    if (v == m - 1) break;
    const Corner& c = corners[v];
    const Vec2 V = P[v].head<2>();
    const int wp = g.input_of_kept[v];
    const double sigma = c.turn >= 0.0 ? 1.0 : -1.0;
    if (c.type == CornerType::kNone) {
      g.boundary_of_kept[v] = static_cast<int>(pieces.size());
    } else if (c.type == CornerType::kArc) {
      ++g.corners_rounded;
      const Vec2 t1 = V - c.tangent * dir[v - 1];
      const Vec2 centre = t1 + sigma * c.radius * left_normal(dir[v - 1]);
      const double half = 0.5 * std::abs(c.turn);
      const int first = static_cast<int>(pieces.size());
      append_arc(pieces, centre, c.radius, t1, sigma, half, wp);
      g.boundary_of_kept[v] = static_cast<int>(pieces.size());
      const double phase_mid = angle_of(t1 - centre) + sigma * half;
      const Vec2 mid = centre + c.radius * Vec2(std::cos(phase_mid), std::sin(phase_mid));
      append_arc(pieces, centre, c.radius, mid, sigma, half, wp);
      if (c.radius < vp.min_turn_radius_m) {
        g.violations.push_back(
            {LimitKind::kTurnRadius, wp, c.radius, vp.min_turn_radius_m, first, first + 2,
             "corner at waypoint " + std::to_string(wp) + " (turn " +
                 std::to_string(rad_to_deg(std::abs(c.turn))) + "°) leaves room for radius " +
                 std::to_string(c.radius) + " m only"});
      }
    } else {
      // Loop through the vertex: −σ arc about C1, σ arc about C2, −σ arc about C3, radius R;
      // C1 and C3 are the centres of the turns tangent to the segments at V, C2 is 2R from
      // both, ahead of V along the incoming direction.
      ++g.reversal_loops;
      const double R = c.radius;
      const Vec2 c1 = V - sigma * R * left_normal(dir[v - 1]);
      const Vec2 c3 = V - sigma * R * left_normal(dir[v]);
      const Vec2 mid = 0.5 * (c1 + c3);
      const Vec2 across = c3 - c1;
      const double h = 0.5 * across.norm();
      Vec2 perp = h > 1e-12 ? Vec2(left_normal(across / (2.0 * h))) : Vec2(dir[v - 1]);
      if (perp.dot(dir[v - 1]) < 0.0) perp = -perp;
      const Vec2 c2 = mid + std::sqrt(std::max(0.0, 4.0 * R * R - h * h)) * perp;
      const Vec2 t1 = 0.5 * (c1 + c2);
      const Vec2 t2 = 0.5 * (c2 + c3);
      append_arc(pieces, c1, R, V, -sigma, sweep_between(V - c1, t1 - c1, -sigma), wp, true);
      const double sweep2 = sweep_between(t1 - c2, t2 - c2, sigma);
      append_arc(pieces, c2, R, t1, sigma, 0.5 * sweep2, wp, true);
      g.boundary_of_kept[v] = static_cast<int>(pieces.size());
      const double phase_mid = angle_of(t1 - c2) + sigma * 0.5 * sweep2;
      append_arc(pieces, c2, R, c2 + R * Vec2(std::cos(phase_mid), std::sin(phase_mid)), sigma,
                 0.5 * sweep2, wp, true);
      append_arc(pieces, c3, R, t2, -sigma, sweep_between(t2 - c3, V - c3, -sigma), wp, true);
    }
  }
  g.boundary_of_kept[0] = 0;
  g.boundary_of_kept[m - 1] = static_cast<int>(pieces.size());

  // Heights: between the path points of two consecutive kept waypoints (boundary_of_kept: the
  // vertex, its arc's midpoint or its loop's far point) z is linear in the flown horizontal arc
  // length, loops level at their vertex. A corner arc is shorter than the two tangent lengths it
  // replaces, by c = R·(tan(φ/2) − φ/2); spread over the whole stretch that steepens it by
  // c/stretch (~1 % for R = 12 m, φ = 60°, 50 m segments), where a height linear on the arc
  // alone between its tangent points steepened the arc by 2·tan(φ/2)/φ (10 % at 60°), so a climb
  // at the segments' pitch or climb limit broke the limit on every corner it turned.
  for (int j = 0; j + 1 < m; ++j) {
    const int begin = g.boundary_of_kept[j];
    const int end = g.boundary_of_kept[j + 1];
    double sloped_m = 0.0;
    for (int k = begin; k < end; ++k)
      if (!pieces[k].level) sloped_m += pieces[k].length_m;
    const double rise_m = P[j + 1].z() - P[j].z();
    const double grade = sloped_m > kTinyLength_m ? rise_m / sloped_m : 0.0;
    double z = P[j].z();
    for (int k = begin; k < end; ++k) {
      pieces[k].z0_m = z;
      pieces[k].grade = pieces[k].level ? 0.0 : grade;
      z += pieces[k].grade * pieces[k].length_m;
    }
  }

  // Unwrap the headings along the path so ψ is continuous.
  for (std::size_t k = 1; k < pieces.size(); ++k) {
    const double prev_end = heading_at(pieces[k - 1], pieces[k - 1].length_m);
    pieces[k].heading0_rad = prev_end + wrap_angle(pieces[k].heading0_rad - prev_end);
  }
  return g;
}

// Speed caps v̄ per piece (file comment, step 3) and the limits no speed can meet.
void assign_caps(Geometry& g, const vehicle::VehicleParams& vp, const TimeParametrizationOptions& o,
                 double cruise) {
  const double v_min = vp.min_speed_m_s();
  for (std::size_t k = 0; k < g.pieces.size(); ++k) {
    Piece& p = g.pieces[k];
    const int ki = static_cast<int>(k);
    const double abs_grade = std::abs(p.grade);
    double cap = std::min(cruise, vp.max_speed_m_s());
    if (abs_grade > 0.0) cap = std::min(cap, vp.max_climb_rate_m_s / abs_grade);
    if (p.is_arc && std::isfinite(o.max_lateral_accel_m_s2)) {
      cap = std::min(cap, std::sqrt(o.max_lateral_accel_m_s2 * p.radius_m));
    }
    if (cap < v_min) {
      cap = v_min;
      if (v_min * abs_grade > vp.max_climb_rate_m_s) {
        g.violations.push_back({LimitKind::kClimbRate, p.waypoint, v_min * abs_grade,
                                vp.max_climb_rate_m_s, ki, ki + 1,
                                "grade " + std::to_string(p.grade) + " after waypoint " +
                                    std::to_string(p.waypoint) +
                                    " needs a climb rate above w_max even at v0 − Δv"});
      }
      if (p.is_arc && v_min * v_min / p.radius_m > o.max_lateral_accel_m_s2) {
        g.violations.push_back({LimitKind::kLateralAccel, p.waypoint, v_min * v_min / p.radius_m,
                                o.max_lateral_accel_m_s2, ki, ki + 1,
                                "corner at waypoint " + std::to_string(p.waypoint) +
                                    " exceeds the lateral acceleration even at v0 − Δv"});
      }
    }
    if (std::atan(abs_grade) > vp.max_pitch_rad) {
      g.violations.push_back({LimitKind::kPitch, p.waypoint, std::atan(abs_grade), vp.max_pitch_rad,
                              ki, ki + 1,
                              "grade " + std::to_string(p.grade) + " after waypoint " +
                                  std::to_string(p.waypoint) + " is steeper than θ_max"});
    }
    p.cap_m_s = cap;
  }
}

// A stretch of constant acceleration inside one piece.
struct Phase {
  int piece;
  double t0_s;
  double s0_m;  // local arc length in the piece
  double length_m;
  double v0_m_s;
  double accel_m_s2;
  double duration_s;
};

struct Profile {
  std::vector<Phase> phases;
  std::vector<double> piece_t0_s;  // size pieces + 1: the time each piece starts (and the end)
};

Profile make_profile(const std::vector<Piece>& pieces, const std::vector<double>& caps,
                     double v_init, std::optional<double> v_final, double a, double t_start) {
  const std::size_t np = pieces.size();
  std::vector<double> u(np + 1);
  u[0] = std::min(v_init, caps[0]);
  u[np] = v_final ? std::min(*v_final, caps[np - 1]) : caps[np - 1];
  for (std::size_t k = 1; k < np; ++k) u[k] = std::min(caps[k - 1], caps[k]);
  for (std::size_t k = 1; k <= np; ++k) {
    u[k] = std::min(u[k], std::sqrt(u[k - 1] * u[k - 1] + 2.0 * a * pieces[k - 1].length_m));
  }
  for (std::size_t k = np; k-- > 0;) {
    u[k] = std::min(u[k], std::sqrt(u[k + 1] * u[k + 1] + 2.0 * a * pieces[k].length_m));
  }

  Profile prof;
  prof.piece_t0_s.resize(np + 1);
  double t = t_start;
  auto add = [&](int piece, double s0, double length, double v0, double accel) {
    if (length <= kTinyLength_m) return;
    const double v1 = std::sqrt(std::max(0.0, v0 * v0 + 2.0 * accel * length));
    const double duration = 2.0 * length / (v0 + v1);  // exact under constant acceleration
    prof.phases.push_back({piece, t, s0, length, v0, accel, duration});
    t += duration;
  };
  for (std::size_t k = 0; k < np; ++k) {
    prof.piece_t0_s[k] = t;
    const int ki = static_cast<int>(k);
    const double L = pieces[k].length_m;
    const double c = caps[k];
    const double va = u[k];
    const double vb = u[k + 1];
    const double s1 = (c * c - va * va) / (2.0 * a);
    const double s2 = L - (c * c - vb * vb) / (2.0 * a);
    if (s1 <= s2) {
      add(ki, 0.0, s1, va, a);
      add(ki, s1, s2 - s1, c, 0.0);
      add(ki, s2, L - s2, std::sqrt(va * va + 2.0 * a * s1), -a);
    } else {
      const double sm = std::clamp((vb * vb - va * va + 2.0 * a * L) / (4.0 * a), 0.0, L);
      add(ki, 0.0, sm, va, a);
      add(ki, sm, L - sm, std::sqrt(va * va + 2.0 * a * sm), -a);
    }
  }
  prof.piece_t0_s[np] = t;
  return prof;
}

void check_inputs(const std::vector<Vec3>& w, const vehicle::VehicleParams& vp,
                  const TimeParametrizationOptions& o) {
  auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (w.size() < 2) throw InputError("waypoints_m", "needs at least 2 waypoints");
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (!w[i].allFinite()) {
      throw InputError("waypoints_m[" + std::to_string(i) + "]", "is not finite");
    }
  }
  if (!positive(vp.cruise_speed_m_s)) throw InputError("vehicle.cruise_speed_m_s", "must be > 0");
  if (!(std::isfinite(vp.speed_band_m_s) && vp.speed_band_m_s >= 0.0 &&
        vp.speed_band_m_s <= vp.cruise_speed_m_s)) {
    throw InputError("vehicle.speed_band_m_s", "must be in [0, cruise_speed_m_s]");
  }
  if (!positive(vp.min_turn_radius_m)) throw InputError("vehicle.min_turn_radius_m", "must be > 0");
  if (!positive(vp.max_climb_rate_m_s)) {
    throw InputError("vehicle.max_climb_rate_m_s", "must be > 0");
  }
  if (!(positive(vp.max_pitch_rad) && vp.max_pitch_rad < 0.5 * kPi)) {
    throw InputError("vehicle.max_pitch_rad", "must be in (0, π/2)");
  }
  if (!positive(o.control_period_s)) throw InputError("options.control_period_s", "must be > 0");
  if (o.cruise_speed_m_s && !positive(*o.cruise_speed_m_s)) {
    throw InputError("options.cruise_speed_m_s", "must be > 0");
  }
  if (!std::isfinite(o.start_time_s)) throw InputError("options.start_time_s", "is not finite");
  if (!(std::isfinite(o.turn_radius_safety_factor) && o.turn_radius_safety_factor >= 1.0)) {
    throw InputError("options.turn_radius_safety_factor", "must be ≥ 1");
  }
  if (!positive(o.max_accel_m_s2)) throw InputError("options.max_accel_m_s2", "must be > 0");
  if (!(o.max_lateral_accel_m_s2 > 0.0)) {
    throw InputError("options.max_lateral_accel_m_s2", "must be > 0 (infinity: no limit)");
  }
  const auto in_band = [&](const std::optional<double>& v) {
    return !v || (std::isfinite(*v) && *v >= vp.min_speed_m_s() && *v <= vp.max_speed_m_s());
  };
  if (!in_band(o.initial_speed_m_s)) {
    throw InputError("options.initial_speed_m_s", "must lie in the speed band [v0 − Δv, v0 + Δv]");
  }
  if (!in_band(o.final_speed_m_s)) {
    throw InputError("options.final_speed_m_s", "must lie in the speed band [v0 − Δv, v0 + Δv]");
  }
  if (!(std::isfinite(o.merge_tolerance_m) && o.merge_tolerance_m >= 1e-6)) {
    throw InputError("options.merge_tolerance_m", "must be ≥ 1e-6 m");
  }
  if (!(std::isfinite(o.loop_turn_angle_rad) && o.loop_turn_angle_rad > 0.0)) {
    throw InputError("options.loop_turn_angle_rad", "must be > 0 (above π: never loop)");
  }
  if (!(std::isfinite(o.timing_window_m) && o.timing_window_m >= 0.0)) {
    throw InputError("options.timing_window_m", "must be finite and ≥ 0");
  }
  if (o.max_timing_iterations < 1) {
    throw InputError("options.max_timing_iterations", "must be ≥ 1");
  }
  if (!(std::isfinite(o.time_tolerance_s) && o.time_tolerance_s >= 0.0)) {
    throw InputError("options.time_tolerance_s", "must be ≥ 0");
  }
}

// Samples the profile every control period and fills the result's reference and statistics.
void sample_into(const Geometry& g, const Profile& prof, const vehicle::VehicleParams& vp,
                 const TimeParametrizationOptions& o, double t_start,
                 TimeParametrizationResult& r) {
  const double t_end = prof.piece_t0_s.back();
  const double dt = o.control_period_s;
  const auto grid = static_cast<long>(std::floor((t_end - t_start) / dt));
  std::vector<double> times;
  times.reserve(static_cast<std::size_t>(grid) + 2);
  for (long k = 0; k <= grid; ++k) times.push_back(t_start + static_cast<double>(k) * dt);
  // The end time closes the reference; a grid point within 1e-6 Δt of it is replaced by it.
  if (t_end - times.back() > 1e-6 * dt) {
    times.push_back(t_end);
  } else if (times.size() > 1) {
    times.back() = t_end;
  } else {
    times.push_back(t_end);
  }

  std::vector<mpc::ReferencePoint> pts(times.size());
  std::size_t ph = 0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    while (ph + 1 < prof.phases.size() &&
           times[i] > prof.phases[ph].t0_s + prof.phases[ph].duration_s) {
      ++ph;
    }
    const Phase& f = prof.phases[ph];
    const double tau = std::clamp(times[i] - f.t0_s, 0.0, f.duration_s);
    const double v = std::max(0.0, f.v0_m_s + f.accel_m_s2 * tau);
    const double s =
        f.s0_m + std::clamp(f.v0_m_s * tau + 0.5 * f.accel_m_s2 * tau * tau, 0.0, f.length_m);
    const Piece& p = g.pieces[static_cast<std::size_t>(f.piece)];
    mpc::ReferencePoint& q = pts[i];
    q.position_m = position_at(p, s);
    q.heading_rad = heading_at(p, s);
    q.speed_m_s = v;
    q.turn_rate_rad_s = p.is_arc ? p.sigma * v / p.radius_m : 0.0;
    q.climb_rate_m_s = v * p.grade;
  }

  r.duration_s = t_end - t_start;
  r.min_speed_m_s = std::numeric_limits<double>::infinity();
  for (const auto& q : pts) {
    r.max_turn_rate_rad_s = std::max(r.max_turn_rate_rad_s, std::abs(q.turn_rate_rad_s));
    r.max_climb_rate_m_s = std::max(r.max_climb_rate_m_s, std::abs(q.climb_rate_m_s));
    r.min_speed_m_s = std::min(r.min_speed_m_s, q.speed_m_s);
    r.max_speed_m_s = std::max(r.max_speed_m_s, q.speed_m_s);
  }
  const double cruise =
      std::min(o.cruise_speed_m_s.value_or(vp.cruise_speed_m_s), vp.max_speed_m_s());
  int last_slowed_corner = -1;
  for (const Piece& p : g.pieces) {
    r.horizontal_length_m += p.length_m;
    r.path_length_m += p.length_m * std::sqrt(1.0 + p.grade * p.grade);
    r.max_pitch_rad = std::max(r.max_pitch_rad, std::atan(std::abs(p.grade)));
    if (p.is_arc) {
      r.max_curvature_1_m = std::max(r.max_curvature_1_m, curvature(p));
      r.min_turn_radius_m = std::min(r.min_turn_radius_m, p.radius_m);
      if (p.cap_m_s < cruise - 1e-9 && p.waypoint != last_slowed_corner) {
        ++r.corners_slowed;
        last_slowed_corner = p.waypoint;
      }
    }
  }
  r.sample_times_s = times;
  r.samples = pts;
  r.reference.emplace(std::move(times), std::move(pts));
}

TimeParametrizationResult parametrize(const std::vector<Vec3>& waypoints_m,
                                      const std::vector<double>* planned_times_s,
                                      const vehicle::VehicleParams& vp,
                                      const TimeParametrizationOptions& o) {
  const auto clock_start = std::chrono::steady_clock::now();
  TimeParametrizationResult r;
  try {
    check_inputs(waypoints_m, vp, o);
    if (planned_times_s) {
      const auto& ts = *planned_times_s;
      if (ts.size() != waypoints_m.size()) {
        throw InputError("times_s", "has " + std::to_string(ts.size()) + " entries for " +
                                        std::to_string(waypoints_m.size()) + " waypoints");
      }
      for (std::size_t i = 0; i < ts.size(); ++i) {
        if (!std::isfinite(ts[i]) || (i > 0 && !(ts[i] > ts[i - 1]))) {
          throw InputError("times_s[" + std::to_string(i) + "]",
                           "must be finite and strictly increasing");
        }
      }
    }
    Geometry g = build_geometry(waypoints_m, vp, o);
    const double cruise = std::clamp(o.cruise_speed_m_s.value_or(vp.cruise_speed_m_s),
                                     vp.min_speed_m_s(), vp.max_speed_m_s());
    // In timed mode the leg speeds take the place of the cruise speed.
    assign_caps(g, vp, o, planned_times_s ? vp.max_speed_m_s() : cruise);
    const std::size_t np = g.pieces.size();
    std::vector<double> caps(np);
    for (std::size_t k = 0; k < np; ++k) caps[k] = g.pieces[k].cap_m_s;
    const int m = static_cast<int>(g.kept_points.size());

    Profile prof;
    double t_start = o.start_time_s;
    if (!planned_times_s) {
      prof = make_profile(g.pieces, caps, o.initial_speed_m_s.value_or(cruise), o.final_speed_m_s,
                          o.max_accel_m_s2, t_start);
    } else {
      // Timed mode (file comment): leg speeds from the smoothed target time function, which
      // is corrected by the arrival errors of the previous iteration.
      const auto& ts = *planned_times_s;
      t_start = ts.front();
      const double v_lo = vp.min_speed_m_s();
      const double v_hi = vp.max_speed_m_s();
      std::vector<double> planned(m), s_at(m, 0.0), leg_speed(m - 1);
      std::vector<int> leg_of_piece(np);
      for (int l = 0; l < m; ++l) planned[l] = ts[static_cast<std::size_t>(g.input_of_kept[l])];
      for (int l = 0; l + 1 < m; ++l) {
        s_at[l + 1] = s_at[l];
        for (int k = g.boundary_of_kept[l]; k < g.boundary_of_kept[l + 1]; ++k) {
          leg_of_piece[static_cast<std::size_t>(k)] = l;
          s_at[l + 1] += g.pieces[static_cast<std::size_t>(k)].length_m;
        }
      }
      const double total_s = s_at.back();
      std::vector<double> target = planned;
      // T*(s): the target times interpolated linearly in arc length.
      auto target_at = [&](double s) {
        const auto it = std::upper_bound(s_at.begin(), s_at.end(), s);
        const std::size_t i = std::clamp<std::size_t>(static_cast<std::size_t>(it - s_at.begin()),
                                                      1, s_at.size() - 1);
        const double span = s_at[i] - s_at[i - 1];
        const double f = span > 0.0 ? std::clamp((s - s_at[i - 1]) / span, 0.0, 1.0) : 1.0;
        return target[i - 1] + f * (target[i] - target[i - 1]);
      };
      const double half_window = 0.5 * o.timing_window_m;
      double best_dev = std::numeric_limits<double>::infinity();
      std::vector<double> leg_caps(np);
      for (int it = 0; it < o.max_timing_iterations; ++it) {
        for (int l = 0; l + 1 < m; ++l) {
          // Box filter of the slowness dT*/ds over the window: it keeps ∫ slowness = time.
          const double c = 0.5 * (s_at[l] + s_at[l + 1]);
          const double lo = std::max(0.0, std::min(c - half_window, s_at[l]));
          const double hi = std::min(total_s, std::max(c + half_window, s_at[l + 1]));
          leg_speed[l] = std::clamp((hi - lo) / (target_at(hi) - target_at(lo)), v_lo, v_hi);
        }
        for (std::size_t k = 0; k < np; ++k) {
          leg_caps[k] = std::min(caps[k], leg_speed[static_cast<std::size_t>(leg_of_piece[k])]);
        }
        Profile trial = make_profile(g.pieces, leg_caps, o.initial_speed_m_s.value_or(leg_speed[0]),
                                     o.final_speed_m_s, o.max_accel_m_s2, t_start);
        double dev = 0.0;
        for (int l = 0; l < m; ++l) {
          const double err =
              trial.piece_t0_s[static_cast<std::size_t>(g.boundary_of_kept[l])] - planned[l];
          dev = std::max(dev, std::abs(err));
          target[l] -= err;
        }
        r.timing_iterations = it + 1;
        if (dev < best_dev) {
          best_dev = dev;
          prof = trial;
        }
        if (dev < 1e-6) break;
        // Keep T* increasing no faster than the top speed allows.
        target[0] = planned[0];
        for (int l = 1; l < m; ++l) {
          target[l] = std::max(target[l], target[l - 1] + (s_at[l] - s_at[l - 1]) / v_hi);
        }
      }
    }

    if (prof.phases.empty()) throw InputError("waypoints_m", "the path is too short to fly");
    sample_into(g, prof, vp, o, t_start, r);
    r.corners_rounded = g.corners_rounded;
    r.corners_tightened = g.corners_tightened;
    r.reversal_loops = g.reversal_loops;
    r.duplicates_removed = g.duplicates_removed;

    // Waypoint times and offsets from the path points they are matched to.
    const std::size_t n = waypoints_m.size();
    r.waypoint_times_s.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const int b = g.boundary_of_kept[static_cast<std::size_t>(g.kept_of_input[i])];
      r.waypoint_times_s[i] = prof.piece_t0_s[static_cast<std::size_t>(b)];
      const Vec3 on_path = static_cast<std::size_t>(b) < np
                               ? position_at(g.pieces[static_cast<std::size_t>(b)], 0.0)
                               : position_at(g.pieces.back(), g.pieces.back().length_m);
      r.max_waypoint_offset_m =
          std::max(r.max_waypoint_offset_m, (on_path - waypoints_m[i]).norm());
      if (planned_times_s) {
        r.max_time_deviation_s = std::max(r.max_time_deviation_s,
                                          std::abs(r.waypoint_times_s[i] - (*planned_times_s)[i]));
      }
    }

    for (const Violation& v : g.violations) {
      LimitViolation out{v.kind, v.waypoint, v.value, v.limit, 0.0, 0.0, v.description};
      if (v.piece_end < 0) {  // at a waypoint: v.piece_begin is the kept index
        out.t_begin_s = out.t_end_s =
            prof.piece_t0_s[static_cast<std::size_t>(g.boundary_of_kept[v.piece_begin])];
      } else {
        out.t_begin_s = prof.piece_t0_s[static_cast<std::size_t>(v.piece_begin)];
        out.t_end_s = prof.piece_t0_s[static_cast<std::size_t>(v.piece_end)];
      }
      // Adjacent pieces of one corner or segment make one violation.
      if (!r.violations.empty()) {
        LimitViolation& last = r.violations.back();
        if (last.kind == out.kind && last.waypoint == out.waypoint &&
            std::abs(last.t_end_s - out.t_begin_s) < 1e-9) {
          last.t_end_s = out.t_end_s;
          last.value = std::max(last.value, out.value);
          continue;
        }
      }
      r.violations.push_back(out);
    }

    if (!r.violations.empty()) {
      r.status = TimeParametrizationStatus::kLimitViolated;
      r.message = std::to_string(r.violations.size()) + " limit violation(s); first: " +
                  std::string(to_string(r.violations.front().kind)) + ": " +
                  r.violations.front().description;
    } else if (planned_times_s && r.max_time_deviation_s > o.time_tolerance_s) {
      r.status = TimeParametrizationStatus::kTimingMissed;
      r.message = "a waypoint is passed " + std::to_string(r.max_time_deviation_s) +
                  " s from its planned time (tolerance " + std::to_string(o.time_tolerance_s) +
                  " s)";
    } else {
      r.status = TimeParametrizationStatus::kOk;
      r.message = "ok";
    }
  } catch (const InputError& e) {
    r = TimeParametrizationResult{};
    r.status = TimeParametrizationStatus::kInvalidInput;
    r.message = e.what();
  }
  r.compute_time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - clock_start)
          .count();
  return r;
}

}  // namespace

TimeParametrizationResult time_parametrize(const std::vector<Vec3>& waypoints_m,
                                           const vehicle::VehicleParams& vehicle,
                                           const TimeParametrizationOptions& options) {
  return parametrize(waypoints_m, nullptr, vehicle, options);
}

TimeParametrizationResult time_parametrize_timed(const std::vector<Vec3>& waypoints_m,
                                                 const std::vector<double>& times_s,
                                                 const vehicle::VehicleParams& vehicle,
                                                 const TimeParametrizationOptions& options) {
  return parametrize(waypoints_m, &times_s, vehicle, options);
}

}  // namespace ridgeline::planning
