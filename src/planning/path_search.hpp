// Initial paths: a collision-free 3-D polyline per UAV over the terrain, from its start through
// its assigned targets in order (DESIGN §5: the initial guess of the global optimizer).
//
// Clearance grid. The search area is cut into square cells of side Δ (cell_size_m). A cell's
// required altitude is
//   z_req(c) = max( H_min,  max_{(x,y) ∈ F(c)} H(x, y) + h_safe + e )          (eq. 14, 19–20)
// where F(c) is the cell's footprint grown by turn_margin_m on every side (room for the UAV's
// turns, ≈ R_min), sampled on a lattice of ≤ footprint_sample_m, and e = terrain.model_error_m().
// A cell with z_req > H_max is blocked.
//
// Search. Lazy Theta* (any-angle A*) over the cells, 8-connected, line of sight traced exactly
// through the cells a segment crosses (a segment through a cell corner also needs both side
// cells free). The start and goal cells are always passable (their exact clearance is checked
// on the final profile). Edge cost along a segment crossing cells with altitudes z_1 … z_m:
//   c = √(L² + V²) + k_climb · Σ max(0, z_{k+1} − z_k),   V = Σ |z_{k+1} − z_k|,
// L the horizontal length; plus k_turn (turn_penalty_m, m/rad) × heading change at each vertex.
// Heuristic: √(d² + Δz²) + k_climb·max(0, Δz) to the goal (admissible by Minkowski's inequality).
//
// Altitude profile. Along the horizontal polyline (arc length s), sampled every ≤ profile_step_m,
// the profile must stay above the hard floor h(s) = H + h_safe + e + pad (pad = profile_pad_m,
// shrunk to tan θ_max × the distance to the nearest pin so a pin at exactly the required
// clearance stays reachable; it covers terrain curvature between samples) and should
// stay above the grid's z_req (the conservative altitude), but it is pinned to the start's and
// each target's altitude z_p and limited in pitch, |dz/ds| ≤ tan θ_max. The wanted floor is
//   q(s) = max( h(s), min(z_req(s), cone(s), H_max) ),
//   cone(s) = min_p (z_p + tan θ_max · |s − s_p|),
// and between two consecutive pins the profile is the least concave majorant of q (a taut
// string over the floor): the shortest profile above q, and its slopes lie between the first and
// last, which the cone bounds by ±tan θ_max. Waypoints are the string's vertices and the
// polyline's corners, so the returned polyline is exactly the profile.
// When the pitch limit cannot be met — two pins further apart in height than tan θ_max × their
// horizontal distance, or the hard floor h(s) above the cone — loiter loops (regular 16-gons of
// radius max(2·turn_margin, Δ) through the pin, on the side with lower terrain) are inserted at
// the pin whose cone is too low (for a pure height change, the lower pin, so every loop altitude
// is above it) until the cone clears the floor. A leg fails (kUnreachable, naming the target)
// when h(s) > H_max somewhere on it, or the loops do not settle within 3 rounds.
//
// Verification. Every returned path is sampled every ≤ check_step_m (≤ 5 m): clearance z − H ≥
// h_safe + e, H_min ≤ z ≤ H_max and every segment's pitch ≤ θ_max, else it is not returned.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/types.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"

namespace ridgeline::planning {

/// Options of the clearance grid and the search, with documented defaults (DESIGN §7 values).
struct PathSearchOptions {
  double cell_size_m = 20.0;                ///< Δ, side of a grid cell (> 0)
  double turn_margin_m = 10.0;              ///< footprint growth on every side, ≈ R_min (≥ 0)
  double max_pitch_rad = deg_to_rad(30.0);  ///< θ_max, in (0, π/2)
  double climb_penalty = 1.0;               ///< k_climb, extra cost per metre climbed (≥ 0)
  double turn_penalty_m = 5.0;              ///< k_turn, cost per radian of heading change (≥ 0)
  double footprint_sample_m = 5.0;  ///< terrain lattice spacing for the footprint max, (0, 5]
  double profile_step_m = 2.0;      ///< profile sampling step, (0, 5]
  double profile_pad_m = 0.5;       ///< extra height over the hard floor (covers the terrain's
                                    ///< curvature between profile samples), ≥ 0
  double check_step_m = 1.0;        ///< verification sampling step, (0, 5]
};

/// Rectangular search area in the ENU plane.
struct SearchArea {
  Vec2 min_m = Vec2(0.0, 0.0);
  Vec2 max_m = Vec2(2000.0, 2000.0);
};

/// A start or target: a name used in error messages and a position.
struct NamedPoint {
  std::string name;
  Vec3 position_m = Vec3::Zero();
};

/// The clearance grid of the file comment, built once per terrain and shared by every UAV's
/// search. Keeps a reference to `terrain`, which must outlive it.
class ClearanceGrid {
 public:
  /// Throws InputError (field `path_search.<name>`, `area` or the limit's) on a bad option,
  /// area or limit.
  ClearanceGrid(const world::Terrain& terrain, const SearchArea& area,
                const world::SafetyLimits& limits, const PathSearchOptions& options = {});

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  /// z_req of the cell at (row, col) (row 0 south, col 0 west), metres.
  double required_altitude_m(int row, int col) const { return required_m_[index(row, col)]; }
  bool blocked(int row, int col) const {
    return required_m_[index(row, col)] > limits_.altitude.max_m;
  }
  /// Cell index containing (x, y), clamped to the grid.
  int cell_of(double x_m, double y_m) const;
  Vec2 cell_centre(int cell) const;
  bool contains(double x_m, double y_m) const;

  const world::Terrain& terrain() const { return terrain_; }
  const SearchArea& area() const { return area_; }
  const world::SafetyLimits& limits() const { return limits_; }
  const PathSearchOptions& options() const { return options_; }
  double build_time_ms() const { return build_time_ms_; }

  int index(int row, int col) const { return row * cols_ + col; }
  double required_altitude_m(int cell) const { return required_m_[cell]; }
  bool blocked(int cell) const { return required_m_[cell] > limits_.altitude.max_m; }

 private:
  const world::Terrain& terrain_;
  SearchArea area_;
  world::SafetyLimits limits_;
  PathSearchOptions options_;
  int rows_ = 0;
  int cols_ = 0;
  std::vector<double> required_m_;
  double build_time_ms_ = 0.0;
};

enum class PathStatus {
  kFound,         ///< a verified path
  kUnreachable,   ///< a target (or the start) cannot be reached; message and failed_point name it
  kInvalidInput,  ///< a start/target outside the area or band, or inside the terrain's clearance
  kVerificationFailed,  ///< the dense check found a violation the profile should have prevented
};
std::string_view to_string(PathStatus status);

struct PathResult {
  PathStatus status = PathStatus::kInvalidInput;
  std::string message;                     ///< why, naming the start/target, when not kFound
  std::string failed_point;                ///< name of the unreachable/invalid start or target
  std::vector<Vec3> waypoints_m;           ///< start, …, target_1, …, target_n
  std::vector<int> target_waypoint_index;  ///< index in waypoints_m of each target
  double length_m = 0.0;                   ///< 3-D length of the polyline
  double min_clearance_m = 0.0;            ///< min z − H(x, y), sampled every ≤ check_step_m
  double max_pitch_rad = 0.0;              ///< max |atan(Δz / Δs_horizontal)| over the segments
  int nodes_expanded = 0;                  ///< over all legs
  double search_time_ms = 0.0;  ///< search + profile + verification (grid build excluded)
};

/// Plans start → targets[0] → targets[1] → … over `grid` (see the file comment). Never throws on
/// bad points: returns kInvalidInput / kUnreachable with a message naming the point.
PathResult plan_initial_path(const ClearanceGrid& grid, const NamedPoint& start,
                             const std::vector<NamedPoint>& targets);

/// Dense check of any polyline: min clearance z − H (sampled every ≤ step_m along each segment)
/// and max pitch |atan(Δz/Δs)|.
struct PathCheck {
  double min_clearance_m = 0.0;
  double max_pitch_rad = 0.0;
  double min_altitude_m = 0.0;
  double max_altitude_m = 0.0;
};
PathCheck check_path(const world::Terrain& terrain, const std::vector<Vec3>& waypoints_m,
                     double step_m);

}  // namespace ridgeline::planning
