# The two commands of the README:
#   make run    installs the dependencies, builds, and runs the main job on the default scenario
#   make test   installs the dependencies, builds, and runs every test
BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: run test build deps test-deps node-deps web-deps configure clean asan

deps:
	@./scripts/install-deps.sh

# The packages only the tests need (chromium, which opens report.html headless).
test-deps:
	@./scripts/install-deps.sh --test

$(BUILD_DIR)/build.ninja:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(CMAKE_FLAGS)

configure: deps $(BUILD_DIR)/build.ninja

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

run: build web-deps
	$(BUILD_DIR)/ridgeline run --out out/default

test: build node-deps web-deps test-deps
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

# node-mavlink, the independent MAVLink decoder the tests check ours against, from its lock
# file; only when missing or out of date, and silently. Node.js and npm come from apt if absent.
MAVLINK_CHECK := tools/mavlink-check
node-deps: $(MAVLINK_CHECK)/node_modules/.package-lock.json
	@:

$(MAVLINK_CHECK)/node_modules/.package-lock.json: $(MAVLINK_CHECK)/package.json $(MAVLINK_CHECK)/package-lock.json
	@command -v npm >/dev/null || { echo "node-deps: installing nodejs npm"; \
	  sudo=$$([ "$$(id -u)" -ne 0 ] && echo sudo); $$sudo apt-get update -qq && \
	  $$sudo apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null; }
	@npm ci --prefix $(MAVLINK_CHECK) --no-audit --no-fund --loglevel=error >/dev/null
	@touch $@

# plotly.js (plotly.js-dist-min), inlined into every report.html, from web/'s lock file; the
# binary reads web/node_modules/plotly.js-dist-min/plotly.min.js. Same rules as node-deps.
web-deps: web/node_modules/.package-lock.json
	@:

web/node_modules/.package-lock.json: web/package.json web/package-lock.json
	@command -v npm >/dev/null || { echo "web-deps: installing nodejs npm"; \
	  sudo=$$([ "$$(id -u)" -ne 0 ] && echo sudo); $$sudo apt-get update -qq && \
	  $$sudo apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null; }
	@npm ci --prefix web --no-audit --no-fund --loglevel=error >/dev/null
	@touch $@

# Address and undefined-behaviour sanitizers over the whole test suite.
asan:
	$(MAKE) test BUILD_DIR=build-asan BUILD_TYPE=Debug CMAKE_FLAGS="-DRIDGELINE_SANITIZE=ON"

clean:
	rm -rf $(BUILD_DIR) build-asan
