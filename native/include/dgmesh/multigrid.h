/// \file
/// Smoothed-aggregation algebraic multigrid (Vanek, Mandel, Brezina 1996) as the preconditioner of
/// BiCGSTAB (van der Vorst 1992), for sparse systems A X = B with two right-hand sides solved
/// together: every sparse sweep reads A once for both columns (the solves are memory-bound). Made
/// for the systems of unwrap's eq. 5.3 (thesis 5.2: convex-combination weights, M-matrices on a
/// planar mesh graph), where a V-cycle costs a few sparse products and reduces the error by a
/// constant factor, so a solve is O(n) instead of the O(n^1.5), BLAS-bound work of a sparse LU.
#pragma once
#include <memory>

#include "dgmesh/types.h"

namespace dgmesh {

/// Two columns (u and v, or two right-hand sides), row-major so that a row's pair is contiguous.
using Block2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

/// Up to this many unknowns the aggregation uses the stricter strength threshold 0.25 (above: 0.1);
/// unwrap also keeps a hierarchy over several solves up to this size.
constexpr int kSmallAmgRows = 20000;

/// The multigrid hierarchy of a square sparse matrix with a non-zero diagonal: aggregates along the
/// strong connections (|a_ij| >= theta max_k |a_ik|), smoothed prolongators, Galerkin coarse
/// operators, a block Gauss-Seidel smoother (a fixed number of row blocks, so the result does not
/// depend on the thread count) and a direct solve of the coarsest level (dense LU up to 300 rows on
/// charts up to 50000 unknowns, else a sparse LU of about 4000 rows).
class AmgPreconditioner {
 public:
  AmgPreconditioner();
  ~AmgPreconditioner();
  AmgPreconditioner(AmgPreconditioner&&) noexcept;
  AmgPreconditioner& operator=(AmgPreconditioner&&) noexcept;

  /// Builds the hierarchy for A. Throws SolverError when the coarsest level is singular.
  void setup(const SpMatR& A);
  /// Keeps the aggregates, prolongators and coarse operators of the last setup() and only takes the
  /// finest level's values from A (same size and number of non-zeros): the smoother sees the current
  /// system, the coarse correction an earlier one, which still removes the smooth error when the
  /// values change gradually. Returns false (nothing to refresh: call setup) without a hierarchy, for
  /// another pattern, or when the finest level is the coarsest.
  bool refresh(const SpMatR& A);
  /// X = M^-1 B: one V-cycle for A X = B from X = 0.
  void apply(const Block2& B, Block2& X);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// Right-preconditioned BiCGSTAB on A X = B for both columns at once, each with its own scalars,
/// from the initial guess in X, preconditioned by M (set up for A). A column stops when its relative
/// residual |B - A X| / |B| reaches tol (a zero column of B gives a zero column of X). Returns the
/// iterations, or -1 if a column did not converge within max_it or broke down.
int bicgstab_amg(const SpMatR& A, AmgPreconditioner& M, const Block2& B, Block2& X, double tol, int max_it);

}  // namespace dgmesh
