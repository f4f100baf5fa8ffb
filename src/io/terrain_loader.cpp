#include <fmt/format.h>

#include "io/scenario_file.hpp"
#include "world/terrain.hpp"

namespace ridgeline::io {

std::shared_ptr<const world::Terrain> build_terrain(const sim::TerrainSource& source) {
  if (source.kind == sim::TerrainSource::Kind::kPeaks)
    return std::make_shared<world::PeakTerrain>(source.peaks, "terrain");
  throw InputError("terrain.dem", "DEM terrain is not wired yet");
}

}  // namespace ridgeline::io
