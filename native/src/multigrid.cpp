// Smoothed-aggregation multigrid and BiCGSTAB for two right-hand sides; see multigrid.h.
#include "dgmesh/multigrid.h"

#include <Eigen/SparseLU>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/detail/parallel_rows.h"
#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace dgmesh {

namespace {

using detail::kParallelRows;
using detail::Vec2;

// Coarsest level: solved by a sparse LU with this many rows above kSmallChart unknowns, else
// coarsened further to at most kDenseCoarseRows rows for a dense LU (see Impl::setup).
constexpr int kCoarseRows = 4000;
constexpr int kSmallChart = 50000;
constexpr int kDenseCoarseRows = 300;
// Row blocks of the parallel multigrid smoother, fixed so that the sweep does not depend on the
// thread count. More blocks make a weaker smoother (more of each sweep is Jacobi); see
// bench/notes/unwrap.md.
constexpr int kSmootherBlocks = 2;

// Y = A X (beta = 0) or Y += A X (beta = 1) for a row-major CSR matrix and two columns.
void spmm(const SpMatR& A, const Block2& X, Block2& Y, bool add = false) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* val = A.valuePtr();
  const double* x = X.data();
  double* y = Y.data();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (int i = 0; i < n; ++i) {
    double s0 = 0, s1 = 0;
    for (int p = outer[i]; p < outer[i + 1]; ++p) {
      const double a = val[p];
      const int j = inner[p];
      s0 += a * x[2 * j], s1 += a * x[2 * j + 1];
    }
    if (add) {
      y[2 * i] += s0, y[2 * i + 1] += s1;
    } else {
      y[2 * i] = s0, y[2 * i + 1] = s1;
    }
  }
}

// R = B - A X
void residual(const SpMatR& A, const Block2& X, const Block2& B, Block2& R) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* val = A.valuePtr();
  const double* x = X.data();
  const double* b = B.data();
  double* r = R.data();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (int i = 0; i < n; ++i) {
    double s0 = b[2 * i], s1 = b[2 * i + 1];
    for (int p = outer[i]; p < outer[i + 1]; ++p) {
      const double a = val[p];
      const int j = inner[p];
      s0 -= a * x[2 * j], s1 -= a * x[2 * j + 1];
    }
    r[2 * i] = s0, r[2 * i + 1] = s1;
  }
}

// X * Y for row-major sparse matrices, by blocks of rows in parallel (Eigen's product is serial).
SpMatR par_product(const SpMatR& X, const SpMatR& Y) {
  const int n = static_cast<int>(X.rows());
#ifdef _OPENMP
  const int nt = n > kParallelRows ? omp_get_max_threads() : 1;
#else
  const int nt = 1;
#endif
  if (nt <= 1) return SpMatR(X * Y);
  std::vector<SpMatR> part(nt);
#pragma omp parallel for schedule(static, 1) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    const int lo = static_cast<int>(static_cast<long long>(n) * t / nt);
    const int hi = static_cast<int>(static_cast<long long>(n) * (t + 1) / nt);
    part[t] = X.middleRows(lo, hi - lo) * Y;
    part[t].makeCompressed();
  }
  Eigen::Index nnz = 0;
  for (const SpMatR& p : part) nnz += p.nonZeros();
  SpMatR Z(n, Y.cols());
  Z.resizeNonZeros(nnz);
  int* outer = Z.outerIndexPtr();
  int row = 0, off = 0;
  outer[0] = 0;
  for (const SpMatR& p : part) {
    std::copy(p.innerIndexPtr(), p.innerIndexPtr() + p.nonZeros(), Z.innerIndexPtr() + off);
    std::copy(p.valuePtr(), p.valuePtr() + p.nonZeros(), Z.valuePtr() + off);
    for (int i = 0; i < p.rows(); ++i) outer[row + i + 1] = off + p.outerIndexPtr()[i + 1];
    row += static_cast<int>(p.rows());
    off += static_cast<int>(p.nonZeros());
  }
  return Z;
}

// Column-wise dot products of two n x 2 blocks.
Vec2 coldot(const Block2& a, const Block2& b) {
  const int n = static_cast<int>(a.rows());
  const double* x = a.data();
  const double* y = b.data();
  const auto s = ordered_sums<2>(n, n > 4 * kParallelRows, [&](int i, std::array<double, 2>& a) {
    a[0] += x[2 * i] * y[2 * i], a[1] += x[2 * i + 1] * y[2 * i + 1];
  });
  return Vec2(s[0], s[1]);
}

// Dense LU with partial pivoting of the coarsest multigrid level (at most kDenseCoarseRows rows),
// unblocked and serial: Eigen's blocked LU forks OpenMP threads for its products even at this
// size, which costs more than the factorisation on a loaded machine.
class SmallLU {
 public:
  void factor(const SpMatR& A) {
    n_ = static_cast<int>(A.rows());
    lu_.assign(static_cast<size_t>(n_) * n_, 0.0);
    perm_.resize(n_);
    for (int i = 0; i < n_; ++i)
      for (SpMatR::InnerIterator it(A, i); it; ++it) lu_[static_cast<size_t>(i) * n_ + it.col()] = it.value();
    for (int k = 0; k < n_; ++k) {
      int p = k;
      for (int i = k + 1; i < n_; ++i)
        if (std::abs(at(i, k)) > std::abs(at(p, k))) p = i;
      perm_[k] = p;
      if (p != k)
        for (int j = 0; j < n_; ++j) std::swap(at(k, j), at(p, j));
      const double d = at(k, k);
      if (d == 0) throw SolverError("unwrap: multigrid coarse level is singular");
      const double inv = 1.0 / d;
      double* rk = &lu_[static_cast<size_t>(k) * n_];
      for (int i = k + 1; i < n_; ++i) {
        double* ri = &lu_[static_cast<size_t>(i) * n_];
        const double l = ri[k] * inv;
        ri[k] = l;
        if (l != 0)
          for (int j = k + 1; j < n_; ++j) ri[j] -= l * rk[j];
      }
    }
  }
  // X = A^-1 B for the two columns.
  void solve(const Block2& B, Block2& X) const {
    X = B;
    for (int k = 0; k < n_; ++k)
      if (perm_[k] != k) std::swap(X(k, 0), X(perm_[k], 0)), std::swap(X(k, 1), X(perm_[k], 1));
    for (int i = 1; i < n_; ++i) {
      const double* ri = &lu_[static_cast<size_t>(i) * n_];
      double s0 = X(i, 0), s1 = X(i, 1);
      for (int j = 0; j < i; ++j) s0 -= ri[j] * X(j, 0), s1 -= ri[j] * X(j, 1);
      X(i, 0) = s0, X(i, 1) = s1;
    }
    for (int i = n_ - 1; i >= 0; --i) {
      const double* ri = &lu_[static_cast<size_t>(i) * n_];
      double s0 = X(i, 0), s1 = X(i, 1);
      for (int j = i + 1; j < n_; ++j) s0 -= ri[j] * X(j, 0), s1 -= ri[j] * X(j, 1);
      X(i, 0) = s0 / ri[i], X(i, 1) = s1 / ri[i];
    }
  }

 private:
  double& at(int i, int j) { return lu_[static_cast<size_t>(i) * n_ + j]; }
  int n_ = 0;
  std::vector<double> lu_;
  std::vector<int> perm_;
};

}  // namespace

class AmgPreconditioner::Impl {
 public:
  void setup(const SpMatR& A0) {
    levels_.resize(1);
    levels_[0].A = A0;
    // Coarsen down to a level solved directly. On large charts a larger coarsest level (solved
    // by a sparse LU) costs a little more to factor but keeps the strongly anisotropic first
    // equalization steps (weights divided by stretches up to stretch_cap) at ~20 iterations
    // instead of ~40. On small and medium charts the sparse LU of that level (~800 rows at 8K
    // unknowns) cost more than the whole rest of a step, so they coarsen further, to a level
    // small enough for a dense LU (measured on lion-head: 7 instead of 5.5 iterations per step,
    // but about a quarter less CPU per step).
    const int kc = A0.rows() > kSmallChart ? kCoarseRows : kDenseCoarseRows;
    // Strength threshold of the aggregation: on charts up to kSmallAmgRows unknowns the stricter
    // 0.25 follows the equalization's anisotropy better (lion-head, 8K: 3 instead of 4 BiCGSTAB
    // iterations per step, a quarter less solve time); at 33K the usual 0.1 was slightly faster.
    const double theta = A0.rows() > kSmallAmgRows ? 0.1 : 0.25;
    while (levels_.back().A.rows() > kc && levels_.size() < 16) {
      Level& L = levels_.back();
      const SpMatR& A = L.A;
      const int n = static_cast<int>(A.rows());
      L.inv_diag.resize(n);
      for (int i = 0; i < n; ++i) {
        double d = 0;
        for (SpMatR::InnerIterator it(A, i); it; ++it)
          if (it.col() == i) d = it.value();
        L.inv_diag[i] = d != 0 ? 1.0 / d : 0.0;
      }
      int na = 0;
      const std::vector<int> agg = aggregate(A, theta, na);
      if (na >= n * 0.8 || na < 1) break;  // not coarsening: stop here
      // Smoothed prolongator P = (I - omega D^-1 A) P_tent, omega = 2/3 (rows of A are normalised),
      // built row by row: row i holds, per aggregate of i's neighbours, the sum of their entries.
      const double omega = 2.0 / 3.0;
      const int* outer = A.outerIndexPtr();
      const int* inner = A.innerIndexPtr();
      const double* val = A.valuePtr();
      std::vector<int> tcol(A.nonZeros()), count(n);
      std::vector<double> tval(A.nonZeros());
#pragma omp parallel for schedule(static) if (n > kParallelRows)
      for (int i = 0; i < n; ++i) {
        const int b = outer[i];
        int k = b;  // row i's sorted, merged entries in [b, k) (at most one per entry of A)
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const int a = agg[inner[p]];
          const double v = (inner[p] == i ? 1.0 : 0.0) - omega * L.inv_diag[i] * val[p];
          int q = b;
          while (q < k && tcol[q] < a) ++q;
          if (q < k && tcol[q] == a) {
            tval[q] += v;
            continue;
          }
          for (int r = k; r > q; --r) tcol[r] = tcol[r - 1], tval[r] = tval[r - 1];
          tcol[q] = a, tval[q] = v, ++k;
        }
        count[i] = k - b;
      }
      L.P.resize(n, na);
      int* pout = L.P.outerIndexPtr();
      pout[0] = 0;
      for (int i = 0; i < n; ++i) pout[i + 1] = pout[i] + count[i];
      L.P.resizeNonZeros(pout[n]);
      int* pin = L.P.innerIndexPtr();
      double* pval = L.P.valuePtr();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
      for (int i = 0; i < n; ++i) {
        std::copy(tcol.begin() + outer[i], tcol.begin() + outer[i] + count[i], pin + pout[i]);
        std::copy(tval.begin() + outer[i], tval.begin() + outer[i] + count[i], pval + pout[i]);
      }
      L.R = L.P.transpose();
      const SpMatR AP = par_product(A, L.P);
      Level next;
      next.A = par_product(L.R, AP).pruned(1e-14, 1.0);
      levels_.emplace_back(std::move(next));
    }
    Level& C = levels_.back();
    dense_ = C.A.rows() <= kDenseCoarseRows;
    if (dense_) {
      dlu_.factor(C.A);
    } else {
      const SpMat Ac = C.A;
      coarse_.compute(Ac);
      if (coarse_.info() != Eigen::Success) throw SolverError("unwrap: multigrid coarse solve failed");
    }
    for (Level& L : levels_) {
      const int n = static_cast<int>(L.A.rows());
      L.x.resize(n, 2), L.b.resize(n, 2), L.r.resize(n, 2), L.xo.resize(n, 2);
    }
  }

  // Keeps the aggregates, prolongators and coarse operators of the last setup() and only takes
  // the finest level's values from A0 (same sparsity pattern): the smoother sees the current
  // system, the coarse correction the one of an earlier step. Equalization changes the weights
  // gradually, so the stale coarse levels still remove the smooth error.
  bool refresh(const SpMatR& A0) {
    if (levels_.empty() || levels_[0].A.rows() != A0.rows() || levels_[0].A.nonZeros() != A0.nonZeros()) return false;
    Level& L = levels_[0];
    std::copy(A0.valuePtr(), A0.valuePtr() + A0.nonZeros(), L.A.valuePtr());
    if (levels_.size() == 1) return false;  // the finest level is the coarse direct solve
    const int n = static_cast<int>(L.A.rows());
    for (int i = 0; i < n; ++i) {
      double d = 0;
      for (SpMatR::InnerIterator it(L.A, i); it; ++it)
        if (it.col() == i) d = it.value();
      L.inv_diag[i] = d != 0 ? 1.0 / d : 0.0;
    }
    return true;
  }

  // One V-cycle for A X = B from X = 0.
  void apply(const Block2& b, Block2& x) {
    levels_[0].b = b;
    cycle(0);
    x = levels_[0].x;
  }
  int n_levels() const { return static_cast<int>(levels_.size()); }

 private:
  struct Level {
    SpMatR A, P, R;
    VecXd inv_diag;
    Block2 x, b, r, xo;
  };

  // Aggregation of smoothed aggregation (phases 1 and 2 of Vanek et al.): strong connections are
  // |a_ij| >= theta max_k |a_ik|. Returns the aggregate of every node.
  static std::vector<int> aggregate(const SpMatR& A, double theta, int& na) {
    const int n = static_cast<int>(A.rows());
    std::vector<int> agg(n, -1);
    na = 0;
    std::vector<double> rmax(n, 0.0);
    for (int i = 0; i < n; ++i)
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (it.col() != i) rmax[i] = std::max(rmax[i], std::abs(it.value()));
    auto strong = [&](int i, const SpMatR::InnerIterator& it) {
      return it.col() != i && std::abs(it.value()) >= theta * rmax[i];
    };
    // Phase 1: a node whose strong neighbours are all free starts an aggregate with them.
    for (int i = 0; i < n; ++i) {
      if (agg[i] >= 0) continue;
      bool free = true;
      for (SpMatR::InnerIterator it(A, i); it && free; ++it)
        if (strong(i, it) && agg[it.col()] >= 0) free = false;
      if (!free) continue;
      agg[i] = na;
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (strong(i, it)) agg[it.col()] = na;
      ++na;
    }
    // Phase 2: the rest join the aggregate of their strongest aggregated neighbour.
    std::vector<int> agg2 = agg;
    for (int i = 0; i < n; ++i) {
      if (agg[i] >= 0) continue;
      double best = -1;
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (it.col() != i && agg[it.col()] >= 0 && std::abs(it.value()) > best)
          best = std::abs(it.value()), agg2[i] = agg[it.col()];
      if (agg2[i] < 0) agg2[i] = na++;
    }
    return agg2;
  }

  // Hybrid Gauss-Seidel sweep (forward or backward) on both columns: Gauss-Seidel inside each
  // block of rows, Jacobi across blocks (values of other blocks are read from the copy
  // xo), so the sweep runs in parallel without data races.
  static void gauss_seidel(Level& L, bool forward) {
    const int n = static_cast<int>(L.A.rows());
    const int* outer = L.A.outerIndexPtr();
    const int* inner = L.A.innerIndexPtr();
    const double* val = L.A.valuePtr();
    const double* b = L.b.data();
    double* x = L.x.data();
    const bool par = n > kParallelRows;
    if (!par) {
      // Serial sweep: x_i += (b_i - A_i x) / a_ii over the whole row (diagonal included), which
      // equals the Gauss-Seidel update without a branch per entry.
      const double* dinv = L.inv_diag.data();
      for (int k = 0; k < n; ++k) {
        const int i = forward ? k : n - 1 - k;
        double s0 = b[2 * i], s1 = b[2 * i + 1];
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const double a = val[p];
          const int j = inner[p];
          s0 -= a * x[2 * j], s1 -= a * x[2 * j + 1];
        }
        x[2 * i] += s0 * dinv[i], x[2 * i + 1] += s1 * dinv[i];
      }
      return;
    }
    L.xo = L.x;
    const double* xo = L.xo.data();
    // A fixed number of row blocks, not one per thread: the sweep (Gauss-Seidel inside a block,
    // Jacobi across blocks) then does not depend on the thread count.
#pragma omp parallel for schedule(static) if (par)
    for (int blk = 0; blk < kSmootherBlocks; ++blk) {
      const int lo = static_cast<int>(static_cast<long long>(n) * blk / kSmootherBlocks);
      const int hi = static_cast<int>(static_cast<long long>(n) * (blk + 1) / kSmootherBlocks);
      for (int k = lo; k < hi; ++k) {
        const int i = forward ? k : lo + hi - 1 - k;
        double s0 = b[2 * i], s1 = b[2 * i + 1];
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const int j = inner[p];
          if (j == i) continue;
          const double* xj = (j >= lo && j < hi) ? x : xo;
          s0 -= val[p] * xj[2 * j], s1 -= val[p] * xj[2 * j + 1];
        }
        x[2 * i] = s0 * L.inv_diag[i], x[2 * i + 1] = s1 * L.inv_diag[i];
      }
    }
  }

  void cycle(size_t l) {
    Level& L = levels_[l];
    if (l + 1 == levels_.size()) {
      if (dense_) {
        dlu_.solve(L.b, L.x);
        return;
      }
      const Eigen::MatrixXd bc = L.b;
      const Eigen::MatrixXd xc = coarse_.solve(bc);
      L.x = xc;
      return;
    }
    L.x.setZero();
    gauss_seidel(L, true);
    residual(L.A, L.x, L.b, L.r);
    Level& C = levels_[l + 1];
    spmm(L.R, L.r, C.b);
    cycle(l + 1);
    spmm(L.P, C.x, L.x, true);
    gauss_seidel(L, false);
  }

  std::vector<Level> levels_;
  Eigen::SparseLU<SpMat, Eigen::COLAMDOrdering<int>> coarse_;
  bool dense_ = false;
  SmallLU dlu_;
};

AmgPreconditioner::AmgPreconditioner() : impl_(std::make_unique<Impl>()) {}
AmgPreconditioner::~AmgPreconditioner() = default;
AmgPreconditioner::AmgPreconditioner(AmgPreconditioner&&) noexcept = default;
AmgPreconditioner& AmgPreconditioner::operator=(AmgPreconditioner&&) noexcept = default;
void AmgPreconditioner::setup(const SpMatR& A) { impl_->setup(A); }
bool AmgPreconditioner::refresh(const SpMatR& A) { return impl_->refresh(A); }
void AmgPreconditioner::apply(const Block2& B, Block2& X) { impl_->apply(B, X); }

int bicgstab_amg(const SpMatR& A, AmgPreconditioner& M, const Block2& B, Block2& X, double tol, int max_it) {
  const int n = static_cast<int>(A.rows());
  const Vec2 bnorm = coldot(B, B).cwiseSqrt();
  Block2 r(n, 2), r0, p = Block2::Zero(n, 2), v = Block2::Zero(n, 2), y(n, 2), z(n, 2), s(n, 2), t(n, 2);
  residual(A, X, B, r);
  bool active[2];
  const Vec2 rn = coldot(r, r).cwiseSqrt();
  for (int c = 0; c < 2; ++c) {
    if (bnorm[c] == 0) X.col(c).setZero();
    active[c] = bnorm[c] > 0 && rn[c] > tol * bnorm[c];
    if (!active[c]) r.col(c).setZero();
  }
  if (!active[0] && !active[1]) return 0;
  r0 = r;
  Vec2 rho(1, 1), alpha(1, 1), omega(1, 1);
  for (int it = 1; it <= max_it; ++it) {
    const Vec2 rho1 = coldot(r0, r);
    Vec2 beta;
    for (int c = 0; c < 2; ++c) {
      if (active[c] && std::abs(rho1[c]) < 1e-300) return -1;
      beta[c] = active[c] ? (rho1[c] / rho[c]) * (alpha[c] / omega[c]) : 0.0;
    }
    // p = r + beta (p - omega v)
#pragma omp parallel for schedule(static) if (n > 4 * kParallelRows)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) p(i, c) = r(i, c) + beta[c] * (p(i, c) - omega[c] * v(i, c));
    M.apply(p, y);
    spmm(A, y, v);
    const Vec2 r0v = coldot(r0, v);
    for (int c = 0; c < 2; ++c) alpha[c] = active[c] ? rho1[c] / r0v[c] : 0.0;
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) s(i, c) = r(i, c) - alpha[c] * v(i, c);
    const Vec2 sn = coldot(s, s).cwiseSqrt();
    for (int c = 0; c < 2; ++c)
      if (active[c] && sn[c] <= tol * bnorm[c]) {
        X.col(c) += alpha[c] * y.col(c);
        active[c] = false;
        alpha[c] = 0;
        s.col(c).setZero();
      }
    if (!active[0] && !active[1]) return it;
    M.apply(s, z);
    spmm(A, z, t);
    const Vec2 ts = coldot(t, s), tt = coldot(t, t);
    for (int c = 0; c < 2; ++c) omega[c] = active[c] ? ts[c] / tt[c] : 0.0;
#pragma omp parallel for schedule(static) if (n > 4 * kParallelRows)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) {
        X(i, c) += alpha[c] * y(i, c) + omega[c] * z(i, c);
        r(i, c) = s(i, c) - omega[c] * t(i, c);
      }
    const Vec2 rn2 = coldot(r, r).cwiseSqrt();
    for (int c = 0; c < 2; ++c) {
      if (!active[c]) continue;
      if (!std::isfinite(omega[c]) || omega[c] == 0) return -1;
      if (rn2[c] <= tol * bnorm[c]) active[c] = false, r.col(c).setZero();
    }
    if (!active[0] && !active[1]) return it;
    rho = rho1;
  }
  return -1;
}

}  // namespace dgmesh
