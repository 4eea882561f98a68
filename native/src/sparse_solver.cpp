#include "dgmesh/sparse_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include "dgmesh/errors.h"

namespace dgmesh {

struct SparseSolver::Impl {
  Kind kind = Kind::Cholesky;
  bool ok = false;
  Eigen::SimplicialLDLT<SpMat> ldlt;
  Eigen::SparseLU<SpMat, Eigen::COLAMDOrdering<int>> lu;
};

SparseSolver::SparseSolver() : impl_(std::make_unique<Impl>()) {}
SparseSolver::~SparseSolver() = default;
SparseSolver::SparseSolver(SparseSolver&&) noexcept = default;
SparseSolver& SparseSolver::operator=(SparseSolver&&) noexcept = default;

void SparseSolver::factor(const SpMat& A, Kind kind) {
  if (A.rows() != A.cols()) throw SolverError("sparse solver: matrix is not square");
  impl_->kind = kind;
  impl_->ok = false;
  if (kind == Kind::Cholesky) {
    impl_->ldlt.analyzePattern(A);
  } else {
    SpMat M = A;
    M.makeCompressed();
    impl_->lu.analyzePattern(M);
  }
  refactor(A);
}

void SparseSolver::refactor(const SpMat& A) {
  impl_->ok = false;
  if (impl_->kind == Kind::Cholesky) {
    impl_->ldlt.factorize(A);
    if (impl_->ldlt.info() != Eigen::Success)
      throw SolverError("sparse solver: LDL^T factorisation failed (matrix not positive definite?)");
  } else {
    SpMat M = A;
    M.makeCompressed();
    impl_->lu.factorize(M);
    if (impl_->lu.info() != Eigen::Success)
      throw SolverError("sparse solver: LU factorisation failed: " + impl_->lu.lastErrorMessage());
  }
  impl_->ok = true;
}

Eigen::MatrixXd SparseSolver::solve(const Eigen::MatrixXd& B) const {
  if (!impl_->ok) throw SolverError("sparse solver: solve() before a successful factor()");
  Eigen::MatrixXd X = impl_->kind == Kind::Cholesky ? Eigen::MatrixXd(impl_->ldlt.solve(B))
                                                    : Eigen::MatrixXd(impl_->lu.solve(B));
  if (!X.allFinite()) throw SolverError("sparse solver: solution is not finite (singular system)");
  return X;
}

bool SparseSolver::factored() const { return impl_->ok; }
int SparseSolver::rows() const {
  return static_cast<int>(impl_->kind == Kind::Cholesky ? impl_->ldlt.rows() : impl_->lu.rows());
}

}  // namespace dgmesh
