#include "io/scenario_file.hpp"

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/random.hpp"
#include "io/geo_frame.hpp"
#include "io/yaml_fields.hpp"

namespace ridgeline::io {

extern const char* const kDefaultScenarioYaml;  // generated from scenarios/default.yaml

namespace {

namespace fs = std::filesystem;

std::string read_text_file(const fs::path& path, const std::string& field) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(field, fmt::format("cannot read file '{}'", path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(field, fmt::format("error while reading '{}'", path.string()));
  return text.str();
}

// A position given either as `<metric_key>: [x, y, z]` in the local ENU frame or as
// `<geo_key>: {lat_deg, lon_deg, alt_amsl_m}` (WGS 84, needs the scenario's origin).
Vec3 parse_position(YamlMap& m, const std::string& metric_key, const std::string& geo_key,
                    const GeoFrame* frame) {
  const bool metric = m.has(metric_key);
  if (metric == m.has(geo_key)) {
    throw InputError(m.path(), fmt::format("give exactly one of '{}' (local ENU metres) or '{}' "
                                           "({{lat_deg, lon_deg, alt_amsl_m}})",
                                           metric_key, geo_key));
  }
  if (metric) return m.required(metric_key).as_vec3();
  const YamlValue value = m.required(geo_key);
  if (frame == nullptr) {
    throw InputError(value.path(),
                     "a latitude/longitude position needs a geodetic origin: add a "
                     "top-level 'origin: {lat_deg, lon_deg, alt_amsl_m}'");
  }
  YamlMap g = value.as_map();
  GeoPoint p;
  p.lat_deg = g.required("lat_deg").as_double();
  p.lon_deg = g.required("lon_deg").as_double();
  p.alt_amsl_m = g.required("alt_amsl_m").as_double();
  g.finish();
  return frame->to_local(p, value.path());
}

world::PeakCombination parse_combination(const YamlValue& v) {
  const std::string s = v.as_string();
  if (s == "max") return world::PeakCombination::kMax;
  if (s == "sum") return world::PeakCombination::kSum;
  throw InputError(v.path(), fmt::format("must be 'max' or 'sum', got '{}'", s));
}

world::PeakTerrainConfig parse_peak_terrain(YamlMap& m) {
  world::PeakTerrainConfig config;
  if (auto c = m.optional("combination")) config.combination = parse_combination(*c);
  config.base_elevation_m = m.get_double("base_elevation_m", 0.0);
  config.model_error_m = m.get_double("model_error_m", 0.0);
  if (config.model_error_m < 0.0)
    throw InputError(m.path() + ".model_error_m", "must not be negative");
  // An empty list is a flat terrain at the base elevation.
  const std::vector<YamlValue> peaks = m.required("peaks").as_list();
  for (const YamlValue& item : peaks) {
    YamlMap p = item.as_map();
    world::Peak peak;
    peak.x_m = p.required("x_m").as_double();
    peak.y_m = p.required("y_m").as_double();
    peak.height_m = p.required("height_m").as_double();
    peak.sigma_x_m = p.required("sigma_x_m").as_double();
    peak.sigma_y_m = p.required("sigma_y_m").as_double();
    p.finish();
    if (peak.height_m <= 0.0)
      throw InputError(p.path() + ".height_m", fmt::format("must be positive, got {}", peak.height_m));
    if (peak.sigma_x_m <= 0.0)
      throw InputError(p.path() + ".sigma_x_m", fmt::format("must be positive, got {}", peak.sigma_x_m));
    if (peak.sigma_y_m <= 0.0)
      throw InputError(p.path() + ".sigma_y_m", fmt::format("must be positive, got {}", peak.sigma_y_m));
    config.peaks.push_back(peak);
  }
  return config;
}

mission::TerrainSource parse_terrain(YamlMap& m, const fs::path& base_dir, int include_depth);

// `terrain: {include: FILE}`: FILE holds a top-level `terrain:` block (as `ridgeline fit-dem`
// writes it, with an informational `fit_report:` beside it).
mission::TerrainSource parse_terrain_include(const YamlValue& include, const fs::path& base_dir,
                                             int include_depth) {
  if (include_depth > 4) throw InputError(include.path(), "includes nest too deeply (a cycle?)");
  const fs::path path = base_dir / include.as_string();
  const std::string text = read_text_file(path, include.path());
  YamlMap top = YamlValue(parse_yaml(text, path.string()), path.string()).as_map();
  YamlMap terrain = top.required("terrain").as_map();
  // The report is informational but for the frame the fit was made in (fit-dem --origin).
  std::optional<mission::GeodeticOrigin> fit_origin;
  const bool has_report = top.has("fit_report");
  if (auto report = top.optional("fit_report")) {
    if (report->node().IsMap() && report->node()["origin"]) {
      YamlMap o = YamlValue(report->node()["origin"], report->path() + ".origin").as_map();
      mission::GeodeticOrigin g;
      g.lat_deg = o.required("lat_deg").as_double();
      g.lon_deg = o.required("lon_deg").as_double();
      g.alt_amsl_m = o.required("alt_amsl_m").as_double();
      o.finish();
      fit_origin = g;
    }
  }
  top.finish();
  mission::TerrainSource source = parse_terrain(terrain, path.parent_path(), include_depth + 1);
  if (source.included_from.empty()) {
    source.included_from = path.string();
    source.included_fit_report = has_report;
    source.included_fit_origin = fit_origin;
  }
  return source;
}

mission::TerrainSource parse_terrain(YamlMap& m, const fs::path& base_dir, int include_depth) {
  const int sources = int(m.has("peaks")) + int(m.has("dem")) + int(m.has("include"));
  if (sources != 1) {
    throw InputError(m.path(), "give exactly one of 'peaks' (inline peaks), 'dem' (a raster "
                               "file) or 'include' (a terrain file written by fit-dem)");
  }
  if (auto include = m.optional("include")) {
    mission::TerrainSource source = parse_terrain_include(*include, base_dir, include_depth);
    m.finish();
    return source;
  }
  mission::TerrainSource source;
  if (auto dem_value = m.optional("dem")) {
    YamlMap dem = dem_value->as_map();
    source.kind = mission::TerrainSource::Kind::kDem;
    source.dem_path = (base_dir / dem.required("path").as_string()).string();
    const std::string model = dem.get_string("model", "raster");
    if (model == "raster") {
      source.dem_model = mission::TerrainSource::DemModel::kRaster;
    } else if (model == "fitted") {
      source.dem_model = mission::TerrainSource::DemModel::kFitted;
    } else {
      throw InputError(dem.path() + ".model", fmt::format("must be 'raster' or 'fitted', got '{}'", model));
    }
    source.dem_fit_peaks = static_cast<int>(dem.get_int("fit_peaks", 8));
    if (source.dem_fit_peaks < 1 || source.dem_fit_peaks > 200)
      throw InputError(dem.path() + ".fit_peaks", fmt::format("must be in [1, 200], got {}", source.dem_fit_peaks));
    if (auto c = dem.optional("combination")) source.dem_fit_combination = parse_combination(*c);
    source.dem_vertical_datum = dem.get_string("vertical_datum", "");
    dem.finish();
    m.finish();
    return source;
  }
  source.kind = mission::TerrainSource::Kind::kPeaks;
  source.peaks = parse_peak_terrain(m);
  m.finish();
  return source;
}

void parse_vehicle(YamlMap& m, vehicle::VehicleParams& v) {
  v.cruise_speed_m_s = m.get_double("cruise_speed_m_s", v.cruise_speed_m_s);
  v.speed_band_m_s = m.get_double("speed_band_m_s", v.speed_band_m_s);
  v.min_turn_radius_m = m.get_double("min_turn_radius_m", v.min_turn_radius_m);
  v.max_climb_rate_m_s = m.get_double("max_climb_rate_m_s", v.max_climb_rate_m_s);
  v.max_pitch_rad = deg_to_rad(m.get_double("max_pitch_deg", rad_to_deg(v.max_pitch_rad)));
  v.tau_v_s = m.get_double("tau_v_s", v.tau_v_s);
  v.tau_omega_s = m.get_double("tau_omega_s", v.tau_omega_s);
  v.tau_w_s = m.get_double("tau_w_s", v.tau_w_s);
  m.finish();
}

mission::UavSpec parse_uav(const YamlValue& item, const vehicle::VehicleParams& defaults,
                           const GeoFrame* frame) {
  YamlMap m = item.as_map();
  mission::UavSpec uav;
  uav.name = m.required("name").as_string();
  uav.vehicle = defaults;
  if (auto v = m.optional("vehicle")) {
    YamlMap vm = v->as_map();
    parse_vehicle(vm, uav.vehicle);
  }
  YamlMap start = m.required("start").as_map();
  uav.start_position_m = parse_position(start, "position_m", "position_geo", frame);
  uav.start_heading_rad = deg_to_rad(start.get_double("heading_deg", 0.0));
  uav.start_speed_m_s = start.get_double("speed_m_s", uav.vehicle.cruise_speed_m_s);
  start.finish();
  uav.sensor_range_m = m.get_double("sensor_range_m", uav.sensor_range_m);
  if (auto targets = m.optional("targets"))
    for (const YamlValue& name : targets->as_list())
      uav.assigned_targets.push_back(name.as_string());
  if (auto end = m.optional("end")) {
    YamlMap e = end->as_map();
    uav.end_position_m = parse_position(e, "position_m", "position_geo", frame);
    e.finish();
  }
  m.finish();
  return uav;
}

mission::InspectionTarget parse_target(const YamlValue& item, const GeoFrame* frame) {
  YamlMap m = item.as_map();
  mission::InspectionTarget t;
  t.name = m.required("name").as_string();
  t.position_m = parse_position(m, "position_m", "position_geo", frame);
  t.priority = static_cast<int>(m.get_int("priority", t.priority));
  t.inspection_radius_m = m.get_double("inspection_radius_m", t.inspection_radius_m);
  m.finish();
  return t;
}

world::Threat parse_threat(const YamlValue& item, std::size_t index, const GeoFrame* frame) {
  YamlMap m = item.as_map();
  world::Threat t;
  t.name = m.get_string("name", fmt::format("threat{}", index + 1));
  t.centre_m = parse_position(m, "centre_m", "centre_geo", frame);
  t.velocity_m_s = m.required("velocity_m_s").as_vec3();
  t.radius_m = m.required("radius_m").as_double();
  t.appear_s = m.required("appear_s").as_double();
  t.vanish_s = m.required("vanish_s").as_double();
  m.finish();
  return t;
}

void parse_wind(YamlMap& m, world::WindConfig& w, std::uint64_t scenario_seed) {
  w.mean_m_s = m.get_vec3("mean_m_s", w.mean_m_s);
  w.gust_std_m_s = m.get_double("gust_std_m_s", w.gust_std_m_s);
  w.vertical_gust_ratio = m.get_double("vertical_gust_ratio", w.vertical_gust_ratio);
  w.correlation_length_m = m.get_double("correlation_length_m", w.correlation_length_m);
  w.correlation_time_s = m.get_double("correlation_time_s", w.correlation_time_s);
  w.measurement_noise_m_s = m.get_double("measurement_noise_m_s", w.measurement_noise_m_s);
  w.gust_modes = static_cast<int>(m.get_int("gust_modes", w.gust_modes));
  const long long seed = m.get_int("seed", -1);
  if (seed < -1) throw InputError(m.path() + ".seed", "must not be negative");
  // Without its own seed the wind derives one from the scenario's, so one seed fixes a run.
  w.seed = seed >= 0 ? static_cast<std::uint64_t>(seed) : derive_seed(scenario_seed, 1);
  m.finish();
}

void parse_mpc(YamlMap& m, mission::MpcConfig& c) {
  c.control_period_s = m.get_double("control_period_s", c.control_period_s);
  c.prediction_step_s = m.get_double("prediction_step_s", c.prediction_step_s);
  c.horizon_steps = static_cast<int>(m.get_int("horizon_steps", c.horizon_steps));
  c.control_horizon_steps = static_cast<int>(m.get_int("control_horizon_steps", c.control_horizon_steps));
  c.position_weight = m.get_double("position_weight", c.position_weight);
  c.move_weights = m.get_vec3("move_weights", c.move_weights);
  c.max_moves = m.get_vec3("max_moves", c.max_moves);
  c.slack_weight = m.get_double("slack_weight", c.slack_weight);
  m.finish();
}

void parse_planner(YamlMap& m, mission::PlannerConfig& p) {
  p.waypoints_per_uav = static_cast<int>(m.get_int("waypoints_per_uav", p.waypoints_per_uav));
  p.max_turn_angle_rad = deg_to_rad(m.get_double("max_turn_angle_deg", rad_to_deg(p.max_turn_angle_rad)));
  p.pitch_penalty = m.get_double("pitch_penalty", p.pitch_penalty);
  p.turn_penalty = m.get_double("turn_penalty", p.turn_penalty);
  if (auto w = m.optional("weights")) {
    YamlMap wm = w->as_map();
    p.weight_range = wm.get_double("range", p.weight_range);
    p.weight_pitch = wm.get_double("pitch", p.weight_pitch);
    p.weight_turn = wm.get_double("turn", p.weight_turn);
    p.weight_altitude = wm.get_double("altitude", p.weight_altitude);
    wm.finish();
  }
  if (auto c = m.optional("cluster")) {
    YamlMap cm = c->as_map();
    p.lambda_individual = cm.get_double("individual", p.lambda_individual);
    p.lambda_collision = cm.get_double("collision", p.lambda_collision);
    cm.finish();
  }
  if (auto a = m.optional("allocation")) {
    YamlMap am = a->as_map();
    p.allocation_makespan_weight = am.get_double("makespan_weight", p.allocation_makespan_weight);
    p.allocation_priority_weight = am.get_double("priority_weight", p.allocation_priority_weight);
    am.finish();
  }
  if (auto v = m.optional("optimizer_replan")) p.optimizer_replan = v->as_bool();
  m.finish();
}

void parse_simulation(YamlMap& m, mission::SimulationConfig& s) {
  s.duration_s = m.get_double("duration_s", s.duration_s);
  s.truth_rate_hz = m.get_double("truth_rate_hz", s.truth_rate_hz);
  s.message_rate_hz = m.get_double("message_rate_hz", s.message_rate_hz);
  s.truth_time_constant_scale = m.get_double("truth_time_constant_scale", s.truth_time_constant_scale);
  s.position_noise_m = m.get_double("position_noise_m", s.position_noise_m);
  if (auto link = m.optional("link")) {
    YamlMap lm = link->as_map();
    s.link_latency_s = lm.get_double("latency_s", s.link_latency_s);
    s.link_jitter_s = lm.get_double("jitter_s", s.link_jitter_s);
    s.link_drop_rate = lm.get_double("drop_rate", s.link_drop_rate);
    lm.finish();
  }
  m.finish();
}

}  // namespace

InvalidScenario::InvalidScenario(std::vector<InputError> problems)
    : InputError(problems.empty() ? std::string() : problems.front().field(),
                 problems.empty()
                     ? std::string("invalid scenario")
                     : problems.front().reason() +
                           (problems.size() > 1
                                ? fmt::format(" (and {} more problem{})", problems.size() - 1,
                                              problems.size() > 2 ? "s" : "")
                                : std::string())),
      problems_(std::move(problems)) {}

std::string_view default_scenario_yaml() { return kDefaultScenarioYaml; }

mission::Scenario parse_scenario(const std::string& yaml_text, const std::string& source,
                                 const fs::path& base_dir) {
  const YAML::Node root = parse_yaml(yaml_text, source);
  if (!root.IsMap()) {
    throw InputError(source, "a scenario must be a YAML mapping with keys such as area, "
                             "terrain, uavs, targets");
  }
  YamlMap top(root, "");
  mission::Scenario s;
  s.name = top.get_string("name", "unnamed");
  const long long seed = top.get_int("seed", 1);
  if (seed < 0) throw InputError("seed", "must not be negative");
  s.seed = static_cast<std::uint64_t>(seed);

  // The origin comes first: lat/lon positions and a home-relative altitude band need it.
  std::optional<GeoFrame> frame;
  if (auto origin = top.optional("origin")) {
    YamlMap m = origin->as_map();
    mission::GeodeticOrigin o;
    o.lat_deg = m.required("lat_deg").as_double();
    o.lon_deg = m.required("lon_deg").as_double();
    o.alt_amsl_m = m.required("alt_amsl_m").as_double();
    m.finish();
    frame.emplace(o);
    s.origin = o;
  }
  const GeoFrame* geo = frame ? &*frame : nullptr;

  YamlMap area = top.required("area").as_map();
  s.area.x_min_m = area.required("x_min_m").as_double();
  s.area.x_max_m = area.required("x_max_m").as_double();
  s.area.y_min_m = area.required("y_min_m").as_double();
  s.area.y_max_m = area.required("y_max_m").as_double();
  area.finish();

  if (auto alt = top.optional("altitude")) {
    YamlMap m = alt->as_map();
    s.safety.altitude.min_m = m.get_double("min_m", s.safety.altitude.min_m);
    s.safety.altitude.max_m = m.get_double("max_m", s.safety.altitude.max_m);
    const std::string reference = m.get_string("reference", "datum");
    if (reference == "home") {
      if (!s.origin) {
        throw InputError("altitude.reference",
                         "'home' means above the origin's altitude, but "
                         "the scenario has no 'origin'");
      }
      s.safety.altitude.min_m += s.origin->alt_amsl_m;
      s.safety.altitude.max_m += s.origin->alt_amsl_m;
      s.altitude_stated_reference = mission::AltitudeReference::kHome;
    } else if (reference != "datum") {
      throw InputError("altitude.reference",
                       fmt::format("must be 'datum' (the frame's z: above mean sea level with "
                                   "an origin) or 'home' (above the origin's altitude), got '{}'",
                                   reference));
    }
    m.finish();
  }
  if (s.origin) s.safety.altitude.datum = world::AltitudeDatum::kMeanSeaLevel;
  if (auto safety = top.optional("safety")) {
    YamlMap m = safety->as_map();
    s.safety.terrain_clearance_m = m.get_double("terrain_clearance_m", s.safety.terrain_clearance_m);
    s.safety.separation_m = m.get_double("separation_m", s.safety.separation_m);
    s.safety.threat_margin_m = m.get_double("threat_margin_m", s.safety.threat_margin_m);
    m.finish();
  }

  YamlMap terrain = top.required("terrain").as_map();
  s.terrain = parse_terrain(terrain, base_dir, 0);
  if (s.terrain.included_fit_report) {
    // A fitted terrain file is in the frame it was fitted in; flying it in another would put
    // every peak in the wrong place.
    const auto& fitted = s.terrain.included_fit_origin;
    const std::string file = s.terrain.included_from;
    if (s.origin && !fitted) {
      throw InputError(
          "terrain.include",
          fmt::format("'{}' was fitted in its DEM's own south-west-corner frame "
                      "(fit-dem without --origin), not in this scenario's "
                      "geographic frame; fit it again with --origin {},{},{}",
                      file, s.origin->lat_deg, s.origin->lon_deg, s.origin->alt_amsl_m));
    }
    if (fitted && !s.origin) {
      throw InputError("terrain.include",
                       fmt::format("'{}' was fitted around the geodetic origin ({}, {}, {} m); "
                                   "the scenario must name the same 'origin'",
                                   file, fitted->lat_deg, fitted->lon_deg, fitted->alt_amsl_m));
    }
    // 1e-7 degrees is about a centimetre: the file keeps 10 significant digits.
    if (fitted && s.origin &&
        (std::abs(fitted->lat_deg - s.origin->lat_deg) > 1e-7 ||
         std::abs(fitted->lon_deg - s.origin->lon_deg) > 1e-7)) {
      throw InputError("terrain.include",
                       fmt::format("'{}' was fitted around the origin ({}, {}), not the "
                                   "scenario's ({}, {})",
                                   file, fitted->lat_deg, fitted->lon_deg, s.origin->lat_deg,
                                   s.origin->lon_deg));
    }
  }

  vehicle::VehicleParams vehicle_defaults;
  if (auto v = top.optional("vehicle")) {
    YamlMap m = v->as_map();
    parse_vehicle(m, vehicle_defaults);
  }
  for (const YamlValue& item : top.required("uavs").as_list())
    s.uavs.push_back(parse_uav(item, vehicle_defaults, geo));
  for (const YamlValue& item : top.required("targets").as_list())
    s.targets.push_back(parse_target(item, geo));
  if (auto threats = top.optional("threats")) {
    const auto items = threats->as_list();
    for (std::size_t i = 0; i < items.size(); ++i)
      s.threats.push_back(parse_threat(items[i], i, geo));
  }
  s.wind.seed = derive_seed(s.seed, 1);
  if (auto w = top.optional("wind")) {
    YamlMap m = w->as_map();
    parse_wind(m, s.wind, s.seed);
  }
  if (auto m = top.optional("mpc")) {
    YamlMap mm = m->as_map();
    parse_mpc(mm, s.mpc);
  }
  if (auto p = top.optional("planner")) {
    YamlMap pm = p->as_map();
    parse_planner(pm, s.planner);
  }
  if (auto sim_block = top.optional("simulation")) {
    YamlMap sm = sim_block->as_map();
    parse_simulation(sm, s.simulation);
  }
  top.finish();
  return s;
}

LoadedScenario load_scenario(const std::string& yaml_text, const std::string& source,
                             const fs::path& base_dir) {
  LoadedScenario loaded;
  loaded.source = source;
  loaded.scenario = parse_scenario(yaml_text, source, base_dir);
  loaded.terrain = build_terrain(loaded.scenario.terrain, loaded.scenario.origin,
                                 loaded.scenario.area, &loaded.terrain_report);
  std::vector<InputError> problems = mission::validate(loaded.scenario, *loaded.terrain);
  if (!problems.empty()) throw InvalidScenario(std::move(problems));
  return loaded;
}

LoadedScenario load_scenario_file(const fs::path& path) {
  const std::string text = read_text_file(path, path.string());
  return load_scenario(text, path.string(), path.parent_path());
}

LoadedScenario load_default_scenario() {
  return load_scenario(std::string(default_scenario_yaml()), "<default>", fs::current_path());
}

}  // namespace ridgeline::io
