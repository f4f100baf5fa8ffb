#include "mpc/sphere_rows.hpp"

#include <cmath>
#include <cstring>

#include "core/simd_clones.hpp"

namespace ridgeline::mpc {

// Element-wise, so the vectorizer takes it as is; the products round before the sums as in the
// scalar expression (contraction off).
RIDGELINE_SIMD_CLONES RIDGELINE_NO_CONTRACTION void moving_centres(const Vec3& centre,
                                                                   const Vec3& velocity,
                                                                   double appear_s, double t_s,
                                                                   double dt, int n, double* cx,
                                                                   double* cy, double* cz) {
  const double c0 = centre.x(), c1 = centre.y(), c2 = centre.z();
  const double v0 = velocity.x(), v1 = velocity.y(), v2 = velocity.z();
  for (int j = 0; j < n; ++j) {
    const double since = (t_s + (j + 1) * dt) - appear_s;
    cx[j] = c0 + v0 * since;
    cy[j] = c1 + v1 * since;
    cz[j] = c2 + v2 * since;
  }
}

// The differences p_j − c_j and their squared lengths, element-wise: the vectorizer takes it.
// (The pointers are this function's restrict parameters: restrict locals would not let GCC
// drop its overlap checks.)
inline __attribute__((always_inline)) void squared_distances(
    const double* __restrict px, const double* __restrict py, const double* __restrict pz,
    const double* __restrict cx, const double* __restrict cy, const double* __restrict cz, int n,
    double* __restrict dx, double* __restrict dy, double* __restrict dz,
    double* __restrict squared) {
  for (int j = 0; j < n; ++j) {
    const double x = px[j] - cx[j], y = py[j] - cy[j], z = pz[j] - cz[j];
    dx[j] = x;
    dy[j] = y;
    dz[j] = z;
    squared[j] = x * x + y * y + z * z;
  }
}

RIDGELINE_SIMD_CLONES RIDGELINE_NO_CONTRACTION void sphere_rows(const HorizonPoints& nominal,
                                                                const SphereSpec& sphere, int n,
                                                                const SphereRowsOut& out) {
  const double* __restrict px = nominal.x;
  const double* __restrict py = nominal.y;
  const double* __restrict pz = nominal.z;
  const double* __restrict cx = sphere.centres.x;
  const double* __restrict cy = sphere.centres.y;
  const double* __restrict cz = sphere.centres.z;
  const double* __restrict margins = sphere.margins;
  double* __restrict dist = out.distance;
  double* __restrict ux = out.nx;
  double* __restrict uy = out.ny;
  double* __restrict uz = out.nz;
  double* __restrict bound = out.bound;
  std::int64_t* __restrict active = out.active;
  const double required = sphere.required_m, activation = sphere.activation_m;
  const double from_s = sphere.from_s, to_s = sphere.to_s, t_s = sphere.t_s, dt = sphere.dt_s;
  const bool windowed = sphere.windowed;
  squared_distances(px, py, pz, cx, cy, cz, n, ux, uy, uz, dist);
  // Vector square roots: this file is built without errno (CMakeLists.txt says why).
  for (int j = 0; j < n; ++j) dist[j] = std::sqrt(dist[j]);
  // The rest by four lanes written out (the vectorizer leaves a loop with these conditions
  // scalar), then the steps past the last multiple of four one by one.
  const Vec4 activation4 = activation - Vec4{}, zero = {};
  const Mask4 always = ~Mask4{};
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    Vec4 d, x, y, z, c0, c1, c2, margin = {};
    std::memcpy(&d, dist + j, sizeof d);
    std::memcpy(&x, ux + j, sizeof x);
    std::memcpy(&y, uy + j, sizeof y);
    std::memcpy(&z, uz + j, sizeof z);
    std::memcpy(&c0, cx + j, sizeof c0);
    std::memcpy(&c1, cy + j, sizeof c1);
    std::memcpy(&c2, cz + j, sizeof c2);
    if (margins != nullptr) std::memcpy(&margin, margins + j, sizeof margin);
    const Vec4 nx = x / d, ny = y / d, nz = z / d;
    // (required − 0 is `required` for every value, −0 included, as the scalar lanes below.)
    const Vec4 need = margins != nullptr ? required + margin : required - zero;
    const Vec4 b = nx * c0 + ny * c1 + nz * c2 + need;
    const Vec4 steps = {static_cast<double>(j + 1), static_cast<double>(j + 2),
                        static_cast<double>(j + 3), static_cast<double>(j + 4)};
    const Vec4 tj = t_s + steps * dt;
    // (Lane-wise comparisons give −1 where true; the casts only name the type.)
    const Mask4 in_window = windowed ? Mask4((from_s <= tj) & (tj <= to_s)) : always;
    const Mask4 on = (in_window & ~Mask4(d - need > activation4)) & 1;
    std::memcpy(ux + j, &nx, sizeof nx);
    std::memcpy(uy + j, &ny, sizeof ny);
    std::memcpy(uz + j, &nz, sizeof nz);
    std::memcpy(bound + j, &b, sizeof b);
    std::memcpy(active + j, &on, sizeof on);
  }
  for (; j < n; ++j) {
    const double d = dist[j];
    const double nx = ux[j] / d, ny = uy[j] / d, nz = uz[j] / d;
    const double need = margins != nullptr ? required + margins[j] : required;
    ux[j] = nx;
    uy[j] = ny;
    uz[j] = nz;
    bound[j] = nx * cx[j] + ny * cy[j] + nz * cz[j] + need;
    const double tj = t_s + (j + 1) * dt;
    const bool in_window = !windowed || (from_s <= tj && tj <= to_s);
    active[j] = in_window && !(d - need > activation) ? 1 : 0;
  }
}

}  // namespace ridgeline::mpc
