#include "core/sim/sparse_cholesky.h"

#include <omp.h>

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <utility>
#include <vector>

#include "core/util/private_rand.h"
#include "core/util/serial_blas.h"

// BLAS/LAPACK (OpenBLAS on Debian) for the dense separator block. The trailing lengths are gfortran's
// hidden CHARACTER lengths; C implementations ignore them.
extern "C" {
void dsyrk_(const char* uplo, const char* trans, const int* n, const int* k, const double* alpha, const double* a,
            const int* lda, const double* beta, double* c, const int* ldc, size_t, size_t);
void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info, size_t);
}

namespace kgd {
namespace {

using SpMat = Eigen::SparseMatrix<double>;

// Below this many unknowns a factorization takes a few milliseconds and splitting it does not pay.
constexpr int kMinSplitUnknowns = 9000;
// Keep a split only when its estimated critical path is below this fraction of the whole factorization.
constexpr double kSplitWorthIt = 0.85;

// Our factors have thousands of small supernodes (fronts of tens to a few hundred rows). On them BLAS
// threading costs more than it gives (UseSerialBlas), and CHOLMOD 3.0 (SuiteSparse 5.12) opens an
// OpenMP team of a compiled-in 4 threads for every supernode it zeroes, whatever OMP_NUM_THREADS says.
// On 2 cores the two fight: threaded, a factorization of the 7k-vertex sleeve spends half its time in
// the kernel and takes twice as long as serial. Serial BLAS also makes results independent of the
// machine's core count. The two cores go to the two domains.

// Limits OpenMP's active nesting while alive: 0 runs CHOLMOD's OpenMP regions on the calling thread;
// 1 lets our two-domain region run on two threads while CHOLMOD's regions inside it stay serial. The
// ICV is process-wide in libgomp, so it is restored to the value seen at first use rather than to what
// this scope found (concurrent solves in one worker could otherwise leave it lowered for good).
// Threads for the two domains: two unless OpenMP is limited to one.
int DomainThreads() { return std::min(2, omp_get_max_threads()); }

class ActiveLevelsScope {
 public:
  explicit ActiveLevelsScope(int levels) {
    static const int initial = omp_get_max_active_levels();
    restore_ = initial;
    omp_set_max_active_levels(levels);
  }
  ~ActiveLevelsScope() { omp_set_max_active_levels(restore_); }
  ActiveLevelsScope(const ActiveLevelsScope&) = delete;
  ActiveLevelsScope& operator=(const ActiveLevelsScope&) = delete;

 private:
  int restore_ = 1;
};

// Relaxed amalgamation twice CHOLMOD's default: supernodes of up to 8 / 32 / 96 columns may merge when
// the merge adds explicit zeros (at most 80 % / 10 % / 5 %, CHOLMOD's zrelax defaults). Our supernodes
// are small, and fewer, larger ones spend more of the factorization in dense kernels: on the arm
// flexion sleeve a factorization takes 8 % less time, whole or split (docs/PERFORMANCE.md).
void UseLargerSupernodes(cholmod_common* c) {
  c->nrelax[0] = 8;
  c->nrelax[1] = 32;
  c->nrelax[2] = 96;
}

// A CHOLMOD view of a matrix holding the upper triangle of a symmetric one (CHOLMOD's analysis and
// factorization only read it).
cholmod_sparse ViewUpper(const SpMat& m) {
  cholmod_sparse v = Eigen::viewAsCholmod(m);
  v.stype = 1;
  return v;
}

// The upper triangle of H(order, order), with each entry's index into H's values (so that a numeric
// factorization only gathers values into a fixed pattern).
SpMat SubmatrixPattern(const SpMat& upper, const std::vector<int>& order, std::vector<int>* source) {
  std::vector<int> pos(upper.rows(), -1);
  for (size_t i = 0; i < order.size(); ++i) pos[order[i]] = static_cast<int>(i);
  std::vector<Eigen::Triplet<double>> entries;
  for (int j = 0; j < upper.outerSize(); ++j) {
    if (pos[j] < 0) continue;
    for (int e = upper.outerIndexPtr()[j]; e < upper.outerIndexPtr()[j + 1]; ++e) {
      const int i = upper.innerIndexPtr()[e];
      if (pos[i] < 0) continue;
      // Indices into H's values are exact in a double up to 2^53.
      entries.emplace_back(std::min(pos[i], pos[j]), std::max(pos[i], pos[j]), static_cast<double>(e));
    }
  }
  SpMat sub(static_cast<Eigen::Index>(order.size()), static_cast<Eigen::Index>(order.size()));
  sub.setFromTriplets(entries.begin(), entries.end());
  sub.makeCompressed();
  if (source) {
    source->resize(sub.nonZeros());
    for (Eigen::Index e = 0; e < sub.nonZeros(); ++e) (*source)[e] = static_cast<int>(sub.valuePtr()[e]);
  }
  return sub;
}

// One domain's bordered block [H_kk H_kS; H_Sk H_SS]: the domain's unknowns in METIS order, then the
// separator's.
struct Domain {
  Domain() {
    cholmod_start(&common);
    common.print = 0;
  }
  ~Domain() {
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  Domain(const Domain&) = delete;
  Domain& operator=(const Domain&) = delete;

  std::vector<int> order;  // global unknowns: the domain's, then the separator's
  int n_domain = 0;
  SpMat block;              // upper triangle of H(order, order)
  std::vector<int> source;  // block.valuePtr()[e] = H.valuePtr()[source[e]]
  mutable cholmod_common common;  // CHOLMOD's workspace, also for solves
  cholmod_factor* factor = nullptr;
  Eigen::MatrixXd trailing;  // L_SS of this block (lower triangular, separator x separator)
  double flops = 0, nonzeros = 0;
};

// Symbolic analysis of a domain's block: METIS on the domain (postordered), the separator last.
// Returns false when CHOLMOD fails (out of memory).
bool AnalyzeDomain(const SpMat& upper, const std::vector<int>& unknowns, const std::vector<int>& separator,
                   Domain* d) {
  SpMat inner = SubmatrixPattern(upper, unknowns, nullptr);
  cholmod_sparse view = ViewUpper(inner);
  std::vector<int> perm(unknowns.size());
  if (!cholmod_metis(&view, nullptr, 0, /*postorder=*/1, perm.data(), &d->common)) return false;
  d->order.clear();
  for (int p : perm) d->order.push_back(unknowns[p]);
  d->order.insert(d->order.end(), separator.begin(), separator.end());
  d->n_domain = static_cast<int>(unknowns.size());
  d->block = SubmatrixPattern(upper, d->order, &d->source);
  // The order is final: a postorder of the whole block could move separator columns before domain ones.
  d->common.nmethods = 1;
  d->common.method[0].ordering = CHOLMOD_NATURAL;
  d->common.postorder = 0;
  d->common.supernodal = CHOLMOD_SUPERNODAL;
  UseLargerSupernodes(&d->common);
  if (d->factor) cholmod_free_factor(&d->factor, &d->common);
  cholmod_sparse block = ViewUpper(d->block);
  d->factor = cholmod_analyze(&block, &d->common);
  if (!d->factor) return false;
  d->flops = d->common.fl;
  d->nonzeros = d->common.lnz;
  return true;
}

}  // namespace

struct SparseCholesky::Impl {
  Impl() {
    cholmod_common& c = plain.cholmod();
    c.print = 0;  // failures are reported through the return value, not stderr
    // The analysis runs once per mesh and the factorization hundreds of times, so both fill-reducing
    // orderings are tried and the sparser factor kept. CHOLMOD's default tries METIS only when AMD's
    // factor looks dense (>= 500 flops per factor entry and >= 5 times the matrix's entries); our
    // garments stay far below the first, yet METIS's nested dissection cuts the factorization's flops by
    // 38 % on the built-in arm flexion sleeve (7k vertices) and by 46 % on the slouch's shirt (17k),
    // while AMD stays better on the flat pull-test sample (docs/PERFORMANCE.md).
    // The entries are copied from CHOLMOD's default suite (1: AMD, 2: METIS) to keep their parameters.
    c.method[0] = c.method[1];
    c.method[1] = c.method[2];
    c.method[0].ordering = CHOLMOD_AMD;
    c.method[1].ordering = CHOLMOD_METIS;
    c.nmethods = 2;
    UseLargerSupernodes(&c);
    UseSerialBlas();
  }

  bool SplitFrom(const SpMat& upper);
  bool FactorDomain(Domain& d, const SpMat& upper, double shift);

  Eigen::CholmodSupernodalLLT<SpMat, Eigen::Upper> plain;
  bool analyzed = false;
  bool split = false;
  int n = 0;
  double nonzeros = 0;
  std::unique_ptr<Domain> domain[2];
  std::vector<int> separator;
  std::vector<std::pair<int, int>> separator_source;  // (index into H's values, lower-triangle position)
  Eigen::MatrixXd schur;                               // Cholesky factor (lower) of the separator's Schur complement
};

// Finds two domains and a separator whose factorizations' critical path is clearly shorter than the
// whole factorization, and analyzes them. False (no split) when none is.
bool SparseCholesky::Impl::SplitFrom(const SpMat& upper) {
  cholmod_sparse view = ViewUpper(upper);
  std::vector<int> part(n, 0);  // 0, 1: domains; 2: separator
  {
    Domain scratch;  // for its CHOLMOD workspace
    if (cholmod_bisect(&view, nullptr, 0, /*compress=*/1, part.data(), &scratch.common) <= 0 ||
        scratch.common.status != CHOLMOD_OK)
      return false;
  }
  // METIS's bisector is a small separator but often an unbalanced one (on the arm flexion sleeve it
  // left a third of the work on one side, two thirds on the other). Breadth-first levels from it into
  // the larger side are separators too, parallel to it, so moving it level by level balances the sides.
  std::vector<std::vector<int>> neighbours(n);
  for (int j = 0; j < n; ++j)
    for (SpMat::InnerIterator e(upper, j); e; ++e)
      if (e.index() != j) {
        neighbours[j].push_back(static_cast<int>(e.index()));
        neighbours[e.index()].push_back(j);
      }
  const int count0 = static_cast<int>(std::count(part.begin(), part.end(), 0));
  const int count1 = static_cast<int>(std::count(part.begin(), part.end(), 1));
  const int larger = count1 > count0 ? 1 : 0;
  std::vector<int> level(n, -1), queue;
  for (int i = 0; i < n; ++i)
    if (part[i] == 2) {
      level[i] = 0;
      queue.push_back(i);
    }
  for (size_t h = 0; h < queue.size(); ++h)
    for (int j : neighbours[queue[h]])
      if (level[j] < 0 && part[j] == larger) {
        level[j] = level[queue[h]] + 1;
        queue.push_back(j);
      }
  const int levels = 1 + *std::max_element(level.begin(), level.end());
  std::vector<int> per_level(levels, 0);
  for (int l : level)
    if (l >= 0) ++per_level[l];
  // The level that balances the unknowns on both sides; the work is then tried at it and at METIS's own.
  int balanced = 0;
  for (int smaller_side = std::min(count0, count1); balanced + 1 < levels;) {
    const int with_next = smaller_side + per_level[balanced];
    if (with_next + per_level[balanced + 1] / 2 >= n - with_next - per_level[balanced + 1]) break;
    smaller_side = with_next;
    ++balanced;
  }
  double best = std::numeric_limits<double>::infinity();
  std::vector<int> cuts = {0};
  if (balanced > 0) cuts.push_back(balanced);
  for (int cut : cuts) {
    std::vector<int> side[2], sep;
    for (int i = 0; i < n; ++i) {
      int p = part[i];
      if (level[i] >= 0) p = level[i] < cut ? 1 - larger : level[i] == cut ? 2 : larger;
      (p == 2 ? sep : side[p]).push_back(i);
    }
    if (side[0].empty() || side[1].empty() || sep.empty()) continue;
    std::unique_ptr<Domain> trial[2] = {std::make_unique<Domain>(), std::make_unique<Domain>()};
    if (!AnalyzeDomain(upper, side[0], sep, trial[0].get()) || !AnalyzeDomain(upper, side[1], sep, trial[1].get()))
      continue;
    // Critical path in flops: the larger domain, then the dense separator work (two rank updates and a
    // Cholesky factorization, about 2.3 s^3 flops, at the higher rate of dense kernels).
    const double s = static_cast<double>(sep.size());
    const double cost = std::max(trial[0]->flops, trial[1]->flops) + s * s * s;
    if (cost >= best) continue;
    best = cost;
    separator = sep;
    for (int k = 0; k < 2; ++k) domain[k] = std::move(trial[k]);
  }
  // The whole factorization in the split's order (both domains, then the separator) costs what the two
  // bordered blocks cost less one dense separator block; that is within 4 % of the whole system's own
  // analysis on our garments (arm 283 / 283 MFlop, shorts 424 / 408, slouch 893 / 890), which is
  // therefore run only when no split is kept: it took as long as the split's.
  if (!domain[0] || best >= kSplitWorthIt * (domain[0]->flops + domain[1]->flops)) {
    domain[0].reset();
    domain[1].reset();
    separator.clear();
    return false;
  }
  const int ns = static_cast<int>(separator.size());
  std::vector<int> pos(n, -1);
  for (int i = 0; i < ns; ++i) pos[separator[i]] = i;
  separator_source.clear();
  for (int j = 0; j < n; ++j) {
    if (pos[j] < 0) continue;
    for (int e = upper.outerIndexPtr()[j]; e < upper.outerIndexPtr()[j + 1]; ++e) {
      const int i = upper.innerIndexPtr()[e];
      if (pos[i] < 0) continue;
      separator_source.emplace_back(e, std::max(pos[i], pos[j]) + ns * std::min(pos[i], pos[j]));
    }
  }
  schur.resize(ns, ns);
  for (auto& d : domain) d->trailing.resize(ns, ns);
  nonzeros = domain[0]->nonzeros + domain[1]->nonzeros + 0.5 * ns * (ns + 1);
  return true;
}

bool SparseCholesky::Impl::FactorDomain(Domain& d, const SpMat& upper, double shift) {
  const double* values = upper.valuePtr();
  double* block_values = d.block.valuePtr();
  for (size_t e = 0; e < d.source.size(); ++e) block_values[e] = values[d.source[e]];
  cholmod_sparse view = ViewUpper(d.block);
  double beta[2] = {shift, 0.0};
  cholmod_factorize_p(&view, beta, nullptr, 0, d.factor, &d.common);
  if (d.common.status != CHOLMOD_OK || d.factor->minor < d.factor->n) return false;
  // L_SS: the separator's rows and columns of the supernodal factor (column-major supernodes; a
  // supernode may straddle the last domain column and the first separator column).
  d.trailing.setZero();
  const int* super = static_cast<const int*>(d.factor->super);
  const int* pi = static_cast<const int*>(d.factor->pi);
  const int* px = static_cast<const int*>(d.factor->px);
  const int* rows = static_cast<const int*>(d.factor->s);
  const double* x = static_cast<const double*>(d.factor->x);
  const int n1 = d.n_domain;
  for (size_t s = 0; s < d.factor->nsuper; ++s) {
    const int first = super[s], end = super[s + 1];
    if (end <= n1) continue;
    const int nrow = pi[s + 1] - pi[s];
    for (int j = std::max(first, n1); j < end; ++j)
      for (int r = j - first; r < nrow; ++r) d.trailing(rows[pi[s] + r] - n1, j - n1) = x[px[s] + (j - first) * nrow + r];
  }
  return true;
}

SparseCholesky::SparseCholesky() : impl_(std::make_unique<Impl>()) {}
SparseCholesky::~SparseCholesky() = default;

void SparseCholesky::Analyze(const SpMat& upper, bool allow_split) {
  // METIS (CHOLMOD's METIS ordering and bisection) reseeds libc's rand() at every call and draws from
  // it: another thread's draws in between (gRPC's, c-ares', another analysis') would make the
  // ordering, and so every result after it, differ from run to run. The analysis draws from a state of
  // its own (core/util/private_rand.h); the lock keeps METIS's other globals to one analysis at a time.
  static std::mutex metis;
  std::lock_guard<std::mutex> lock(metis);
  PrivateRand private_rand;
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  m.n = static_cast<int>(upper.rows());
  m.analyzed = true;
  m.split = allow_split && m.n >= kMinSplitUnknowns && m.SplitFrom(upper);
  if (m.split) return;
  m.plain.analyzePattern(upper);
  m.nonzeros = m.plain.cholmod().lnz;
}

bool SparseCholesky::analyzed() const { return impl_->analyzed; }

bool SparseCholesky::Factorize(const SpMat& upper, double shift) {
  Impl& m = *impl_;
  if (!m.split) {
    m.plain.setShift(shift);
    ActiveLevelsScope serial(0);
    m.plain.factorize(upper);
    return m.plain.info() == Eigen::Success;
  }
  bool ok[2] = {false, false};
  {
    const int threads = DomainThreads();
    ActiveLevelsScope levels(threads > 1 ? 1 : 0);
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int k = 0; k < 2; ++k) ok[k] = m.FactorDomain(*m.domain[k], upper, shift);
  }
  if (!ok[0] || !ok[1]) return false;
  // S = L_SS^0 L_SS^0^T + L_SS^1 L_SS^1^T - (H_SS + shift I), lower triangle.
  const int ns = static_cast<int>(m.separator.size());
  m.schur.setZero();
  const double* values = upper.valuePtr();
  for (const auto& [e, at] : m.separator_source) m.schur.data()[at] = -values[e];
  m.schur.diagonal().array() -= shift;
  const double one = 1.0;
  for (auto& d : m.domain) dsyrk_("L", "N", &ns, &ns, &one, d->trailing.data(), &ns, &one, m.schur.data(), &ns, 1, 1);
  int info = 0;
  dpotrf_("L", &ns, m.schur.data(), &ns, &info, 1);
  return info == 0;
}

Eigen::VectorXd SparseCholesky::Solve(const Eigen::VectorXd& b) const {
  const Impl& m = *impl_;
  if (!m.split) return m.plain.solve(b);
  const int ns = static_cast<int>(m.separator.size());
  Eigen::VectorXd x(m.n);
  Eigen::VectorXd z[2];
  // cholmod_solve into a fresh dense result, copied out (CHOLMOD 3 has no in-place solve).
  auto triangular_solve = [](const Domain& d, int system, Eigen::VectorXd* v) {
    cholmod_dense rhs = Eigen::viewAsCholmod(*v);
    cholmod_dense* y = cholmod_solve(system, d.factor, &rhs, &d.common);
    if (!y) {  // out of memory: a non-finite step, which Newton rejects
      v->setConstant(std::numeric_limits<double>::quiet_NaN());
      return;
    }
    *v = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(y->x), v->size());
    cholmod_free_dense(&y, &d.common);
  };
  const int threads = DomainThreads();
  ActiveLevelsScope levels(threads > 1 ? 1 : 0);
  // Forward: z = L^-1 [b_D; 0]. Its separator part gives H_Sk H_kk^-1 b_k = -L_SS z_S.
#pragma omp parallel for num_threads(threads) schedule(static, 1)
  for (int k = 0; k < 2; ++k) {
    const Domain& d = *m.domain[k];
    z[k] = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.order.size()));
    for (int i = 0; i < d.n_domain; ++i) z[k][i] = b[d.order[i]];
    triangular_solve(d, CHOLMOD_L, &z[k]);
  }
  Eigen::VectorXd x_separator(ns);
  for (int i = 0; i < ns; ++i) x_separator[i] = b[m.separator[i]];
  for (int k = 0; k < 2; ++k)
    x_separator += m.domain[k]->trailing.triangularView<Eigen::Lower>() * z[k].tail(ns);
  m.schur.triangularView<Eigen::Lower>().solveInPlace(x_separator);
  m.schur.triangularView<Eigen::Lower>().transpose().solveInPlace(x_separator);
  // Backward: L^T [x_k; x_S] = [z_k; L_SS^T x_S] returns x_S and gives the domain's x_k.
#pragma omp parallel for num_threads(threads) schedule(static, 1)
  for (int k = 0; k < 2; ++k) {
    const Domain& d = *m.domain[k];
    z[k].tail(ns) = d.trailing.triangularView<Eigen::Lower>().transpose() * x_separator;
    triangular_solve(d, CHOLMOD_Lt, &z[k]);
    for (int i = 0; i < d.n_domain; ++i) x[d.order[i]] = z[k][i];
  }
  for (int i = 0; i < ns; ++i) x[m.separator[i]] = x_separator[i];
  return x;
}

double SparseCholesky::factor_nonzeros() const { return impl_->nonzeros; }
const std::vector<int>& SparseCholesky::separator() const { return impl_->separator; }

}  // namespace kgd
