// Factor once, solve many: the sparse direct solvers the algorithms share.
#pragma once
#include <memory>

#include "dgmesh/types.h"

namespace dgmesh {

class SparseSolver {
 public:
  enum class Kind {
    Cholesky,  // symmetric positive (semi-)definite: LDL^T (Eigen SimplicialLDLT)
    LU,        // general square: sparse LU (Eigen SparseLU, COLAMD ordering)
    Umfpack,   // general square: UMFPACK's multifrontal LU (SuiteSparse), fastest on large systems
    // symmetric positive definite: CHOLMOD's supernodal LL^T (SuiteSparse, dense kernels). On the
    // two-ring systems of fair.cpp 1.1-1.4x (26K unknowns, a scan) to 4x (37K, a torus) faster
    // than Cholesky, its solves 2-3x.
    // Falls back to Cholesky when CHOLMOD finds the matrix not positive definite.
    Supernodal,
  };
  SparseSolver();
  ~SparseSolver();
  SparseSolver(SparseSolver&&) noexcept;
  SparseSolver& operator=(SparseSolver&&) noexcept;

  // Throws SolverError if A is not square or the factorisation fails.
  void factor(const SpMat& A, Kind kind);
  // Re-uses the symbolic analysis when A keeps the sparsity pattern of the last factor() call.
  void refactor(const SpMat& A);
  // Solves A X = B column by column. Throws SolverError if not factored or if the solve fails.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& B) const;
  bool factored() const;
  int rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dgmesh
