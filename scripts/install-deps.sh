#!/usr/bin/env bash
# Installs the Debian 12 packages Ridgeline builds with (and with --test, tests with).
# Idempotent: when every package is already installed it prints nothing and touches nothing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  python3                  # scripts/check_layers.py (the layering test)
  libeigen3-dev            # linear algebra (vehicle, QP, MPC)
  coinor-libipopt-dev      # NLP solver: global planner, QP reference in tests
  libceres-dev             # nonlinear least squares: DEM peak fit
  libgdal-dev gdal-bin     # DEM rasters (GeoTIFF, ESRI ASCII, SRTM .hgt)
  libproj-dev              # geodetic frames
  libyaml-cpp-dev          # scenario files
  nlohmann-json3-dev       # JSON outputs
  libcli11-dev             # command line
  libspdlog-dev libfmt-dev # logging, formatting
  cyclonedds-dev cyclonedds-tools  # DDS transport between processes (library; idlc, ddsperf)
  libtorch-dev             # DDPG comparison method (src/learning): training and --method ddpg
  libgtest-dev libgmock-dev libbenchmark-dev
  # A second DDS implementation for the tests (tests/fastdds/): eProsima Fast DDS, which ROS 2
  # and PX4's uXRCE-DDS agent use, and its IDL compiler; fastddsgen is a Java program.
  libfastrtps-dev libfastcdr-dev fastddsgen default-jre-headless
)
# With --test (make test), also what only the tests use.
test_packages=(
  chromium                 # headless browser: the report.html test (tests/apps/report_browser_test.cpp)
)
if [ "${1:-}" = "--test" ]; then packages+=("${test_packages[@]}"); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
[ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
