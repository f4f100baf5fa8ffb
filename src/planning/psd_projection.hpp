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

/// Eigen-decompositions A_j = V_j·diag(μ_j)·V_jᵀ of `count` symmetric N × N matrices (only
/// their lower triangles are read) by cyclic Jacobi rotations: V_j orthogonal, μ_j unsorted.
/// Matrices are processed kBatch at a time, interleaved rotation by rotation: each matrix sees
/// exactly the operations it would alone (the results are bit for bit those of a batch of one),
/// but the independent square roots and divisions of different matrices overlap in the CPU
/// (measured on 6 × 6 blocks: 2.6 µs a block against 3.6 µs one at a time). Convergence is
/// quadratic: 6 × 6 blocks take 5–7 sweeps; at most max_sweeps. A NaN or infinite entry stops
/// that matrix early with a meaningless result.
/// Returns the largest number of sweeps any matrix took.
template <int N>
int jacobi_eigen_batch(const Eigen::Matrix<double, N, N>* a_in, Eigen::Matrix<double, N, 1>* mu,
                       Eigen::Matrix<double, N, N>* v, int count, int max_sweeps = 30) {
  constexpr int kBatch = 8;
  int most_sweeps = 0;
  for (int first = 0; first < count; first += kBatch) {
    const int nb = count - first < kBatch ? count - first : kBatch;
    Eigen::Matrix<double, N, N> a[kBatch];
    bool active[kBatch];
    for (int j = 0; j < nb; ++j) {
      a[j] = a_in[first + j].template selfadjointView<Eigen::Lower>();
      v[first + j].setIdentity();
      active[j] = true;
    }
    int sweep = 0;
    for (; sweep < max_sweeps; ++sweep) {
      bool any = false;
      for (int j = 0; j < nb; ++j) {
        if (!active[j]) continue;
        double off = 0.0;
        double diag = 0.0;
        for (int p = 0; p < N; ++p) {
          diag += a[j](p, p) * a[j](p, p);
          for (int q = p + 1; q < N; ++q) off += a[j](p, q) * a[j](p, q);
        }
        // Converged when the off-diagonal part is below round-off of the whole matrix
        // (2·off + diag is ‖A‖_F², invariant under rotations); `!(… > …)` also stops on NaN.
        active[j] = off > 1e-32 * (2.0 * off + diag);
        any = any || active[j];
      }
      if (!any) break;
      for (int p = 0; p < N - 1; ++p) {
        for (int q = p + 1; q < N; ++q) {
          for (int j = 0; j < nb; ++j) {
            if (!active[j]) continue;
            Eigen::Matrix<double, N, N>& aj = a[j];
            Eigen::Matrix<double, N, N>& vj = v[first + j];
            const double apq = aj(p, q);
            if (apq == 0.0) continue;
            // The rotation that zeroes a_pq: t = tan θ, the smaller root of t² + 2ζt − 1 = 0
            // with ζ = (a_qq − a_pp)/(2a_pq) (|θ| ≤ π/4, the stable choice).
            const double zeta = (aj(q, q) - aj(p, p)) / (2.0 * apq);
            const double t =
                (zeta >= 0.0 ? 1.0 : -1.0) / (std::abs(zeta) + std::sqrt(1.0 + zeta * zeta));
            const double c = 1.0 / std::sqrt(1.0 + t * t);
            const double s = t * c;
            const double rho = s / (1.0 + c);  // tan(θ/2): updates as x − s·(y + ρx) lose less
            aj(p, p) -= t * apq;
            aj(q, q) += t * apq;
            aj(p, q) = aj(q, p) = 0.0;
            for (int r = 0; r < N; ++r) {
              if (r != p && r != q) {
                const double arp = aj(r, p);
                const double arq = aj(r, q);
                aj(r, p) = aj(p, r) = arp - s * (arq + rho * arp);
                aj(r, q) = aj(q, r) = arq + s * (arp - rho * arq);
              }
              const double vrp = vj(r, p);
              const double vrq = vj(r, q);
              vj(r, p) = vrp - s * (vrq + rho * vrp);
              vj(r, q) = vrq + s * (vrp - rho * vrq);
            }
          }
        }
      }
    }
    for (int j = 0; j < nb; ++j) mu[first + j] = a[j].diagonal();
    most_sweeps = sweep > most_sweeps ? sweep : most_sweeps;
  }
  return most_sweeps;
}

/// One matrix: jacobi_eigen_batch with a batch of one; returns its number of sweeps.
template <int N>
int jacobi_eigen(const Eigen::Matrix<double, N, N>& a, Eigen::Matrix<double, N, 1>* mu,
                 Eigen::Matrix<double, N, N>* v, int max_sweeps = 30) {
  return jacobi_eigen_batch<N>(&a, mu, v, 1, max_sweeps);
}

/// Whether the symmetric matrix a is numerically positive definite: a Cholesky factorization
/// (lower triangle) that meets no non-positive pivot.
template <int N>
bool cholesky_succeeds(const Eigen::Matrix<double, N, N>& a) {
  Eigen::Matrix<double, N, N> l = a;
  for (int j = 0; j < N; ++j) {
    double d = l(j, j);
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    if (!(d > 0.0)) return false;
    const double root = std::sqrt(d);
    l(j, j) = root;
    for (int i = j + 1; i < N; ++i) {
      double x = l(i, j);
      for (int k = 0; k < j; ++k) x -= l(i, k) * l(j, k);
      l(i, j) = x / root;
    }
  }
  return true;
}

/// Replaces each of `count` symmetric matrices (both triangles set) by its projection onto the
/// PSD cone. A Cholesky factorization first: when it succeeds, the matrix is positive definite
/// and stays as it is (most blocks of the NLP are); the others are eigen-decomposed together
/// (jacobi_eigen_batch) and their negative eigenpairs subtracted. Each result is bit for bit
/// what project_to_psd gives for that matrix alone.
template <int N>
void project_to_psd_batch(Eigen::Matrix<double, N, N>* blocks, int count) {
  using Mat = Eigen::Matrix<double, N, N>;
  using Vec = Eigen::Matrix<double, N, 1>;
  constexpr int kChunk = 64;  // bounded stack use
  for (int first = 0; first < count; first += kChunk) {
    int index[kChunk];
    Mat in[kChunk];
    int m = 0;
    for (int j = first; j < count && j < first + kChunk; ++j) {
      if (cholesky_succeeds<N>(blocks[j])) continue;
      index[m] = j;
      in[m++] = blocks[j];
    }
    if (m == 0) continue;
    Vec mu[kChunk];
    Mat v[kChunk];
    jacobi_eigen_batch<N>(in, mu, v, m);
    for (int e = 0; e < m; ++e) {
      Mat& a = blocks[index[e]];
      for (int i = 0; i < N; ++i)
        if (mu[e][i] < 0.0) a.noalias() -= (mu[e][i] * v[e].col(i)) * v[e].col(i).transpose();
      // Exactly symmetric (the rank-one updates are, up to the order of products).
      a = (0.5 * (a + a.transpose())).eval();
    }
  }
}

/// One matrix: project_to_psd_batch with a batch of one.
template <int N>
void project_to_psd(Eigen::Matrix<double, N, N>& a) {
  project_to_psd_batch<N>(&a, 1);
}

namespace detail {
struct ThreePointBasis {
  Eigen::Matrix<double, 6, 9> D = Eigen::Matrix<double, 6, 9>::Zero();
  Eigen::Matrix<double, 9, 6> Q = Eigen::Matrix<double, 9, 6>::Zero();
  Eigen::Matrix<double, 6, 6> K;
  ThreePointBasis() {
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
inline const ThreePointBasis& three_point_basis() {
  static const ThreePointBasis basis;
  return basis;
}
}  // namespace detail

/// S = Kᵀ G K: the block in the translation-free basis (see three_point_block).
inline Eigen::Matrix<double, 6, 6> three_point_reduce(const Eigen::Matrix<double, 6, 6>& g) {
  const detail::ThreePointBasis& basis = detail::three_point_basis();
  return basis.K.transpose() * g * basis.K;
}

/// Q S Qᵀ: a block in the translation-free basis back in (a, b, c) (see three_point_block).
inline Eigen::Matrix<double, 9, 9> three_point_expand(const Eigen::Matrix<double, 6, 6>& s) {
  const detail::ThreePointBasis& basis = detail::three_point_basis();
  Eigen::Matrix<double, 9, 9> h;
  h.noalias() = basis.Q * s * basis.Q.transpose();
  return h;
}

/// The Hessian block of a function of three points a, b, c ∈ R³ that depends on their steps
/// u = b − a and w = c − b only (a turn at b): H = Dᵀ G D (9 × 9, rows a, b, c by x, y, z), with G
/// its 6 × 6 Hessian in (u, w) and D = [−I I 0; 0 −I I]; with project, its PSD projection P(H).
///
/// H vanishes on the translations (t, t, t), so with Q (9 × 6) an orthonormal basis of their
/// complement, H = Q S Qᵀ with S = Kᵀ G K, K = D Q, and P(H) = Q P(S) Qᵀ (Q has orthonormal
/// columns): the same projection from a 6 × 6 eigen-problem instead of a 9 × 9 one. Per
/// coordinate Q is the Helmert basis (−1, 1, 0)/√2, (−1, −1, 2)/√6 of the plane orthogonal to
/// (1, 1, 1). With project, the batch form is three_point_reduce, project_to_psd_batch on the
/// S's, three_point_expand.
inline Eigen::Matrix<double, 9, 9> three_point_block(const Eigen::Matrix<double, 6, 6>& g,
                                                     bool project) {
  if (project) {
    Eigen::Matrix<double, 6, 6> s = three_point_reduce(g);
    project_to_psd(s);
    return three_point_expand(s);
  }
  const detail::ThreePointBasis& basis = detail::three_point_basis();
  Eigen::Matrix<double, 9, 9> h;
  h.noalias() = basis.D.transpose() * g * basis.D;
  return h;
}

}  // namespace ridgeline::planning
