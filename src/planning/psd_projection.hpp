// Projection of small symmetric matrices onto the positive semidefinite (PSD) cone, for the
// convexified Hessian of the trajectory NLP (trajectory_nlp.hpp): each element block of the
// Hessian of the Lagrangian is replaced by its nearest PSD matrix in the Frobenius norm,
//   P(A) = Σ_i max(μ_i, 0)·v_i v_iᵀ = A − Σ_{μ_i < 0} μ_i·v_i v_iᵀ,   A = Σ_i μ_i·v_i v_iᵀ.
// P(A) − A is itself PSD, so a sum of projected blocks only ever adds curvature.
//
// The blocks are small (2 × 2 to 6 × 6) and fixed in size; the eigen-decomposition is a cyclic
// Jacobi method, which for such sizes is cheaper than Householder tridiagonalization plus
// implicit QR, needs no allocation, and is accurate to a few ulps of ‖A‖ in every eigenpair
// (Demmel & Veselić 1992): the projection agrees with one from any other backward-stable
// eigen-solver up to round-off.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace ridgeline::planning {

/// Eigen-decomposition A = V·diag(μ)·Vᵀ of a symmetric N × N matrix (only its lower triangle is
/// read) by cyclic Jacobi rotations: V orthogonal, μ unsorted. Returns the number of sweeps (at
/// most max_sweeps; convergence is quadratic, so 6 × 6 blocks take 5–7). A matrix with a NaN
/// or infinite entry gives NaN eigenvalues (the caller sees them, nothing loops forever).
template <int N>
int jacobi_eigen(const Eigen::Matrix<double, N, N>& a_in, Eigen::Matrix<double, N, 1>* mu,
                 Eigen::Matrix<double, N, N>* v, int max_sweeps = 30) {
  Eigen::Matrix<double, N, N> a = a_in.template selfadjointView<Eigen::Lower>();
  v->setIdentity();
  int sweep = 0;
  for (; sweep < max_sweeps; ++sweep) {
    double off = 0.0;
    double diag = 0.0;
    for (int p = 0; p < N; ++p) {
      diag += a(p, p) * a(p, p);
      for (int q = p + 1; q < N; ++q) off += a(p, q) * a(p, q);
    }
    // Stop when the off-diagonal part is below round-off of the whole matrix (2·off + diag is
    // ‖A‖_F², invariant under rotations); the `!(… > …)` form also stops on NaN.
    if (!(off > 1e-32 * (2.0 * off + diag))) break;
    for (int p = 0; p < N - 1; ++p) {
      for (int q = p + 1; q < N; ++q) {
        const double apq = a(p, q);
        if (apq == 0.0) continue;
        // The rotation that zeroes a_pq: t = tan θ, the smaller root of t² + 2ζt − 1 = 0 with
        // ζ = (a_qq − a_pp)/(2a_pq) (|θ| ≤ π/4, the stable choice).
        const double zeta = (a(q, q) - a(p, p)) / (2.0 * apq);
        const double t =
            (zeta >= 0.0 ? 1.0 : -1.0) / (std::abs(zeta) + std::sqrt(1.0 + zeta * zeta));
        const double c = 1.0 / std::sqrt(1.0 + t * t);
        const double s = t * c;
        const double rho = s / (1.0 + c);  // tan(θ/2): updates as x − s·(y + ρx) lose less
        a(p, p) -= t * apq;
        a(q, q) += t * apq;
        a(p, q) = a(q, p) = 0.0;
        for (int r = 0; r < N; ++r) {
          if (r != p && r != q) {
            const double arp = a(r, p);
            const double arq = a(r, q);
            a(r, p) = a(p, r) = arp - s * (arq + rho * arp);
            a(r, q) = a(q, r) = arq + s * (arp - rho * arq);
          }
          const double vrp = (*v)(r, p);
          const double vrq = (*v)(r, q);
          (*v)(r, p) = vrp - s * (vrq + rho * vrp);
          (*v)(r, q) = vrq + s * (vrp - rho * vrq);
        }
      }
    }
  }
  *mu = a.diagonal();
  return sweep;
}

/// Replaces the symmetric matrix a (both triangles set) by its projection onto the PSD cone.
/// A Cholesky factorization first: when it succeeds, a is positive definite and stays as it is
/// (most blocks of the NLP are); otherwise the negative eigenpairs are subtracted.
template <int N>
void project_to_psd(Eigen::Matrix<double, N, N>& a) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  // Cholesky by hand on a copy (Eigen's LLT would do; this one stops at the first non-positive
  // pivot and needs no solver object).
  {
    Mat l = a;
    bool definite = true;
    for (int j = 0; j < N && definite; ++j) {
      double d = l(j, j);
      for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
      if (!(d > 0.0)) {
        definite = false;
        break;
      }
      const double root = std::sqrt(d);
      l(j, j) = root;
      for (int i = j + 1; i < N; ++i) {
        double x = l(i, j);
        for (int k = 0; k < j; ++k) x -= l(i, k) * l(j, k);
        l(i, j) = x / root;
      }
    }
    if (definite) return;
  }
  Vec mu;
  Mat v;
  jacobi_eigen<N>(a, &mu, &v);
  for (int i = 0; i < N; ++i)
    if (mu[i] < 0.0) a.noalias() -= (mu[i] * v.col(i)) * v.col(i).transpose();
  // Keep the result exactly symmetric (the rank-one updates are, up to the order of products).
  a = (0.5 * (a + a.transpose())).eval();
}

/// The Hessian block of a function of three points a, b, c ∈ R³ that depends on their steps
/// u = b − a and w = c − b only (a turn at b): H = Dᵀ G D (9 × 9, rows a, b, c by x, y, z), with G
/// its 6 × 6 Hessian in (u, w) and D = [−I I 0; 0 −I I]; with project, its PSD projection P(H).
///
/// H vanishes on the translations (t, t, t), so with Q (9 × 6) an orthonormal basis of their
/// complement, H = Q S Qᵀ with S = Kᵀ G K, K = D Q, and P(H) = Q P(S) Qᵀ (Q has orthonormal
/// columns): the same projection from a 6 × 6 eigen-problem instead of a 9 × 9 one. Per
/// coordinate Q is the Helmert basis (−1, 1, 0)/√2, (−1, −1, 2)/√6 of the plane orthogonal to
/// (1, 1, 1).
inline Eigen::Matrix<double, 9, 9> three_point_block(const Eigen::Matrix<double, 6, 6>& g,
                                                     bool project) {
  struct Basis {
    Eigen::Matrix<double, 6, 9> D = Eigen::Matrix<double, 6, 9>::Zero();
    Eigen::Matrix<double, 9, 6> Q = Eigen::Matrix<double, 9, 6>::Zero();
    Eigen::Matrix<double, 6, 6> K;
    Basis() {
      const double q1[3] = {-1.0 / std::sqrt(2.0), 1.0 / std::sqrt(2.0), 0.0};
      const double q2[3] = {-1.0 / std::sqrt(6.0), -1.0 / std::sqrt(6.0), 2.0 / std::sqrt(6.0)};
      for (int d = 0; d < 3; ++d) {
        D(d, d) = -1.0;
        D(d, 3 + d) = 1.0;
        D(3 + d, 3 + d) = -1.0;
        D(3 + d, 6 + d) = 1.0;
        for (int m = 0; m < 3; ++m) {
          Q(3 * m + d, d) = q1[m];
          Q(3 * m + d, 3 + d) = q2[m];
        }
      }
      K = D * Q;
    }
  };
  static const Basis basis;
  Eigen::Matrix<double, 9, 9> h;
  if (project) {
    Eigen::Matrix<double, 6, 6> s = basis.K.transpose() * g * basis.K;
    project_to_psd(s);
    h.noalias() = basis.Q * s * basis.Q.transpose();
  } else {
    h.noalias() = basis.D.transpose() * g * basis.D;
  }
  return h;
}

}  // namespace ridgeline::planning
