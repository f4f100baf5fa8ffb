// A mission scenario: the area and terrain, the team of UAVs, the inspection targets, the
// sudden threats, the wind, and the parameters of every layer (DESIGN §7).
//
// These are plain values; the YAML file format that fills them lives in io/scenario_file.hpp
// and its field paths (`uavs[1].vehicle.tau_v_s`) are the ones error messages name.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/types.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/safety_limits.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"
#include "world/wind.hpp"

namespace ridgeline::mission {

/// Rectangular operating area in the local ENU frame.
struct Area {
  double x_min_m = 0.0;
  double x_max_m = 2000.0;
  double y_min_m = 0.0;
  double y_max_m = 2000.0;

  bool contains(double x_m, double y_m) const {
    return x_m >= x_min_m && x_m <= x_max_m && y_m >= y_min_m && y_m <= y_max_m;
  }
};

/// How a scenario file stated its altitude band: in the frame's z (`altitude.reference: datum`,
/// the default) or above the home altitude (the origin's, `reference: home`); the loader adds
/// the home altitude, so the band in SafetyLimits is always in the frame's z.
enum class AltitudeReference { kDatum, kHome };

/// A geodetic origin (WGS 84): the local ENU frame's (0, 0) and the home altitude. See
/// io/geo_frame.hpp for the frame (transverse Mercator on the origin, z above mean sea level).
struct GeodeticOrigin {
  double lat_deg = 0.0;
  double lon_deg = 0.0;
  double alt_amsl_m = 0.0;
};

/// Where the terrain comes from: inline peaks (eq. 12) or a DEM raster.
struct TerrainSource {
  enum class Kind { kPeaks, kDem };
  /// How a DEM is used: queried directly (bilinear) or through a peak field fitted to it.
  enum class DemModel { kRaster, kFitted };

  Kind kind = Kind::kPeaks;
  world::PeakTerrainConfig peaks;  ///< kPeaks
  std::string included_from;       ///< kPeaks read from a terrain file (`include:`), else empty
  /// A fit-dem file records the frame it was fitted in: whether it had a fit report, and the
  /// geodetic origin it was fitted around (none: the DEM's own south-west-corner frame).
  bool included_fit_report = false;
  std::optional<GeodeticOrigin> included_fit_origin;
  std::string dem_path;  ///< kDem, resolved against the scenario file's folder
  DemModel dem_model = DemModel::kRaster;
  int dem_fit_peaks = 8;
  world::PeakCombination dem_fit_combination = world::PeakCombination::kMax;
  /// The vertical datum the scenario says the DEM's heights are in (`dem.vertical_datum`,
  /// e.g. "EGM96" for SRTM), or empty. A DEM that names its own must agree.
  std::string dem_vertical_datum;
};

struct UavSpec {
  std::string name;
  vehicle::VehicleParams vehicle;
  Vec3 start_position_m = Vec3::Zero();
  double start_heading_rad = 0.0;
  double start_speed_m_s = 10.0;
  double sensor_range_m = 300.0;  ///< threats whose surface is this close are sensed
  /// Targets (by name) only this UAV visits: allocation keeps them on its route and adds the
  /// others where they fit best (YAML `uavs[i].targets: [names]`). A name given to two UAVs
  /// is an error.
  std::vector<std::string> assigned_targets = {};
  /// Where the UAV flies after its last target (return home, a landing point), held there
  /// (YAML `uavs[i].end: {position_m | position_geo}`); none: it holds after its last target.
  std::optional<Vec3> end_position_m = std::nullopt;
};

struct InspectionTarget {
  std::string name;
  Vec3 position_m = Vec3::Zero();
  int priority = 1;                   ///< higher is visited first when allocation must choose
  double inspection_radius_m = 30.0;  ///< a pass this close (3-D) counts as an inspection
};

/// A UAV's end position (return home, a landing point) counts as reached this close: a
/// target's default inspection radius. The agent flies on until it is; the recorder judges it.
inline double end_reached_radius_m() { return InspectionTarget{}.inspection_radius_m; }

/// Parameters of the incremental MPC tracker (DESIGN §3).
struct MpcConfig {
  double control_period_s = 0.02;  ///< 50 Hz
  double prediction_step_s = 0.1;  ///< Δt of the prediction model, may exceed the period
  int horizon_steps = 40;          ///< Np
  int control_horizon_steps = 10;  ///< Nc ≤ Np
  double position_weight = 1.0;    ///< Q on each position output, per m²
  Vec3 move_weights = Vec3(2.0, 200.0, 2.0);  ///< R on Δv_c, Δω_c, Δw_c per prediction step
  Vec3 max_moves = Vec3(0.4, 0.15, 0.4);      ///< |Δu| per prediction step (rate × Δt_p)
  double slack_weight = 1e4;                  ///< ρ₁: linear penalty per metre of soft-row slack
};

/// Parameters of the global cooperative planner (DESIGN §5, eq. 14–24).
struct PlannerConfig {
  int waypoints_per_uav = 100;
  double max_turn_angle_rad = deg_to_rad(60.0);  ///< φ_max, eq. 17
  double pitch_penalty = 100.0;                  ///< K_θ, eq. 16
  double turn_penalty = 100.0;                   ///< K_φ, eq. 18
  double weight_range = 1.0;                     ///< w1, eq. 23
  double weight_pitch = 1.0;                     ///< w2
  double weight_turn = 1.0;                      ///< w3
  double weight_altitude = 0.1;                  ///< w4
  double lambda_individual = 1.0;                ///< λ1, eq. 24
  double lambda_collision = 10.0;                ///< λ2
  /// Target allocation J = λ·max_i C_i + Σ_i C_i + β·Σ_j π_j A_j (target_allocation.hpp):
  /// a larger λ spreads the targets over more UAVs (shorter mission, more total range).
  double allocation_makespan_weight = 1.0;  ///< λ ≥ 0
  double allocation_priority_weight = 0.1;  ///< β ≥ 0
  /// On board: a UAV re-plans a threat or neighbour conflict with the local optimizer
  /// (planning/local_replan.hpp, densely validated; the geometric detour stays the fallback)
  /// instead of only the geometric detour (swarm::AgentOptions::optimizer_replan). YAML
  /// `planner.optimizer_replan: true | false`.
  bool optimizer_replan = false;
};

struct SimulationConfig {
  double duration_s = 600.0;
  double truth_rate_hz = 200.0;
  double message_rate_hz = 100.0;
  double truth_time_constant_scale = 1.2;  ///< truth τ = scale × controller τ (model mismatch)
  double position_noise_m = 0.1;           ///< std of each component of a position fix
  /// The inter-UAV link (latency, jitter and so reordering, loss) of the in-process transport.
  double link_latency_s = 0.005;
  double link_jitter_s = 0.005;
  double link_drop_rate = 0.0;
};

struct Scenario {
  std::string name = "unnamed";
  std::uint64_t seed = 1;
  Area area;
  std::optional<GeodeticOrigin> origin;  ///< when set, z is metres above mean sea level
  /// h_safe, d_safe, r_safe and the altitude band (YAML `safety:` and `altitude:`); their
  /// defaults are SafetyLimits' own. The band's datum is mean sea level with an origin.
  world::SafetyLimits safety;
  AltitudeReference altitude_stated_reference = AltitudeReference::kDatum;
  TerrainSource terrain;
  std::vector<UavSpec> uavs;
  std::vector<InspectionTarget> targets;
  std::vector<world::Threat> threats;
  world::WindConfig wind;
  MpcConfig mpc;
  PlannerConfig planner;
  SimulationConfig simulation;
};

/// Checks a scenario's values and their consistency with the terrain: ranges, min below
/// max, finite numbers, unique names, starts and targets inside the area, within the altitude
/// band and above the terrain clearance, starts separated by d_safe, assigned targets named in
/// `targets` and given to one UAV only, ends placed as targets are. Returns every problem
/// found, each naming its field path; an empty list means the scenario is valid.
std::vector<InputError> validate(const Scenario& scenario, const world::Terrain& terrain);

}  // namespace ridgeline::mission
