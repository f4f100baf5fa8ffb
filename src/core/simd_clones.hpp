// Run-time dispatched vector code for the hot loops of the 50 Hz step.
//
// The build targets baseline x86-64 (SSE2: two doubles a vector) so that the binary runs on
// any x86-64 machine. A function marked RIDGELINE_SIMD_CLONES is compiled twice, for the
// baseline and for x86-64-v3 (AVX2: four doubles a vector), and the loader picks the clone
// the CPU supports (GCC's target_clones, an ifunc resolved once at start-up).
//
// The two clones agree to round-off, not bit for bit: in the x86-64-v3 clone GCC contracts
// a·b + c into fused multiply-adds (its default for C++), which round once instead of twice.
// Sums are not reordered (no -ffast-math), so a vectorized loop must be element-wise: a
// floating-point reduction stays scalar. Eigen's own kernels inside such a function stay SSE2
// (Eigen picks its packets at compile time), so the hot loops are written by hand.
#pragma once

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define RIDGELINE_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define RIDGELINE_SIMD_CLONES
#endif
