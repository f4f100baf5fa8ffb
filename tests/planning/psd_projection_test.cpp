#include "planning/psd_projection.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace ridgeline::planning {
namespace {

template <int N>
using Mat = Eigen::Matrix<double, N, N>;
template <int N>
using Vec = Eigen::Matrix<double, N, 1>;

// A random orthogonal matrix (QR of a Gaussian matrix).
template <int N>
Mat<N> random_orthogonal(std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Mat<N> g;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) g(i, j) = normal(rng);
  return Eigen::HouseholderQR<Mat<N>>(g).householderQ() * Mat<N>::Identity();
}

// Symmetric test matrices of the kinds that break eigen-solvers: dense random, low rank (PSD,
// NSD and indefinite), repeated eigenvalues (± and 0), diagonal, zero, and each scaled by
// 1e-8 … 1e8.
template <int N>
std::vector<Mat<N>> test_matrices(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Mat<N>> out;
  for (int trial = 0; trial < 40; ++trial) {
    Mat<N> a;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j <= i; ++j) a(i, j) = a(j, i) = normal(rng);
    out.push_back(a);
    for (int rank = 1; rank < N; ++rank) {
      Mat<N> b = Mat<N>::Zero();
      for (int r = 0; r < rank; ++r) {
        Vec<N> v;
        for (int i = 0; i < N; ++i) v[i] = normal(rng);
        const double sign = trial % 3 == 0 ? 1.0 : (trial % 3 == 1 ? -1.0 : (r % 2 ? 1.0 : -1.0));
        b += sign * v * v.transpose();
      }
      out.push_back(b);
    }
    // Repeated eigenvalues: −2 twice, 0 (several times), 3 twice.
    Vec<N> mu = Vec<N>::Zero();
    mu[0] = -2.0;
    if (N > 1) mu[N - 1] = 3.0;
    if (N > 2) mu[1] = -2.0;
    if (N > 3) mu[N - 2] = 3.0;
    const Mat<N> q = random_orthogonal<N>(rng);
    Mat<N> rep = q * mu.asDiagonal() * q.transpose();
    rep = (0.5 * (rep + rep.transpose())).eval();
    out.push_back(rep);
  }
  Vec<N> d;
  for (int i = 0; i < N; ++i) d[i] = i % 2 ? -1.0 - i : 1.0 + i;
  out.push_back(d.asDiagonal());
  out.push_back(Mat<N>::Zero());
  const std::size_t base = out.size();
  for (std::size_t m = 0; m < base; m += 7) {
    out.push_back(1e-8 * out[m]);
    out.push_back(1e8 * out[m]);
  }
  return out;
}

// The reference: Eigen's Householder tridiagonalization + implicit QR, negative eigenvalues
// clamped to zero.
template <int N>
Mat<N> reference_projection(const Mat<N>& a) {
  const Eigen::SelfAdjointEigenSolver<Mat<N>> eigen(a);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
         eigen.eigenvectors().transpose();
}

// Both solvers are backward stable: each decomposes a matrix within c·N·ε·‖A‖ of A, so the
// eigenvalues agree to that (Weyl), and so do the projections (the projection onto a convex set
// is 1-Lipschitz in the Frobenius norm). ε = 2.2e-16, N ≤ 9: 1e-12·‖A‖ leaves a margin of ~50.
constexpr double kRelTol = 1e-12;

template <int N>
void check_eigen(unsigned seed) {
  for (const Mat<N>& a : test_matrices<N>(seed)) {
    const double norm = a.norm();
    Vec<N> mu;
    Mat<N> v;
    const int sweeps = jacobi_eigen<N>(a, &mu, &v);
    EXPECT_LT(sweeps, 30) << "no convergence:\n" << a;
    EXPECT_LE((v.transpose() * v - Mat<N>::Identity()).norm(), 1e-13) << a;
    EXPECT_LE((v * mu.asDiagonal() * v.transpose() - a).norm(), kRelTol * norm) << a;
    const Eigen::SelfAdjointEigenSolver<Mat<N>> eigen(a);
    Vec<N> sorted = mu;
    std::sort(sorted.data(), sorted.data() + N);
    EXPECT_LE((sorted - eigen.eigenvalues()).cwiseAbs().maxCoeff(), kRelTol * norm) << a;
  }
}

TEST(JacobiEigen, MatchesEigenSelfAdjointSolverOnHardMatrices) {
  check_eigen<2>(1);
  check_eigen<3>(2);
  check_eigen<6>(3);
  check_eigen<9>(4);
}

template <int N>
void check_projection(unsigned seed) {
  int projected = 0;
  for (const Mat<N>& a : test_matrices<N>(seed)) {
    const double norm = std::max(a.norm(), std::numeric_limits<double>::min());
    Mat<N> p = a;
    project_to_psd(p);
    EXPECT_LE((p - reference_projection(a)).norm(), kRelTol * norm) << a;
    EXPECT_EQ(p, p.transpose());
    // PSD, idempotent, and P(A) − A ⪰ 0 (only curvature is added).
    const Eigen::SelfAdjointEigenSolver<Mat<N>> ep(p);
    EXPECT_GE(ep.eigenvalues().minCoeff(), -kRelTol * norm) << a;
    const Eigen::SelfAdjointEigenSolver<Mat<N>> added(Mat<N>(p - a));
    EXPECT_GE(added.eigenvalues().minCoeff(), -kRelTol * norm) << a;
    Mat<N> pp = p;
    project_to_psd(pp);
    EXPECT_LE((pp - p).norm(), kRelTol * norm) << a;
    if ((p - a).norm() > kRelTol * norm) ++projected;
  }
  EXPECT_GT(projected, 20) << "the matrices must exercise the projection, not only the test";
}

TEST(ProjectToPsd, MatchesClampedEigenDecomposition) {
  check_projection<2>(5);
  check_projection<3>(6);
  check_projection<6>(7);
  check_projection<9>(8);
}

// The batch interleaves the matrices rotation by rotation; each must come out bit for bit as
// alone (the NLP relies on it: its Hessian must not depend on how blocks are grouped). 150+
// matrices span several batches and chunks, with positive definite ones mixed in.
TEST(ProjectToPsd, BatchGivesExactlyTheResultsOfOneByOne) {
  std::vector<Mat<6>> blocks = test_matrices<6>(12);
  for (std::size_t m = 0; m < blocks.size(); m += 3) blocks[m] += 50.0 * Mat<6>::Identity();
  std::vector<Mat<6>> batch = blocks;
  project_to_psd_batch<6>(batch.data(), static_cast<int>(batch.size()));
  int changed = 0;
  for (std::size_t m = 0; m < blocks.size(); ++m) {
    Mat<6> one = blocks[m];
    project_to_psd(one);
    EXPECT_EQ(batch[m], one) << "block " << m;
    if (batch[m] != blocks[m]) ++changed;
  }
  EXPECT_GT(changed, 50);
  EXPECT_LT(changed, static_cast<int>(blocks.size()));
  std::vector<Vec<6>> mu(blocks.size());
  std::vector<Mat<6>> v(blocks.size());
  jacobi_eigen_batch<6>(blocks.data(), mu.data(), v.data(), static_cast<int>(blocks.size()));
  for (std::size_t m = 0; m < blocks.size(); ++m) {
    Vec<6> mu1;
    Mat<6> v1;
    jacobi_eigen<6>(blocks[m], &mu1, &v1);
    EXPECT_EQ(mu[m], mu1);
    EXPECT_EQ(v[m], v1);
  }
}

TEST(ProjectToPsd, PositiveDefiniteMatricesStayExactlyAsTheyAre) {
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Mat<6> b;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) b(i, j) = normal(rng);
    const Mat<6> a = b * b.transpose() + 1e-3 * Mat<6>::Identity();
    Mat<6> p = a;
    project_to_psd(p);
    EXPECT_EQ(p, a);
  }
}

TEST(ProjectToPsd, NanInputTerminatesAndStaysNan) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int where = 0; where < 2; ++where) {
    Mat<6> a = -Mat<6>::Identity();
    if (where == 0) {
      a(2, 2) = nan;
    } else {
      a(4, 1) = a(1, 4) = nan;
    }
    Vec<6> mu;
    Mat<6> v;
    EXPECT_LE(jacobi_eigen<6>(a, &mu, &v), 30);
    project_to_psd(a);
    EXPECT_TRUE(a.hasNaN()) << "a NaN block must not come back finite";
  }
}

// three_point_block against an independent construction: D built entry by entry, the product
// Dᵀ G D, and the 9 × 9 projection by Eigen's solver (no reduction to 6 × 6).
TEST(ThreePointBlock, IsDtGDAndItsProjectionIsTheFullBlocksProjection) {
  Eigen::Matrix<double, 6, 9> d = Eigen::Matrix<double, 6, 9>::Zero();
  for (int c = 0; c < 3; ++c) {
    d(c, 3 + c) = 1.0;  // u = b − a
    d(c, c) = -1.0;
    d(3 + c, 6 + c) = 1.0;  // w = c − b
    d(3 + c, 3 + c) = -1.0;
  }
  int projected = 0;
  for (const Mat<6>& g : test_matrices<6>(10)) {
    const Mat<9> h = d.transpose() * g * d;
    const double norm = std::max(h.norm(), std::numeric_limits<double>::min());
    EXPECT_LE((three_point_block(g, false) - h).norm(), 1e-15 * norm);
    const Mat<9> p = three_point_block(g, true);
    EXPECT_LE((p - reference_projection<9>(h)).norm(), kRelTol * norm) << g;
    // The projection keeps the translations (t, t, t) in the null space.
    for (int c = 0; c < 3; ++c) {
      Vec<9> t = Vec<9>::Zero();
      t[c] = t[3 + c] = t[6 + c] = 1.0;
      EXPECT_LE((p * t).norm(), kRelTol * norm);
    }
    if ((p - h).norm() > kRelTol * norm) ++projected;
  }
  EXPECT_GT(projected, 20);
}

}  // namespace
}  // namespace ridgeline::planning
