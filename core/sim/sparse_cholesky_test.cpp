#include "core/sim/sparse_cholesky.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Dense>
#include <atomic>
#include <cstdlib>
#include <random>
#include <thread>
#include <vector>

namespace kgd {
namespace {

using SpMat = Eigen::SparseMatrix<double>;

// A garment-like system: a tube of `around` x `along` vertices, three unknowns each, one random
// positive semi-definite 9 x 9 block per triangle plus a small diagonal; the upper triangle. Long
// tubes like the sleeve are where the two-domain split applies.
SpMat TubeSystem(int around, int along, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 3 * around * along;
  std::vector<Eigen::Triplet<double>> t;
  auto vertex = [&](int i, int j) { return (i % around) + around * j; };
  auto add_triangle = [&](int a, int b, int c) {
    Eigen::Matrix<double, 9, 9> G;
    for (int r = 0; r < 9; ++r)
      for (int q = 0; q < 9; ++q) G(r, q) = u(rng);
    const Eigen::Matrix<double, 9, 9> K = G * G.transpose();
    const int v[3] = {a, b, c};
    for (int p = 0; p < 9; ++p)
      for (int q = 0; q < 9; ++q) {
        const int row = 3 * v[p / 3] + p % 3, col = 3 * v[q / 3] + q % 3;
        if (row <= col) t.emplace_back(row, col, K(p, q));
      }
  };
  for (int j = 0; j + 1 < along; ++j)
    for (int i = 0; i < around; ++i) {
      add_triangle(vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1));
      add_triangle(vertex(i, j), vertex(i + 1, j + 1), vertex(i, j + 1));
    }
  for (int d = 0; d < n; ++d) t.emplace_back(d, d, 1e-3);
  SpMat A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

double RelativeResidual(const SpMat& upper, double shift, const Eigen::VectorXd& x, const Eigen::VectorXd& b) {
  const Eigen::VectorXd r = upper.selfadjointView<Eigen::Upper>() * x + shift * x - b;
  return r.norm() / b.norm();
}

// An analysis, a factorization (shift 1e-2) and a solve of A x = b, from scratch: the separator and x
// (empty when the factorization fails).
void SolveAfresh(const SpMat& A, const Eigen::VectorXd& b, bool allow_split, std::vector<int>* separator, Eigen::VectorXd* x) {
  SparseCholesky c;
  c.Analyze(A, allow_split);
  *separator = c.separator();
  *x = c.Factorize(A, 1e-2) ? c.Solve(b) : Eigen::VectorXd();
}

double& Diagonal(SpMat& upper, int i) { return upper.coeffRef(i, i); }

TEST(SparseCholesky, SmallSystemsAreFactoredWhole) {
  const SpMat A = TubeSystem(12, 20, 1);  // 720 unknowns
  SparseCholesky c;
  c.Analyze(A);
  EXPECT_TRUE(c.separator().empty());
  ASSERT_TRUE(c.Factorize(A, 0.0));
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), -1.0, 2.0);
  EXPECT_LT(RelativeResidual(A, 0.0, c.Solve(b), b), 1e-10);
}

TEST(SparseCholesky, TwoDomainsSolveLikeTheWholeFactorization) {
  const SpMat A = TubeSystem(40, 100, 2);  // 12,000 unknowns
  SparseCholesky split, whole;
  split.Analyze(A);
  whole.Analyze(A, /*allow_split=*/false);
  ASSERT_FALSE(split.separator().empty()) << "a long tube should split";
  EXPECT_TRUE(whole.separator().empty());
  // The separator is a ring of the tube, not a slab of it.
  EXPECT_LE(split.separator().size(), 3u * 40u * 3u);
  std::printf("separator %zu unknowns of %ld; factor entries split %.0f, whole %.0f\n", split.separator().size(),
              static_cast<long>(A.rows()), split.factor_nonzeros(), whole.factor_nonzeros());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::VectorXd b(A.rows());
  for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = normal(rng);
  for (double shift : {0.0, 0.5, 100.0}) {
    ASSERT_TRUE(split.Factorize(A, shift));
    ASSERT_TRUE(whole.Factorize(A, shift));
    const Eigen::VectorXd xs = split.Solve(b), xw = whole.Solve(b);
    EXPECT_LT(RelativeResidual(A, shift, xs, b), 1e-10) << "shift " << shift;
    EXPECT_LT((xs - xw).norm(), 1e-8 * xw.norm()) << "shift " << shift;
  }
}

TEST(SparseCholesky, ReportsAnIndefiniteMatrixWhereverItsNegativePivotIs) {
  const SpMat A = TubeSystem(40, 100, 4);
  SparseCholesky c;
  c.Analyze(A);
  ASSERT_FALSE(c.separator().empty());
  std::vector<char> in_separator(A.rows(), 0);
  for (int i : c.separator()) in_separator[i] = 1;
  int domain_unknown = 0;
  while (in_separator[domain_unknown]) ++domain_unknown;
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(A.rows());
  // A negative diagonal in a domain fails that domain's factorization; one on the separator only the
  // dense Schur complement's. After either, a definite matrix factors and solves again.
  for (int i : {domain_unknown, c.separator()[c.separator().size() / 2], static_cast<int>(A.rows()) - 1}) {
    SpMat bad = A;
    Diagonal(bad, i) = -1e3;
    EXPECT_FALSE(c.Factorize(bad, 0.0)) << "unknown " << i;
    ASSERT_TRUE(c.Factorize(A, 0.0));
    EXPECT_LT(RelativeResidual(A, 0.0, c.Solve(b), b), 1e-10);
  }
}

TEST(SparseCholesky, ResultsDoNotDependOnTheNumberOfThreads) {
  const SpMat A = TubeSystem(40, 100, 5);
  SparseCholesky c;
  c.Analyze(A);
  ASSERT_FALSE(c.separator().empty());
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), 1.0, -3.0);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  ASSERT_TRUE(c.Factorize(A, 1e-2));
  const Eigen::VectorXd serial = c.Solve(b);
  omp_set_num_threads(2);
  ASSERT_TRUE(c.Factorize(A, 1e-2));
  const Eigen::VectorXd parallel = c.Solve(b);
  omp_set_num_threads(threads);
  EXPECT_EQ((serial - parallel).cwiseAbs().maxCoeff(), 0.0);
}

// METIS draws from one process-wide random state; analyses running at once on two threads (a worker
// with two jobs) must still order the unknowns as an analysis alone does.
TEST(SparseCholesky, AnalysesAtOnceOrderAsOneAlone) {
  const SpMat A = TubeSystem(40, 100, 6);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), -2.0, 1.0);
  auto solve = [&](bool allow_split, std::vector<int>* separator, Eigen::VectorXd* x) { SolveAfresh(A, b, allow_split, separator, x); };
  for (bool allow_split : {true, false}) {
    std::vector<int> separator;
    Eigen::VectorXd alone;
    solve(allow_split, &separator, &alone);
    ASSERT_EQ(alone.size(), A.rows());
    std::vector<int> seps[2][4];
    Eigen::VectorXd xs[2][4];
    std::thread others[2];
    for (int t = 0; t < 2; ++t)
      others[t] = std::thread([&, t] {
        for (int k = 0; k < 4; ++k) solve(allow_split, &seps[t][k], &xs[t][k]);
      });
    for (auto& t : others) t.join();
    for (int t = 0; t < 2; ++t)
      for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(seps[t][k], separator) << "thread " << t << ", analysis " << k << ", split " << allow_split;
        ASSERT_EQ(xs[t][k].size(), A.rows());
        EXPECT_EQ((xs[t][k] - alone).cwiseAbs().maxCoeff(), 0.0) << "thread " << t << ", analysis " << k << ", split " << allow_split;
      }
  }
}

// METIS as Debian builds it draws from libc's rand(), which other libraries of a service process call
// from their own threads (gRPC and c-ares do): an analysis while another thread draws must still order
// the unknowns as one alone does, or a served job parts from the same job run locally.
TEST(SparseCholesky, AnAnalysisWhileAnotherThreadCallsRandOrdersAsOneAlone) {
  const SpMat A = TubeSystem(40, 100, 7);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), 1.0, -2.0);
  auto solve = [&](bool allow_split, std::vector<int>* separator, Eigen::VectorXd* x) { SolveAfresh(A, b, allow_split, separator, x); };
  for (bool allow_split : {true, false}) {
    std::vector<int> separator;
    Eigen::VectorXd alone;
    solve(allow_split, &separator, &alone);
    ASSERT_EQ(alone.size(), A.rows());
    std::atomic<bool> stop{false};
    std::atomic<long> draws{0};
    std::thread drawer([&] {
      while (!stop) {
        (void)std::rand();
        ++draws;
      }
    });
    for (int k = 0; k < 3; ++k) {
      std::vector<int> s;
      Eigen::VectorXd x;
      solve(allow_split, &s, &x);
      EXPECT_EQ(s, separator) << "analysis " << k << ", split " << allow_split;
      ASSERT_EQ(x.size(), A.rows());
      EXPECT_EQ((x - alone).cwiseAbs().maxCoeff(), 0.0) << "analysis " << k << ", split " << allow_split;
    }
    stop = true;
    drawer.join();
    EXPECT_GT(draws.load(), 0) << "the other thread drew while the analyses ran";
  }
}

}  // namespace
}  // namespace kgd
