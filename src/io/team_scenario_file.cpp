#include "io/team_scenario_file.hpp"

#include <fmt/format.h>

#include <map>
#include <sstream>
#include <vector>

#include "core/error.hpp"

namespace ridgeline::io {
namespace {

// A top-level section: its key and its text (the comment lines right above the key, the key's
// line and the indented or blank lines after it).
struct Section {
  std::string key;  // empty: the text after the last section (trailing comments)
  std::string text;
};

bool is_top_level_key(const std::string& line) {
  if (line.empty() || line[0] == ' ' || line[0] == '#' || line[0] == '-') return false;
  return line.find(':') != std::string::npos;
}

std::vector<Section> split_sections(std::string_view yaml) {
  std::vector<Section> sections;
  std::string pending_comments;  // comment lines not yet attached to a key
  std::istringstream in{std::string(yaml)};
  for (std::string line; std::getline(in, line);) {
    if (is_top_level_key(line)) {
      sections.push_back({line.substr(0, line.find(':')), pending_comments + line + "\n"});
      pending_comments.clear();
    } else if (!line.empty() && line[0] == '#') {
      pending_comments += line + "\n";
    } else if (sections.empty()) {
      pending_comments += line + "\n";
    } else {
      sections.back().text += pending_comments + line + "\n";
      pending_comments.clear();
    }
  }
  if (!pending_comments.empty()) sections.push_back({"", pending_comments});
  return sections;
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string vec(const Vec3& v) { return fmt::format("[{:.1f}, {:.1f}, {:.1f}]", v.x(), v.y(), v.z()); }

}  // namespace

std::string team_scenario_yaml(std::string_view base_yaml, const mission::Scenario& team,
                               const std::string& how_made, const std::string& dem_path) {
  std::map<std::string, std::string> replaced;
  replaced["name"] = fmt::format(
      "# A generated team scenario: {} UAVs on a take-off grid, {} targets and {} threats drawn\n"
      "# from seed {}, made by `{}`;\n"
      "# every other field is the default scenario's (DESIGN §7).\n"
      "# Units are SI (metres, seconds, m/s); angles in degrees where the key says _deg.\n"
      "# Frame: local ENU (x east, y north, z up); z is height above the terrain datum.\n"
      "name: {}\n",
      team.uavs.size(), team.targets.size(), team.threats.size(), team.seed, how_made, team.name);
  replaced["seed"] = fmt::format("seed: {}\n", team.seed);
  std::string uavs = "uavs:\n";
  for (const mission::UavSpec& u : team.uavs)
    uavs += fmt::format(
        "  - name: {}\n    start: {{position_m: {}, heading_deg: {:.1f}, speed_m_s: {}}}\n"
        "    sensor_range_m: {}\n",
        u.name, vec(u.start_position_m), rad_to_deg(u.start_heading_rad), u.start_speed_m_s,
        u.sensor_range_m);
  replaced["uavs"] = uavs + "\n";
  std::string targets = "targets:\n";
  for (const mission::InspectionTarget& t : team.targets)
    targets += fmt::format("  - {{name: {}, position_m: {}, priority: {}, inspection_radius_m: {}}}\n",
                           t.name, vec(t.position_m), t.priority, t.inspection_radius_m);
  replaced["targets"] = targets + "\n";
  std::string threats = "# Sudden threats, eq. 13: unknown to the global planner; sensed in flight.\n";
  if (team.threats.empty()) threats += "threats: []\n";
  else threats += "threats:\n";
  for (const world::Threat& t : team.threats)
    threats += fmt::format(
        "  - {{name: {}, centre_m: {}, velocity_m_s: [{:.2f}, {:.2f}, {:.2f}], radius_m: {:.1f}, "
        "appear_s: {:.1f}, vanish_s: {:.1f}}}\n",
        t.name, vec(t.centre_m), t.velocity_m_s.x(), t.velocity_m_s.y(), t.velocity_m_s.z(),
        t.radius_m, t.appear_s, t.vanish_s);
  replaced["threats"] = threats + "\n";
  if (!dem_path.empty()) {
    replaced["terrain"] = fmt::format(
        "# Terrain: the DEM raster, queried bilinearly on its own cells (its south-west corner\n"
        "# frame, metres).\nterrain:\n  dem: {{path: {}, model: raster}}\n\n",
        quoted(dem_path));
    const mission::Area& a = team.area;
    replaced["area"] = fmt::format("area: {{x_min_m: {:.1f}, x_max_m: {:.1f}, y_min_m: {:.1f}, y_max_m: {:.1f}}}\n",
                                   a.x_min_m, a.x_max_m, a.y_min_m, a.y_max_m);
  }
  std::string out;
  std::map<std::string, bool> found;
  for (const Section& s : split_sections(base_yaml)) {
    auto it = replaced.find(s.key);
    if (it == replaced.end()) {
      out += s.text;
    } else {
      out += it->second;
      found[s.key] = true;
    }
  }
  for (const auto& [key, text] : replaced)
    if (!found[key])
      throw InputError("base", fmt::format("the base scenario text has no top-level '{}' section", key));
  return out;
}

}  // namespace ridgeline::io
