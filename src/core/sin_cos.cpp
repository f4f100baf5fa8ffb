#include "core/sin_cos.hpp"

#include <immintrin.h>

#include <cmath>

namespace ridgeline {
namespace {

// glibc's libmvec (libc6-dev, linked as mvec): sine and cosine of four doubles in AVX2
// registers.
extern "C" __m256d _ZGVdN4v_sin(__m256d x);
extern "C" __m256d _ZGVdN4v_cos(__m256d x);

__attribute__((target("avx2"))) void sin_cos_avx2(const double* x, double* s, double* c, int n) {
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d v = _mm256_loadu_pd(x + i);
    _mm256_storeu_pd(s + i, _ZGVdN4v_sin(v));
    _mm256_storeu_pd(c + i, _ZGVdN4v_cos(v));
  }
  if (i == n) return;
  // The last one to three angles, padded with zeros into one more call.
  alignas(32) double xt[4] = {}, st[4], ct[4];
  for (int k = 0; i + k < n; ++k) xt[k] = x[i + k];
  const __m256d v = _mm256_load_pd(xt);
  _mm256_store_pd(st, _ZGVdN4v_sin(v));
  _mm256_store_pd(ct, _ZGVdN4v_cos(v));
  for (int k = 0; i + k < n; ++k) {
    s[i + k] = st[k];
    c[i + k] = ct[k];
  }
}

}  // namespace

void sin_cos(const double* x, double* s, double* c, int n) {
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) {
    sin_cos_avx2(x, s, c, n);
    return;
  }
  for (int i = 0; i < n; ++i) {
    s[i] = std::sin(x[i]);
    c[i] = std::cos(x[i]);
  }
}

}  // namespace ridgeline
