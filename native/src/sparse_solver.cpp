#include "dgmesh/sparse_solver.h"

#include <Eigen/CholmodSupport>
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
  std::unique_ptr<Eigen::CholmodSupernodalLLT<SpMat>> chol;  // made on first use (CHOLMOD's workspace)
  bool chol_failed = false;                                  // Supernodal fell back to ldlt for this pattern

  Eigen::CholmodSupernodalLLT<SpMat>& cholmod() {
    if (!chol) {
      chol = std::make_unique<Eigen::CholmodSupernodalLLT<SpMat>>();
      chol->cholmod().print = 0;  // a matrix that is not positive definite is reported by info()
    }
    return *chol;
  }
};

SparseSolver::SparseSolver() : impl_(std::make_unique<Impl>()) {}
SparseSolver::~SparseSolver() = default;
SparseSolver::SparseSolver(SparseSolver&&) noexcept = default;
SparseSolver& SparseSolver::operator=(SparseSolver&&) noexcept = default;

void SparseSolver::factor(const SpMat& A, Kind kind) {
  if (A.rows() != A.cols()) throw SolverError("sparse solver: matrix is not square");
  impl_->kind = kind;
  impl_->ok = false;
  impl_->chol_failed = false;
  if (kind == Kind::Cholesky) {
    impl_->ldlt.analyzePattern(A);
  } else if (kind == Kind::Supernodal) {
    impl_->cholmod().analyzePattern(A);
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
  if (impl_->kind == Kind::Supernodal && !impl_->chol_failed) {
    impl_->cholmod().factorize(A);
    if (impl_->cholmod().info() == Eigen::Success) {
      impl_->ok = true;
      return;
    }
    // Not numerically positive definite for LL^T: LDL^T from now on (it handles what it can).
    impl_->chol_failed = true;
    impl_->ldlt.analyzePattern(A);
  }
  if (impl_->kind == Kind::Cholesky || impl_->kind == Kind::Supernodal) {
    impl_->ldlt.factorize(A);
    if (impl_->ldlt.info() != Eigen::Success)
      throw SolverError("sparse solver: LDL^T factorisation failed (matrix not positive definite?)");
  } else if (impl_->kind == Kind::Umfpack) {
    impl_->umf_matrix = A;
    impl_->umf_matrix.makeCompressed();
    impl_->umf.factorize(impl_->umf_matrix);
    if (impl_->umf.info() != Eigen::Success)
      throw SolverError("sparse solver: UMFPACK factorisation failed (singular matrix?)");
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
    case Kind::Cholesky:
      X = impl_->ldlt.solve(B);
      break;
    case Kind::Supernodal:
      X = impl_->chol_failed ? Eigen::MatrixXd(impl_->ldlt.solve(B)) : Eigen::MatrixXd(impl_->chol->solve(B));
      break;
    case Kind::LU:
      X = impl_->lu.solve(B);
      break;
    case Kind::Umfpack:
      X = impl_->umf.solve(B);
      break;
  }
  if (!X.allFinite()) throw SolverError("sparse solver: solution is not finite (singular system)");
  return X;
}

bool SparseSolver::factored() const { return impl_->ok; }
int SparseSolver::rows() const {
  switch (impl_->kind) {
    case Kind::Cholesky:
      return static_cast<int>(impl_->ldlt.rows());
    case Kind::Supernodal:
      return static_cast<int>(impl_->chol_failed ? impl_->ldlt.rows() : impl_->chol->rows());
    case Kind::LU:
      return static_cast<int>(impl_->lu.rows());
    case Kind::Umfpack:
      return static_cast<int>(impl_->umf.rows());
  }
  return 0;
}

}  // namespace dgmesh
