// Run-time dispatched vector code for the hot loops of the 50 Hz step.
//
// The build targets baseline x86-64 (SSE2: two doubles a vector) so that the binary runs on
// any x86-64 machine. A function marked RIDGELINE_SIMD_CLONES is compiled twice, for the
// baseline and for x86-64-v3 (AVX2: four doubles a vector), and the loader picks the clone
// the CPU supports (GCC's target_clones, an ifunc resolved once at start-up).
//
// The two clones agree to round-off, not bit for bit: in the x86-64-v3 clone GCC contracts
// a·b + c into fused multiply-adds (its default for C++), which round once instead of twice.
// A function that must round as the baseline does adds RIDGELINE_NO_CONTRACTION (contraction
// off for that function only; where there are no clones, it leaves the compiler's default).
// Sums are not reordered (no -ffast-math), so a vectorized loop must be element-wise: a
// floating-point reduction stays scalar. Eigen's own kernels inside such a function stay SSE2
// (Eigen picks its packets at compile time), so the hot loops are written by hand.
#pragma once

#include <cstddef>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define RIDGELINE_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#define RIDGELINE_NO_CONTRACTION __attribute__((optimize("fp-contract=off")))
#else
#define RIDGELINE_SIMD_CLONES
#define RIDGELINE_NO_CONTRACTION
#endif

namespace ridgeline {

// Four doubles as one value (GCC's vector extension): one AVX2 register in the x86-64-v3
// clones, two SSE2 registers in the baseline ones. Loaded and stored with memcpy (unaligned);
// passed by reference only (a vector argument by value would change the baseline's ABI).
typedef double Vec4 __attribute__((vector_size(32)));
// A lane-wise comparison of two Vec4: −1 where true, 0 elsewhere.
typedef long long Mask4 __attribute__((vector_size(32)));

// v ← |v| lane by lane: the sign bit cleared (as std::abs; −0 gives +0, a NaN stays a NaN). In
// place, as the vectors here are passed by reference only (see Vec4).
inline __attribute__((always_inline)) void make_magnitude(Vec4& v) {
  constexpr long long kMagnitude = 0x7fffffffffffffffLL;  // every bit but the sign
  const Mask4 magnitude = {kMagnitude, kMagnitude, kMagnitude, kMagnitude};
  v = (Vec4)((Mask4)v & magnitude);  // a vector cast of equal size reinterprets the bits
}

// No entry of x[0..n) infinite or NaN: x·0 is ±0 for a finite x and NaN otherwise, and a NaN,
// once summed in, stays. Four vector sums of x·0 (one fused multiply-add each in an AVX2
// clone) read the entries at about one instruction per four; written with vector types,
// because the vectorizer would keep a floating-point sum scalar. Inlined into its callers (the
// QP's input checks, clones of their own; a received message's check).
inline __attribute__((always_inline)) bool entries_finite(const double* x, std::ptrdiff_t n) {
  const Vec4 zero = {};
  Vec4 s0 = {}, s1 = {}, s2 = {}, s3 = {};
  std::ptrdiff_t i = 0;
  for (; i + 16 <= n; i += 16) {
    Vec4 v0, v1, v2, v3;
    std::memcpy(&v0, x + i, sizeof v0);
    std::memcpy(&v1, x + i + 4, sizeof v1);
    std::memcpy(&v2, x + i + 8, sizeof v2);
    std::memcpy(&v3, x + i + 12, sizeof v3);
    s0 += v0 * zero;
    s1 += v1 * zero;
    s2 += v2 * zero;
    s3 += v3 * zero;
  }
  const Vec4 s = (s0 + s1) + (s2 + s3);
  double tail = (s[0] + s[1]) + (s[2] + s[3]);
  for (; i < n; ++i) tail += x[i] * 0.0;
  return tail == 0.0;
}

// Transposes the 4 × 4 block whose rows are r0..r3, in place (the rows become its columns).
inline __attribute__((always_inline)) void transpose4(Vec4& r0, Vec4& r1, Vec4& r2, Vec4& r3) {
  const Vec4 t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6);  // r0[0] r1[0] r0[2] r1[2]
  const Vec4 t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
  const Vec4 t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6);
  const Vec4 t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
  r0 = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  r1 = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  r2 = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  r3 = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
}

}  // namespace ridgeline
