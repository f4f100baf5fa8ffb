#include "mission/scenario.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace ridgeline::mission {
namespace {

// Collects problems with their field paths.
class Checker {
 public:
  std::vector<InputError> problems;

  void fail(const std::string& field, const std::string& reason) {
    problems.emplace_back(field, reason);
  }
  // Runs a validator of a lower layer that throws on its first problem.
  template <typename Check>
  void collect(Check&& check) {
    try {
      check();
    } catch (const InputError& e) {
      problems.push_back(e);
    }
  }
  bool finite(const std::string& field, double value) {
    if (std::isfinite(value)) return true;
    fail(field, fmt::format("must be a finite number, got {}", value));
    return false;
  }
  bool finite(const std::string& field, const Vec3& v) {
    if (v.allFinite()) return true;
    fail(field, fmt::format("must be finite, got [{}, {}, {}]", v.x(), v.y(), v.z()));
    return false;
  }
  void positive(const std::string& field, double value) {
    if (finite(field, value) && value <= 0.0)
      fail(field, fmt::format("must be positive, got {}", value));
  }
  void non_negative(const std::string& field, double value) {
    if (finite(field, value) && value < 0.0)
      fail(field, fmt::format("must not be negative, got {}", value));
  }
  void ordered(const std::string& min_field, double min, const std::string& max_field, double max) {
    if (finite(min_field, min) && finite(max_field, max) && min >= max)
      fail(min_field, fmt::format("{} must be below {} ({})", min, max_field, max));
  }
};

void check_vehicle(Checker& c, const std::string& path, const vehicle::VehicleParams& v) {
  c.positive(path + ".cruise_speed_m_s", v.cruise_speed_m_s);
  c.non_negative(path + ".speed_band_m_s", v.speed_band_m_s);
  if (std::isfinite(v.cruise_speed_m_s) && std::isfinite(v.speed_band_m_s) &&
      v.min_speed_m_s() <= 0.0) {
    c.fail(path + ".speed_band_m_s",
           fmt::format("cruise speed minus the band must stay positive (fixed-heading-rate "
                       "model needs forward speed), got {} - {} m/s",
                       v.cruise_speed_m_s, v.speed_band_m_s));
  }
  c.positive(path + ".min_turn_radius_m", v.min_turn_radius_m);
  c.positive(path + ".max_climb_rate_m_s", v.max_climb_rate_m_s);
  if (c.finite(path + ".max_pitch_deg", v.max_pitch_rad) &&
      (v.max_pitch_rad <= 0.0 || v.max_pitch_rad >= kPi / 2)) {
    c.fail(path + ".max_pitch_deg",
           fmt::format("must be in (0, 90) degrees, got {}", rad_to_deg(v.max_pitch_rad)));
  }
  c.positive(path + ".tau_v_s", v.tau_v_s);
  c.positive(path + ".tau_omega_s", v.tau_omega_s);
  c.positive(path + ".tau_w_s", v.tau_w_s);
}

// A point must lie in the area, in the altitude band and above the terrain clearance.
void check_placement(Checker& c, const std::string& field, const Vec3& p, const Scenario& s,
                     const world::Terrain& terrain) {
  if (!c.finite(field, p)) return;
  if (!s.area.contains(p.x(), p.y())) {
    c.fail(field,
           fmt::format("({:.1f}, {:.1f}) is outside the area x [{}, {}], y [{}, {}]", p.x(), p.y(),
                       s.area.x_min_m, s.area.x_max_m, s.area.y_min_m, s.area.y_max_m));
    return;
  }
  if (p.z() < s.safety.altitude.min_m || p.z() > s.safety.altitude.max_m) {
    c.fail(field, fmt::format("altitude {:.1f} m is outside the altitude band [{}, {}] m", p.z(),
                              s.safety.altitude.min_m, s.safety.altitude.max_m));
  }
  const double ground = terrain.height(p.x(), p.y());
  const double floor = ground + s.safety.clearance_floor_m(terrain);
  if (p.z() < floor) {
    const std::string model_error =
        terrain.model_error_m() > 0.0
            ? fmt::format(" + terrain model error {:.1f} m", terrain.model_error_m())
            : "";
    c.fail(field, fmt::format("{:.1f} m below the terrain clearance (terrain {:.1f} m + "
                              "h_safe {} m{}){}",
                              floor - p.z(), ground, s.safety.terrain_clearance_m, model_error,
                              p.z() < ground ? ": it is inside the terrain" : ""));
  }
}

template <typename Item>
void check_unique_names(Checker& c, const std::string& list, const std::vector<Item>& items) {
  std::set<std::string> seen;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string field = fmt::format("{}[{}].name", list, i);
    if (items[i].name.empty()) c.fail(field, "must not be empty");
    if (!seen.insert(items[i].name).second)
      c.fail(field, fmt::format("'{}' is used twice", items[i].name));
  }
}

}  // namespace

std::vector<InputError> validate(const Scenario& s, const world::Terrain& terrain) {
  Checker c;
  c.ordered("area.x_min_m", s.area.x_min_m, "area.x_max_m", s.area.x_max_m);
  c.ordered("area.y_min_m", s.area.y_min_m, "area.y_max_m", s.area.y_max_m);
  c.collect([&] { world::validate(s.safety); });
  if (!c.problems.empty()) return c.problems;  // later checks rely on a sane area and band

  if (s.uavs.empty()) c.fail("uavs", "at least one UAV is needed");
  check_unique_names(c, "uavs", s.uavs);
  for (std::size_t i = 0; i < s.uavs.size(); ++i) {
    const UavSpec& u = s.uavs[i];
    const std::string path = fmt::format("uavs[{}]", i);
    check_vehicle(c, path + ".vehicle", u.vehicle);
    check_placement(c, path + ".start.position_m", u.start_position_m, s, terrain);
    c.finite(path + ".start.heading_deg", u.start_heading_rad);
    if (c.finite(path + ".start.speed_m_s", u.start_speed_m_s) &&
        (u.start_speed_m_s < 0.0 || u.start_speed_m_s > u.vehicle.max_speed_m_s())) {
      c.fail(path + ".start.speed_m_s", fmt::format("{} m/s is outside [0, {}] m/s",
                                                    u.start_speed_m_s, u.vehicle.max_speed_m_s()));
    }
    c.positive(path + ".sensor_range_m", u.sensor_range_m);
    for (std::size_t j = 0; j < i; ++j) {
      const double d = (u.start_position_m - s.uavs[j].start_position_m).norm();
      if (d < s.safety.separation_m) {
        c.fail(path + ".start.position_m",
               fmt::format("{:.1f} m from uavs[{}] ('{}'), closer than the separation d_safe "
                           "{} m",
                           d, j, s.uavs[j].name, s.safety.separation_m));
      }
    }
  }

  // A mission without targets is a ferry flight: every UAV must then have somewhere to go.
  const bool every_uav_has_end =
      !s.uavs.empty() && std::all_of(s.uavs.begin(), s.uavs.end(),
                                     [](const UavSpec& u) { return u.end_position_m.has_value(); });
  if (s.targets.empty() && !every_uav_has_end)
    c.fail("targets", "at least one inspection target is needed (or an end for every UAV)");
  check_unique_names(c, "targets", s.targets);
  for (std::size_t i = 0; i < s.targets.size(); ++i) {
    const InspectionTarget& t = s.targets[i];
    const std::string path = fmt::format("targets[{}]", i);
    check_placement(c, path + ".position_m", t.position_m, s, terrain);
    if (t.priority < 0) c.fail(path + ".priority", fmt::format("must be >= 0, got {}", t.priority));
    c.positive(path + ".inspection_radius_m", t.inspection_radius_m);
  }

  // Per-UAV missions: an assigned target must exist and belong to one UAV; an end is placed as
  // a target is (inside the area and the band, h_safe above the terrain).
  std::map<std::string, std::size_t> owner;  // target name -> the UAV it is given to
  for (std::size_t i = 0; i < s.uavs.size(); ++i) {
    const UavSpec& u = s.uavs[i];
    for (std::size_t k = 0; k < u.assigned_targets.size(); ++k) {
      const std::string& name = u.assigned_targets[k];
      const std::string field = fmt::format("uavs[{}].targets[{}]", i, k);
      const bool known = std::any_of(s.targets.begin(), s.targets.end(),
                                     [&](const InspectionTarget& t) { return t.name == name; });
      if (!known) {
        c.fail(field, fmt::format("no target is named '{}'", name));
        continue;
      }
      const auto [it, inserted] = owner.emplace(name, i);
      if (!inserted) {
        c.fail(field, it->second == i
                          ? fmt::format("target '{}' is listed twice", name)
                          : fmt::format("target '{}' is already given to uavs[{}] ('{}')", name,
                                        it->second, s.uavs[it->second].name));
      }
    }
    if (u.end_position_m)
      check_placement(c, fmt::format("uavs[{}].end.position_m", i), *u.end_position_m, s, terrain);
  }

  for (std::size_t i = 0; i < s.threats.size(); ++i)
    c.collect([&] { world::validate(s.threats[i], fmt::format("threats[{}]", i)); });
  c.collect([&] { world::validate(s.wind, "wind"); });

  const MpcConfig& m = s.mpc;
  c.positive("mpc.control_period_s", m.control_period_s);
  c.positive("mpc.prediction_step_s", m.prediction_step_s);
  if (std::isfinite(m.prediction_step_s) && std::isfinite(m.control_period_s) &&
      m.prediction_step_s < m.control_period_s) {
    c.fail("mpc.prediction_step_s", fmt::format("{} s is shorter than the control period {} s",
                                                m.prediction_step_s, m.control_period_s));
  }
  if (m.horizon_steps < 1) c.fail("mpc.horizon_steps", "must be at least 1");
  if (m.control_horizon_steps < 1 || m.control_horizon_steps > m.horizon_steps) {
    c.fail("mpc.control_horizon_steps", fmt::format("must be in [1, horizon_steps = {}], got {}",
                                                    m.horizon_steps, m.control_horizon_steps));
  }
  c.positive("mpc.position_weight", m.position_weight);
  for (int k = 0; k < 3; ++k) {
    c.positive(fmt::format("mpc.move_weights[{}]", k), m.move_weights[k]);
    c.positive(fmt::format("mpc.max_moves[{}]", k), m.max_moves[k]);
  }
  c.positive("mpc.slack_weight", m.slack_weight);

  const PlannerConfig& p = s.planner;
  if (p.waypoints_per_uav < 2) c.fail("planner.waypoints_per_uav", "must be at least 2");
  if (c.finite("planner.max_turn_angle_deg", p.max_turn_angle_rad) &&
      (p.max_turn_angle_rad <= 0.0 || p.max_turn_angle_rad > kPi)) {
    c.fail("planner.max_turn_angle_deg",
           fmt::format("must be in (0, 180] degrees, got {}", rad_to_deg(p.max_turn_angle_rad)));
  }
  c.non_negative("planner.pitch_penalty", p.pitch_penalty);
  c.non_negative("planner.turn_penalty", p.turn_penalty);
  c.non_negative("planner.weights.range", p.weight_range);
  c.non_negative("planner.weights.pitch", p.weight_pitch);
  c.non_negative("planner.weights.turn", p.weight_turn);
  c.non_negative("planner.weights.altitude", p.weight_altitude);
  c.non_negative("planner.cluster.individual", p.lambda_individual);
  c.non_negative("planner.cluster.collision", p.lambda_collision);
  c.non_negative("planner.allocation.makespan_weight", p.allocation_makespan_weight);
  c.non_negative("planner.allocation.priority_weight", p.allocation_priority_weight);

  const SimulationConfig& sim = s.simulation;
  c.positive("simulation.duration_s", sim.duration_s);
  c.positive("simulation.truth_rate_hz", sim.truth_rate_hz);
  if (std::isfinite(sim.truth_rate_hz) && std::isfinite(m.control_period_s) &&
      sim.truth_rate_hz * m.control_period_s < 1.0 - 1e-9) {
    c.fail("simulation.truth_rate_hz", fmt::format("{} Hz is slower than the control rate {} Hz",
                                                   sim.truth_rate_hz, 1.0 / m.control_period_s));
  }
  c.positive("simulation.message_rate_hz", sim.message_rate_hz);
  c.positive("simulation.truth_time_constant_scale", sim.truth_time_constant_scale);
  c.non_negative("simulation.position_noise_m", sim.position_noise_m);
  c.non_negative("simulation.link.latency_s", sim.link_latency_s);
  c.non_negative("simulation.link.jitter_s", sim.link_jitter_s);
  if (!(sim.link_drop_rate >= 0.0 && sim.link_drop_rate < 1.0))
    c.fail("simulation.link.drop_rate", fmt::format("{} is outside [0, 1)", sim.link_drop_rate));
  return c.problems;
}

}  // namespace ridgeline::mission
