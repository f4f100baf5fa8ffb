#include "io/terrain_fit_file.hpp"

#include <yaml-cpp/yaml.h>

#include "io/atomic_file.hpp"

namespace ridgeline::io {

std::string terrain_fit_yaml(const world::TerrainFitResult& fit, const std::string& dem_path,
                             const world::RasterGrid& grid,
                             const std::optional<mission::GeodeticOrigin>& origin) {
  const world::PeakTerrainConfig& t = fit.terrain;
  YAML::Emitter out;
  // 10 significant digits: millimetres for projected coordinates up to 10^7 m, and no
  // 0.1 → 0.10000000000000001 noise.
  out.SetDoublePrecision(10);
  out << YAML::BeginMap;
  out << YAML::Key << "terrain" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "combination" << YAML::Value
      << (t.combination == world::PeakCombination::kMax ? "max" : "sum")
      << YAML::Comment("max | sum");
  out << YAML::Key << "base_elevation_m" << YAML::Value << t.base_elevation_m;
  out << YAML::Key << "model_error_m" << YAML::Value << t.model_error_m
      << YAML::Comment("max residual of the fit");
  out << YAML::Key << "peaks" << YAML::Value << YAML::BeginSeq;
  for (const world::Peak& p : t.peaks) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "x_m" << YAML::Value << p.x_m;
    out << YAML::Key << "y_m" << YAML::Value << p.y_m;
    out << YAML::Key << "height_m" << YAML::Value << p.height_m;
    out << YAML::Key << "sigma_x_m" << YAML::Value << p.sigma_x_m;
    out << YAML::Key << "sigma_y_m" << YAML::Value << p.sigma_y_m;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  out << YAML::Key << "fit_report" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "dem" << YAML::Value << dem_path;
  out << YAML::Key << "rmse_m" << YAML::Value << fit.rmse_m;
  out << YAML::Key << "max_residual_m" << YAML::Value << fit.max_residual_m;
  out << YAML::Key << "iterations" << YAML::Value << fit.iterations;
  out << YAML::Key << "time_s" << YAML::Value << fit.time_s;
  out << YAML::Key << "raster_cols" << YAML::Value << grid.cols;
  out << YAML::Key << "raster_rows" << YAML::Value << grid.rows;
  if (origin) {
    out << YAML::Key << "origin" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "lat_deg" << YAML::Value << origin->lat_deg;
    out << YAML::Key << "lon_deg" << YAML::Value << origin->lon_deg;
    out << YAML::Key << "alt_amsl_m" << YAML::Value << origin->alt_amsl_m;
    out << YAML::EndMap;
  }
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void write_terrain_fit_yaml(const std::filesystem::path& path, const world::TerrainFitResult& fit,
                            const std::string& dem_path, const world::RasterGrid& grid,
                            const std::optional<mission::GeodeticOrigin>& origin) {
  write_file_atomically(path, terrain_fit_yaml(fit, dem_path, grid, origin));
}

}  // namespace ridgeline::io
