// The tracker's control step must not allocate after warm-up (STYLE.md practice 4; header of
// src/mpc/uav_tracker.hpp). This program counts heap allocations by interposing malloc and
// friends (Eigen allocates with malloc, not operator new) and forwarding to glibc's
// __libc_* entry points. It is a separate program so the interposition touches no other test.
// Under AddressSanitizer, which interposes malloc itself, the check is skipped.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <vector>

#include "mpc/reference.hpp"
#include "mpc/uav_tracker.hpp"
#include "vehicle/vehicle_model.hpp"

#if defined(__SANITIZE_ADDRESS__)
#define RIDGELINE_COUNT_MALLOC 0
#else
#define RIDGELINE_COUNT_MALLOC 1
#endif

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
}  // namespace

#if RIDGELINE_COUNT_MALLOC
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* ptr, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);

void* malloc(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return __libc_calloc(count, size);
}
void* realloc(void* ptr, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return __libc_realloc(ptr, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  *out = __libc_memalign(alignment, size);
  return *out != nullptr ? 0 : 12;  // ENOMEM
}
}
#endif

namespace ridgeline::mpc {
namespace {

// A flat plateau 100 m high under a circle flown at 120 m: the 40 terrain rows are active at
// every step (clearance 20 m against h_safe 20 m + margin), so the QP keeps its size.
class Plateau : public world::Terrain {
 public:
  double height(double, double) const override { return 100.0; }
  Vec2 gradient(double, double) const override { return Vec2::Zero(); }
};

TEST(UavTrackerAllocation, StepDoesNotAllocateAfterWarmUp) {
  if (!RIDGELINE_COUNT_MALLOC) GTEST_SKIP() << "malloc is interposed by the sanitizer";
  // The counter must see an Eigen allocation, or the check below would be vacuous.
  g_counting = true;
  {
    VecX probe = VecX::Ones(1000);
    EXPECT_GT(probe.sum(), 0.0);
  }
  g_counting = false;
  ASSERT_GE(g_allocations.load(), 1);
  g_allocations = 0;
  HelixReference::Config c;
  c.centre_m = Vec3(0.0, 0.0, 120.0);
  c.radius_m = 150.0;
  const HelixReference ref(c);
  std::vector<world::Threat> threats(1);
  threats[0].centre_m = Vec3(0.0, 0.0, 120.0);  // the circle's centre: rows active, never hit
  threats[0].radius_m = 100.0;
  std::vector<messages::PredictedTrajectory> neighbours(1);
  for (int i = 0; i < 100; ++i) {
    neighbours[0].positions_m.push_back(ref.at(i * 0.5 + 3.0).position_m + Vec3(0, 0, 15.0));
  }
  neighbours[0].step_s = 0.5;
  neighbours[0].stamp_s = -0.5;  // the first position at t = 0
  const Plateau plateau;
  const TrackerEnvironment env{threats, neighbours, &plateau};
  UavTracker tracker(UavTrackerOptions{}, world::SafetyLimits{});
  const ReferencePoint r0 = ref.at(0.0);
  vehicle::State s;
  s << r0.position_m, r0.heading_rad, r0.speed_m_s, r0.turn_rate_rad_s, 0.0;
  const vehicle::VehicleParams truth;
  const Vec3 wind(1.0, 0.5, 0.0);
  double t = 0.0;
  long allocations_after_warm_up = 0;
  int soft_rows_min = 1 << 30, soft_rows_max = 0, qp_growths = 0;
  for (int k = 0; k < 400; ++k) {
    const int rows_before = tracker.mpc().num_rows();
    const long allocations_before = g_allocations.load();
    g_counting = k >= 100;
    const UavTrackerResult& r = tracker.step(t, s, wind, ref, env);
    g_counting = false;
    ASSERT_EQ(r.qp_status, qp::QpStatus::kSolved) << k;
    // The QP keeps its largest size; a step that grows it past every size before (a block of
    // soft rows more) may allocate, once. Any other step must not.
    if (tracker.mpc().num_rows() > rows_before) {
      if (k >= 100) ++qp_growths;
      g_allocations = allocations_before;
    }
    if (k >= 100) {
      const int rows = r.soft_rows[0] + r.soft_rows[1] + r.soft_rows[2];
      soft_rows_min = std::min(soft_rows_min, rows);
      soft_rows_max = std::max(soft_rows_max, rows);
    }
    for (int i = 0; i < 4; ++i) s = vehicle::rk4_step(s, r.command, wind, truth, 0.005);
    t += 0.02;
  }
  allocations_after_warm_up = g_allocations.load();
  EXPECT_EQ(allocations_after_warm_up, 0);
  EXPECT_LE(qp_growths, 2);
  // The scenario did exercise soft rows of all kinds.
  EXPECT_GT(soft_rows_min, 40);
  std::printf("soft rows %d..%d, allocations after warm-up %ld, QP growths %d\n", soft_rows_min,
              soft_rows_max, allocations_after_warm_up, qp_growths);
}

}  // namespace
}  // namespace ridgeline::mpc
