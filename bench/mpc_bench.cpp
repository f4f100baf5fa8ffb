// The UAV tracker's full control step (history, linearization along the horizon, threat,
// neighbour and terrain rows, QP assembly, interior-point solve) at the DESIGN's sizes:
// Np = 40 × 0.1 s, Nc = 10, with 3 threats, 2 neighbours and terrain rows active.
//
// The loop is closed (the truth is stepped with RK4 between control steps, outside the timed
// region) so that warm starts see the consecutive problems a real flight produces. Manual
// timing measures tracker.step() alone; the counters report its median, p99 and max (µs) and
// the QP's share. Run: mpc_bench --benchmark_min_time=2s
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <vector>

#include "mpc/reference.hpp"
#include "mpc/uav_tracker.hpp"
#include "vehicle/vehicle_model.hpp"
#include "world/terrain.hpp"
#include "world/threat.hpp"

namespace {

using namespace ridgeline;

// Thread CPU time (µs): on a shared machine the wall clock also counts the time the step was
// preempted; the CPU time does not.
double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
}

// A ridge of Gaussian hills under the circle, high enough that the clearance rows are active
// (the UAV flies 30–60 m above it and activation is 60 m).
class RidgeTerrain : public world::Terrain {
 public:
  double height(double x, double y) const override {
    double h = 0.0;
    for (const auto& c : centres_) {
      h = std::max(h, 80.0 * std::exp(-std::pow((x - c.x()) / 120.0, 2) -
                                      std::pow((y - c.y()) / 120.0, 2)));
    }
    return h;
  }
  Vec2 gradient(double x, double y) const override {
    // Gradient of the highest peak (the max of eq. 12).
    double best = -1.0;
    Vec2 g = Vec2::Zero();
    for (const auto& c : centres_) {
      const double h = 80.0 * std::exp(-std::pow((x - c.x()) / 120.0, 2) -
                                        std::pow((y - c.y()) / 120.0, 2));
      if (h > best) {
        best = h;
        g = Vec2(-2.0 * (x - c.x()) / (120.0 * 120.0) * h, -2.0 * (y - c.y()) / (120.0 * 120.0) * h);
      }
    }
    return g;
  }

 private:
  std::vector<Vec2> centres_{Vec2(150.0, 0.0), Vec2(-100.0, 120.0), Vec2(0.0, -150.0)};
};

void BM_UavTrackerStep(benchmark::State& bm) {
  mpc::UavTrackerOptions options;  // Np 40, Δt_p 0.1 s, Nc 10, 50 Hz
  mpc::UavTracker tracker(options);
  mpc::HelixReference::Config c;
  c.centre_m = Vec3(0.0, 0.0, 120.0);
  c.radius_m = 150.0;
  c.speed_m_s = 10.0;
  const mpc::HelixReference ref(c);

  // Three threats placed on and beside the circle, slowly moving, and two neighbours flying
  // the same circle 25 m ahead and behind at a 15 m offset: all within activation distance.
  std::vector<world::Threat> threats(3);
  const double angles[3] = {0.6, 2.4, 4.2};
  for (int i = 0; i < 3; ++i) {
    threats[i].centre_m = ref.at(angles[i] * 15.0).position_m + Vec3(0.0, 0.0, 10.0 * i);
    threats[i].velocity_m_s = Vec3(1.0, -1.0, 0.0);
    threats[i].radius_m = 25.0;
  }
  auto neighbour = [&](double lead_s, double offset_m) {
    mpc::NeighbourPrediction nb;
    nb.first_time_s = 0.0;
    nb.step_s = 0.5;
    for (int i = 0; i < 400; ++i) {
      const mpc::ReferencePoint r = ref.at(i * 0.5 + lead_s);
      nb.positions_m.push_back(r.position_m +
                               offset_m * Vec3(std::cos(r.heading_rad + 1.57), std::sin(r.heading_rad + 1.57), 0.0));
    }
    return nb;
  };
  std::vector<mpc::NeighbourPrediction> neighbours{neighbour(2.5, 15.0), neighbour(-2.5, -15.0)};
  const RidgeTerrain terrain;
  const mpc::TrackerEnvironment env{threats, neighbours, &terrain};

  vehicle::VehicleParams truth;
  truth.tau_v_s = 0.65;
  truth.tau_omega_s = 0.15;
  const mpc::ReferencePoint r0 = ref.at(0.0);
  vehicle::State s;
  s << r0.position_m, r0.heading_rad, r0.speed_m_s, r0.turn_rate_rad_s, 0.0;
  const Vec3 wind(1.4, 1.4, 0.0);

  std::vector<double> times_us;
  std::vector<double> qp_us;
  std::vector<double> cpu_us;
  std::vector<double> build_us;
  int rows_sum = 0, iterations_sum = 0, not_solved = 0;
  double t = 0.0;
  for (auto _ : bm) {
    const double cpu_start = thread_cpu_us();
    const auto start = std::chrono::steady_clock::now();
    const mpc::UavTrackerResult& r = tracker.step(t, s, wind, ref, env);
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    cpu_us.push_back(thread_cpu_us() - cpu_start);
    bm.SetIterationTime(us * 1e-6);
    times_us.push_back(us);
    qp_us.push_back(r.qp_time_us);
    build_us.push_back(r.build_time_us);
    rows_sum += r.soft_rows[0] + r.soft_rows[1] + r.soft_rows[2];
    iterations_sum += r.qp_iterations;
    not_solved += r.qp_status == qp::QpStatus::kSolved ? 0 : 1;
    for (int i = 0; i < 4; ++i) s = vehicle::rk4_step(s, r.command, wind, truth, 0.005);
    t += options.control_period_s;
    if (t > 90.0) {  // stay in the part of the circle where the obstacles are
      t = 0.0;
      s << r0.position_m, r0.heading_rad, r0.speed_m_s, r0.turn_rate_rad_s, 0.0;
      tracker.reset(vehicle::Input(10.0, r0.turn_rate_rad_s, 0.0));
    }
  }
  const auto pct = [](std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
  };
  const double n = static_cast<double>(times_us.size());
  bm.counters["median_us"] = pct(times_us, 0.5);
  bm.counters["p99_us"] = pct(times_us, 0.99);
  bm.counters["max_us"] = pct(times_us, 1.0);
  bm.counters["cpu_median_us"] = pct(cpu_us, 0.5);
  bm.counters["cpu_p99_us"] = pct(cpu_us, 0.99);
  bm.counters["qp_median_us"] = pct(qp_us, 0.5);
  bm.counters["qp_p99_us"] = pct(qp_us, 0.99);
  bm.counters["build_median_us"] = pct(build_us, 0.5);
  bm.counters["soft_rows_mean"] = rows_sum / n;
  bm.counters["qp_iter_mean"] = iterations_sum / n;
  bm.counters["not_solved"] = not_solved;
}
BENCHMARK(BM_UavTrackerStep)->UseManualTime()->Unit(benchmark::kMicrosecond)->MinTime(3.0);

}  // namespace
