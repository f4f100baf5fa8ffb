#!/bin/sh
# The geographic example: writes DIR/valley.tif, a DEM in EPSG:4326 (1 arc-second cells over
# 46.49..46.55 N, 7.92..8.00 E: a valley floor at 800 m above sea level, a 250 m hill and a
# ridge), and DIR/valley.yaml, a three-UAV scenario over it with a geodetic origin, positions
# partly in latitude/longitude and the altitude band stated above home. Needs awk and GDAL's
# gdal_translate (Debian gdal-bin, installed by scripts/install-deps.sh).
#   scripts/geo_example.sh out/geo && build/ridgeline run --scenario out/geo/valley.yaml --out out/geo/run
set -eu
dir=${1:?usage: scripts/geo_example.sh DIR}
mkdir -p "$dir"
awk 'BEGIN {
  cols = 288; rows = 216; cell = 1 / 3600; x0 = 7.92; y0 = 46.49
  printf "ncols %d\nnrows %d\nxllcorner %.10f\nyllcorner %.10f\ncellsize %.15f\n", cols, rows, x0, y0, cell
  for (i = 0; i < rows; i++) {
    lat = y0 + (rows - 1 - i + 0.5) * cell
    line = ""
    for (j = 0; j < cols; j++) {
      lon = x0 + (j + 0.5) * cell
      u = (lat - 46.525) / 0.004; v = (lon - 7.955) / 0.006; r = (lat - 46.505) / 0.003
      h = 800 + 250 * exp(-0.5 * (u * u + v * v)) + 120 * exp(-0.5 * r * r) * (1 + 0.3 * sin(lon * 300))
      line = line sprintf(j ? " %.3f" : "%.3f", h)
    }
    print line
  }
}' > "$dir/valley.asc"
gdal_translate -q -a_srs EPSG:4326 "$dir/valley.asc" "$dir/valley.tif"
rm -f "$dir/valley.asc" "$dir/valley.asc.aux.xml" "$dir/valley.prj"
cat > "$dir/valley.yaml" <<'YAML'
# Three UAVs over an EPSG:4326 DEM placed by a geodetic origin (README "Geographic frame").
name: valley
origin: {lat_deg: 46.52, lon_deg: 7.96, alt_amsl_m: 800}   # home, on the valley floor
altitude: {min_m: 40, max_m: 500, reference: home}         # 840..1300 m above sea level
area: {x_min_m: -1500, x_max_m: 1500, y_min_m: -1500, y_max_m: 1500}
terrain: {dem: {path: valley.tif, model: raster}}
uavs:
  - {name: uav1, start: {position_geo: {lat_deg: 46.5092, lon_deg: 7.9443, alt_amsl_m: 950}, heading_deg: 45}}
  - {name: uav2, start: {position_m: [-1150, -1230, 950], heading_deg: 45}}
  - {name: uav3, start: {position_m: [-1100, -1260, 950], heading_deg: 45}}
targets:
  - {name: mast, position_m: [1000, 1000, 900], priority: 2}
  - {name: hut, position_geo: {lat_deg: 46.53, lon_deg: 7.975, alt_amsl_m: 950}}
  - {name: saddle, position_m: [-300, 1200, 1000]}
threats:
  - {name: t1, centre_geo: {lat_deg: 46.518, lon_deg: 7.955, alt_amsl_m: 1000}, velocity_m_s: [3, 2, 0], radius_m: 40, appear_s: 40, vanish_s: 300}
wind: {mean_m_s: [1.6, 1.2, 0], gust_std_m_s: 0.8}
YAML
echo "wrote $dir/valley.tif and $dir/valley.yaml"
