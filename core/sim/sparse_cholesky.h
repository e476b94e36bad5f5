// Sparse Cholesky factorization of the Newton systems H + delta I (CHOLMOD, supernodal), on two cores.
//
// CHOLMOD 3 (SuiteSparse 5.12, Debian 12) factorizes serially: its only parallelism is BLAS inside
// each supernode, and our garments' supernodes are too small for that to pay (docs/PERFORMANCE.md).
// On large systems this class therefore splits the unknowns into two domains D0, D1 and a separator S
// (no entry of H couples D0 with D1) and factors the two bordered blocks
//   B_k = [H_kk  H_kS; H_Sk  H_SS] + delta I,   k = 0, 1,
// independently, one per thread. The trailing block of B_k's factor gives the Schur complement part
// of its domain, L_SS^k L_SS^k^T = H_SS + delta I - H_Sk (H_kk + delta I)^-1 H_kS, so the separator's
// Schur complement is
//   S = L_SS^0 L_SS^0^T + L_SS^1 L_SS^1^T - (H_SS + delta I),
// factored densely (LAPACK). Solves run the two domains' triangular solves in parallel as well.
// The separator is METIS's bisector moved, along breadth-first levels, towards the larger side until
// the domains' factorization work balances; the split is kept only when the estimated critical path
// (larger domain plus the dense separator work) is below 0.85 of the whole factorization's work (both
// domains' blocks together). The whole system is analyzed only when no split is kept.
// Below ~9k unknowns, or when no split pays, it is a plain CHOLMOD factorization.
//
// Results do not depend on the number of threads: the same operations run whether the two domains
// go to two threads or one after the other. They differ from the plain factorization's by round-off.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

namespace kgd {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Symbolic analysis of the pattern of `upper`: the upper triangle (diagonal included) of a symmetric
  // n x n matrix, compressed. Once per pattern; Factorize requires a matrix with this same pattern.
  // `allow_split` false forces the plain factorization (tests compare the two).
  void Analyze(const Eigen::SparseMatrix<double>& upper, bool allow_split = true);
  bool analyzed() const;

  // Numeric factorization of upper + shift I (shift >= 0, in the matrix's units). False when that
  // matrix is not positive definite; Solve then must not be called until a factorization succeeds.
  bool Factorize(const Eigen::SparseMatrix<double>& upper, double shift);

  // x = (A + shift I)^-1 b for the last successful factorization.
  Eigen::VectorXd Solve(const Eigen::VectorXd& b) const;

  // Entries of the factor (of both domains' factors and the dense separator block when split).
  double factor_nonzeros() const;
  // The separator's unknowns, ascending; empty when the factorization is not split.
  const std::vector<int>& separator() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd
