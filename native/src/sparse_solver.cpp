#include "dgmesh/sparse_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <Eigen/UmfPackSupport>

#include "dgmesh/errors.h"

namespace dgmesh {

struct SparseSolver::Impl {
  Kind kind = Kind::Cholesky;
  bool ok = false;
  Eigen::SimplicialLDLT<SpMat> ldlt;
  Eigen::SparseLU<SpMat, Eigen::COLAMDOrdering<int>> lu;
  Eigen::UmfPackLU<SpMat> umf;
  SpMat umf_matrix;  // UMFPACK's solve reads the matrix again: it must outlive the factorisation
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
  } else if (kind == Kind::Umfpack) {
    impl_->umf_matrix = A;
    impl_->umf_matrix.makeCompressed();
    impl_->umf.analyzePattern(impl_->umf_matrix);
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
  } else if (impl_->kind == Kind::Umfpack) {
    impl_->umf_matrix = A;
    impl_->umf_matrix.makeCompressed();
    impl_->umf.factorize(impl_->umf_matrix);
    if (impl_->umf.info() != Eigen::Success) throw SolverError("sparse solver: UMFPACK factorisation failed (singular matrix?)");
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
  Eigen::MatrixXd X;
  switch (impl_->kind) {
    case Kind::Cholesky: X = impl_->ldlt.solve(B); break;
    case Kind::LU: X = impl_->lu.solve(B); break;
    case Kind::Umfpack: X = impl_->umf.solve(B); break;
  }
  if (!X.allFinite()) throw SolverError("sparse solver: solution is not finite (singular system)");
  return X;
}

bool SparseSolver::factored() const { return impl_->ok; }
int SparseSolver::rows() const {
  switch (impl_->kind) {
    case Kind::Cholesky: return static_cast<int>(impl_->ldlt.rows());
    case Kind::LU: return static_cast<int>(impl_->lu.rows());
    case Kind::Umfpack: return static_cast<int>(impl_->umf.rows());
  }
  return 0;
}

}  // namespace dgmesh
