// Sines and cosines of many angles at once, for the loops that take one a sample (the wind
// field's modes at every truth step, the MPC's Jacobians along its horizon).
#pragma once

namespace ridgeline {

/// s[i] = sin x[i] and c[i] = cos x[i] for i < n (x, s and c do not overlap). Where the CPU
/// has AVX2, glibc's libmvec takes four angles a call; elsewhere libm's sin and cos take one.
/// The two agree to a few ulp (libmvec's bound is 4 ulp), so results differ between machines
/// with and without AVX2 by round-off only.
void sin_cos(const double* x, double* s, double* c, int n);

}  // namespace ridgeline
