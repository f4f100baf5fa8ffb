// The geometry of the tracker's sphere rows (DESIGN §3): a threat's or a neighbour's soft rows
// along the prediction horizon, "stay `required` + m_j away from the centre c_j", linearized
// about the nominal positions p̄_j as n_jᵀ p_j ≥ n_jᵀ c_j + required + m_j with
// n_j = (p̄_j − c_j)/‖p̄_j − c_j‖.
//
// The horizon is computed four steps at once (AVX2 where the CPU has it) with the values of the
// scalar Vec3 expressions, bit for bit: Eigen's vectorized Vec3 sums (two-double packets, then
// the third) add a squared norm or dot product as (x + y) + z with each product rounded, and so
// do these (contraction off, RIDGELINE_NO_CONTRACTION: GCC on x86-64); divisions and square
// roots are exact in either form. A test checks it against the Vec3 expressions, so a build
// where either condition fails (Eigen without vectorization, another compiler) shows.
#pragma once

#include <cstdint>

#include "core/types.hpp"

namespace ridgeline::mpc {

/// A moving threat's centre at the prediction times t_j = t + (j+1)Δt, j in [0, n) (eq. 13):
/// c_j = c_0 + v·(t_j − t_appear), by coordinate into cx, cy, cz.
void moving_centres(const Vec3& centre, const Vec3& velocity, double appear_s, double t_s,
                    double dt, int n, double* cx, double* cy, double* cz);

/// Positions by coordinate at the n prediction steps (three arrays of n).
struct HorizonPoints {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
};

/// One sphere's rows at the steps j in [0, n): what to keep away from and when.
struct SphereSpec {
  HorizonPoints centres;            ///< c_j
  const double* margins = nullptr;  ///< m_j (n entries), or null for none
  double required_m = 0.0;          ///< the distance to keep beyond m_j
  double activation_m = 0.0;        ///< rows whose nominal lies farther out are inactive
  bool windowed = false;            ///< rows only at t_j within [from_s, to_s] (a threat's life)
  double from_s = 0.0, to_s = 0.0;
  double t_s = 0.0, dt_s = 0.0;  ///< t_j = t_s + (j+1)·dt_s
};

/// The rows' values, n entries each (the caller's storage).
struct SphereRowsOut {
  double* distance;  ///< d_j = ‖p̄_j − c_j‖
  double* nx;        ///< the unit normal (p̄_j − c_j)/d_j; not finite where d_j is 0
  double* ny;
  double* nz;
  double* bound;         ///< n_j·c_j + (required + m_j)
  std::int64_t* active;  ///< 1 if t_j lies in the window (when windowed) and
                         ///< d_j − (required + m_j) ≤ activation (a NaN d_j counts as near)
};

/// Where d_j ≤ 1e-6 the normal is not usable (p̄_j sits on the centre): the caller picks
/// another direction there.
void sphere_rows(const HorizonPoints& nominal, const SphereSpec& sphere, int n,
                 const SphereRowsOut& out);

}  // namespace ridgeline::mpc
