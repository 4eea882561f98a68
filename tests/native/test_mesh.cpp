// Topology, validation, spatial index and sparse solver.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <thread>

#include <omp.h>

#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/shapes.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

namespace {

// Expects validate() to throw MeshError with `needle` in its message.
void expect_rejected(const MatX3d& V, const MatX3i& F, const std::string& needle, unsigned checks = kSurface) {
  try {
    validate(V, F, checks);
    ADD_FAILURE() << "accepted a mesh that should fail with '" << needle << "'";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TriMesh two_triangles() {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  return m;
}

}  // namespace

TEST(Topology, ClosedSphereCounts) {
  const TriMesh s = icosphere(3);
  const Topology t = validate(s.V, s.F);
  EXPECT_EQ(t.n_vertices - t.n_edges() + t.n_faces, 2);  // Euler characteristic
  EXPECT_TRUE(t.boundary_loops.empty());
  EXPECT_EQ(t.n_components, 1);
  for (int e = 0; e < t.n_edges(); ++e) {
    EXPECT_GE(t.edge_faces(e, 1), 0);
    EXPECT_LT(t.edges(e, 0), t.edges(e, 1));
  }
  for (int f = 0; f < t.n_faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const int e = t.face_edges(f, k);
      const int a = s.F(f, k), b = s.F(f, (k + 1) % 3);
      EXPECT_EQ(std::min(a, b), t.edges(e, 0));
      EXPECT_EQ(std::max(a, b), t.edges(e, 1));
      EXPECT_TRUE(t.edge_faces(e, 0) == f || t.edge_faces(e, 1) == f);
    }
}

TEST(Topology, RingsAreCounterClockwiseFans) {
  const TriMesh s = icosphere(2);
  const Topology t = validate(s.V, s.F);
  const MatX3d N = face_normals(s.V, s.F);
  for (int v = 0; v < t.n_vertices; ++v) {
    const int d = t.valence(v);
    ASSERT_GE(d, 5);
    for (int i = 0; i < d; ++i) {
      const int a = t.vv_index[t.vv_offset[v] + i], b = t.vv_index[t.vv_offset[v] + (i + 1) % d];
      const Vec3 n = (s.V.row(a) - s.V.row(v)).cross(s.V.row(b) - s.V.row(v));
      EXPECT_GT(n.dot(s.V.row(v)), 0.0);  // consecutive neighbours turn counter-clockwise
    }
  }
}

TEST(Topology, GridBoundaryLoopAndKRing) {
  const TriMesh g = grid(4, 3);
  const Topology t = validate(g.V, g.F);
  ASSERT_EQ(t.boundary_loops.size(), 1u);
  EXPECT_EQ(t.boundary_loops[0].size(), 2u * (4 + 3));
  EXPECT_EQ(t.n_vertices - t.n_edges() + t.n_faces, 1);
  std::vector<int> ring, mark;
  k_ring(t, 0, 1, ring, mark);
  EXPECT_EQ(ring.size(), static_cast<size_t>(t.valence(0) + 1));
  k_ring(t, 0, 100, ring, mark);
  EXPECT_EQ(ring.size(), static_cast<size_t>(t.n_vertices));
  // 4*4 horizontal edges of 1/4, 5*3 vertical of 1/3, 4*3 diagonals.
  const double diag = std::sqrt(1.0 / 16 + 1.0 / 9);
  EXPECT_NEAR(average_edge_length(g.V, t), (16 * 0.25 + 15 / 3.0 + 12 * diag) / 43.0, 1e-12);
  EXPECT_EQ(t.n_edges(), 43);
}

TEST(Topology, ComponentsAndLooseVertices) {
  TriMesh a = icosphere(1), b = icosphere(1);
  TriMesh m;
  m.V.resize(a.V.rows() * 2 + 1, 3);
  m.V << a.V, (b.V.rowwise() + Eigen::RowVector3d(3, 0, 0)), Eigen::RowVector3d(9, 9, 9);
  m.F.resize(a.F.rows() * 2, 3);
  m.F << a.F, (b.F.array() + int(a.V.rows())).matrix();
  const Topology t = validate(m.V, m.F);
  EXPECT_EQ(t.n_components, 3);  // two spheres and the loose vertex
  EXPECT_TRUE(t.is_loose(int(m.V.rows()) - 1));
  expect_rejected(m.V, m.F, "loose vertex", kSurface | kNoLooseVertices);
}

TEST(Validate, RejectsEachDefectWithAClearMessage) {
  const TriMesh ok = two_triangles();
  EXPECT_NO_THROW(validate(ok.V, ok.F));

  expect_rejected(MatX3d(0, 3), MatX3i(0, 3), "empty");
  {
    MatX3i F = ok.F;
    F(1, 2) = 7;
    expect_rejected(ok.V, F, "refers to vertex 7");
    F(1, 2) = -1;
    expect_rejected(ok.V, F, "refers to vertex -1");
  }
  {
    MatX3d V = ok.V;
    V(2, 1) = std::nan("");
    expect_rejected(V, ok.F, "NaN or infinite");
    V(2, 1) = INFINITY;
    expect_rejected(V, ok.F, "NaN or infinite");
  }
  {
    MatX3i F = ok.F;
    F(1, 2) = 0;
    expect_rejected(ok.V, F, "same vertex twice");
  }
  {
    MatX3d V = ok.V;
    V.row(3) << 2, 2, 0;  // collinear with 0 and 2
    expect_rejected(V, ok.F, "zero area");
  }
  {
    MatX3i F(3, 3);
    F << 0, 1, 2, 0, 2, 3, 2, 0, 1;
    expect_rejected(ok.V, F, "duplicate face");
  }
  {
    // Three triangles on edge 0-1: a fin.
    MatX3d V(5, 3);
    V << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0, 0.5, 0, 1;
    MatX3i F(3, 3);
    F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
    expect_rejected(V, F, "non-manifold edge");
  }
  {
    MatX3i F = ok.F;
    F.row(1) << 0, 3, 2;  // flipped
    expect_rejected(ok.V, F, "inconsistent face orientation");
  }
  {
    // Two triangles touching at vertex 0 only: a bow tie.
    MatX3d V(5, 3);
    V << 0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0;
    MatX3i F(2, 3);
    F << 0, 1, 2, 0, 3, 4;
    expect_rejected(V, F, "non-manifold vertex");
  }
}

TEST(KdTree, RadiusAndKnnMatchBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  MatX3d P(2000, 3);
  for (int i = 0; i < P.rows(); ++i) P.row(i) << u(rng), u(rng), u(rng);
  const KdTree tree(P);
  std::vector<std::pair<int, double>> hits;
  std::vector<int> idx;
  std::vector<double> d2;
  for (int q = 0; q < 50; ++q) {
    const Vec3 x(u(rng), u(rng), u(rng));
    tree.radius(x, 0.3, hits);
    int brute = 0;
    for (int i = 0; i < P.rows(); ++i) brute += (P.row(i).transpose() - x).norm() <= 0.3;
    EXPECT_EQ(static_cast<int>(hits.size()), brute);
    ASSERT_EQ(tree.knn(x, 5, idx, d2), 5);
    double best = 1e9;
    for (int i = 0; i < P.rows(); ++i) best = std::min(best, (P.row(i).transpose() - x).squaredNorm());
    EXPECT_DOUBLE_EQ(d2[0], best);
    EXPECT_EQ(tree.nearest(x), idx[0]);
  }
  KdTree moved = std::move(const_cast<KdTree&>(tree));
  EXPECT_EQ(moved.size(), 2000);
  EXPECT_GE(moved.nearest(Vec3::Zero()), 0);
}

TEST(SparseSolver, FactorOnceSolveMany) {
  const TriMesh s = icosphere(3);
  const SpMat L = cotan_laplacian(s.V, s.F);
  SpMat I(L.rows(), L.cols());
  I.setIdentity();
  const SpMat A = I - 0.1 * L;  // SPD: the implicit smoothing matrix
  for (auto kind : {SparseSolver::Kind::Cholesky, SparseSolver::Kind::LU, SparseSolver::Kind::Umfpack,
                    SparseSolver::Kind::Supernodal}) {
    SparseSolver solver;
    solver.factor(A, kind);
    for (int rep = 0; rep < 3; ++rep) {
      const Eigen::MatrixXd B = Eigen::MatrixXd::Random(L.rows(), 3);
      const Eigen::MatrixXd X = solver.solve(B);
      EXPECT_LT((A * X - B).norm() / B.norm(), 1e-10);
    }
  }
  SparseSolver unfactored;
  EXPECT_THROW(unfactored.solve(Eigen::MatrixXd::Ones(3, 1)), SolverError);
  SpMat singular(3, 3);
  for (auto kind : {SparseSolver::Kind::LU, SparseSolver::Kind::Umfpack}) {
    SparseSolver lu;
    EXPECT_THROW(lu.factor(singular, kind), SolverError);
  }
}

// Supernodal (CHOLMOD): refactoring reuses the analysis of the first matrix's pattern; a matrix that
// is not positive definite falls back to LDL^T (which solves this indefinite one), a singular one throws.
TEST(SparseSolver, SupernodalRefactorAndFallback) {
  const TriMesh s = icosphere(3);
  const SpMat L = cotan_laplacian(s.V, s.F);
  SpMat I(L.rows(), L.cols());
  I.setIdentity();
  SparseSolver solver;
  solver.factor(SpMat(I - 0.1 * L), SparseSolver::Kind::Supernodal);
  for (double tau : {0.1, 10.0, 0.01}) {
    const SpMat A = I - tau * L;
    solver.refactor(A);
    const Eigen::MatrixXd B = Eigen::MatrixXd::Random(L.rows(), 3);
    EXPECT_LT((A * solver.solve(B) - B).norm() / B.norm(), 1e-10);
    EXPECT_EQ(solver.rows(), L.rows());
  }
  SpMat D(3, 3);
  D.insert(0, 0) = 2.0;
  D.insert(1, 1) = -1.0;
  D.insert(2, 2) = 3.0;
  SparseSolver indefinite;
  indefinite.factor(D, SparseSolver::Kind::Supernodal);
  const Eigen::MatrixXd x = indefinite.solve(Eigen::MatrixXd::Ones(3, 1));
  EXPECT_NEAR(x(0), 0.5, 1e-14);
  EXPECT_NEAR(x(1), -1.0, 1e-14);
  EXPECT_NEAR(x(2), 1.0 / 3.0, 1e-14);
  SpMat zero(3, 3);
  zero.insert(0, 0) = 0.0;
  zero.insert(1, 1) = 0.0;
  zero.insert(2, 2) = 0.0;
  SparseSolver singular;
  EXPECT_THROW(singular.factor(zero, SparseSolver::Kind::Supernodal), SolverError);
}

// OpenMP's thread count is per thread: a count set in one thread must reach native work started
// from another (the add-on's jobs run in worker threads), which applies it on entry.
TEST(Parallel, ThreadCountReachesOtherThreads) {
  if (omp_get_num_procs() < 2) GTEST_SKIP() << "one core: every team has one thread";
  const int before = num_threads();
  set_num_threads(1);
  int seen = -1, team = -1;
  std::thread t([&] {
    seen = num_threads();
    apply_num_threads();
#pragma omp parallel
    {
#pragma omp single
      team = omp_get_num_threads();
    }
  });
  t.join();
  set_num_threads(before);
  EXPECT_EQ(seen, 1);
  EXPECT_EQ(team, 1);
}
