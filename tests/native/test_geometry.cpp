// Curvature and operators on surfaces with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "dgmesh/geometry.h"
#include "dgmesh/shapes.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

namespace {

double max_abs_error(const VecXd& x, double exact) { return (x.array() - exact).abs().maxCoeff(); }

}  // namespace

TEST(Curvature, IcosphereConvergesToExactValues) {
  const double r = 2.5;
  double prev_k = 1e9;
  for (int level = 2; level <= 5; ++level) {
    const Mesh m = make_mesh(icosphere(level, r).V, icosphere(level, r).F);
    const Curvature c = curvature(m.V, m.F, m.topo);
    const double eh = max_abs_error(c.mean, 1.0 / r) * r;  // relative
    const double ek = max_abs_error(c.gaussian, 1.0 / (r * r)) * r * r;
    // With Voronoi areas (icosphere triangles are acute), -N.Lap(x)/2 = 1/r exactly for any mesh
    // inscribed in a sphere: (x_j - x_i).x_i = -|x_j - x_i|^2 / 2 cancels the area's cotangent sum.
    EXPECT_LT(eh, 1e-9) << "level " << level;
    EXPECT_LT(ek, prev_k) << "level " << level;
    prev_k = ek;
    // Gauss-Bonnet holds exactly for the angle deficit: sum K A = 2 pi chi = 4 pi.
    EXPECT_NEAR(c.gaussian.dot(c.area), 4 * M_PI, 1e-9);
    // Mixed areas tile the surface.
    EXPECT_NEAR(c.area.sum(), face_areas(m.V, m.F).sum(), 1e-9);
    // Max normals are exact on a sphere: the normalised position.
    for (int v = 0; v < m.V.rows(); ++v) EXPECT_NEAR(c.normals.row(v).dot(m.V.row(v) / r), 1.0, 1e-9);
  }
  EXPECT_LT(prev_k, 0.05);
}

TEST(Curvature, TorusMatchesAnalyticValues) {
  const double R = 2.0, r = 0.7;
  const int nu = 160, nv = 64;
  const TriMesh t = torus(R, r, nu, nv);
  const Mesh m = make_mesh(t.V, t.F);
  const Curvature c = curvature(m.V, m.F, m.topo);
  double eh = 0, ek = 0;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double v = 2 * M_PI * j / nv;
      const double K = std::cos(v) / (r * (R + r * std::cos(v)));
      const double H = (R + 2 * r * std::cos(v)) / (2 * r * (R + r * std::cos(v)));
      eh = std::max(eh, std::abs(c.mean[i * nv + j] - H));
      ek = std::max(ek, std::abs(c.gaussian[i * nv + j] - K));
    }
  EXPECT_LT(eh, 0.02 / r);
  EXPECT_LT(ek, 0.05 / (r * r));
  EXPECT_NEAR(c.gaussian.dot(c.area), 0.0, 1e-8);  // chi = 0
}

TEST(Curvature, TorusErrorShrinksWithRefinement) {
  const double R = 2.0, r = 0.7;
  double prev = 1e9;
  for (int nv : {16, 32, 64}) {
    const int nu = 2 * nv;
    const TriMesh t = torus(R, r, nu, nv);
    const Mesh m = make_mesh(t.V, t.F);
    const Curvature c = curvature(m.V, m.F, m.topo);
    double e = 0;
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        const double v = 2 * M_PI * j / nv;
        e = std::max(e, std::abs(c.mean[i * nv + j] - (R + 2 * r * std::cos(v)) / (2 * r * (R + r * std::cos(v)))));
      }
    EXPECT_LT(e, 0.6 * prev) << nv;
    prev = e;
  }
}

TEST(Curvature, PlaneIsFlatIncludingBoundary) {
  const TriMesh g = grid(20, 15);
  const Mesh m = make_mesh(g.V, g.F);
  const Curvature c = curvature(m.V, m.F, m.topo);
  EXPECT_LT(c.mean.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(c.gaussian.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_TRUE(c.mean.allFinite());
}

TEST(Curvature, ScaleBehaviour) {
  // H scales as 1/s and K as 1/s^2 under uniform scaling: no hidden absolute tolerances.
  const TriMesh s = icosphere(3, 1.0);
  const Mesh a = make_mesh(s.V, s.F), b = make_mesh(s.V * 1e-3, s.F);
  const Curvature ca = curvature(a.V, a.F, a.topo), cb = curvature(b.V, b.F, b.topo);
  EXPECT_LT((cb.mean * 1e-3 - ca.mean).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((cb.gaussian * 1e-6 - ca.gaussian).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Laplacian, CotanMatrixMatchesCurvatureAndAnnihilatesConstants) {
  const TriMesh s = icosphere(3, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  const SpMat L = cotan_laplacian(m.V, m.F);
  EXPECT_LT((L * VecXd::Ones(m.V.rows())).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((SpMat(L.transpose()) - L).norm(), 1e-12);
  const Curvature c = curvature(m.V, m.F, m.topo);
  const Eigen::MatrixXd LV = L * Eigen::MatrixXd(m.V);
  for (int v = 0; v < m.V.rows(); ++v) EXPECT_LT((LV.row(v) / c.area[v] - c.laplace.row(v)).norm(), 1e-9);
}

TEST(Normals, AllWeightsAgreeOnSymmetricVertices) {
  const TriMesh s = icosphere(2, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  for (NormalWeights w : {NormalWeights::Max, NormalWeights::Area, NormalWeights::Angle}) {
    const MatX3d N = vertex_normals(m.V, m.F, m.topo, w);
    // The 12 icosahedron vertices are perfectly symmetric.
    for (int v = 0; v < 12; ++v) EXPECT_NEAR(N.row(v).dot(m.V.row(v)), 1.0, 1e-12);
    EXPECT_TRUE(N.allFinite());
  }
}

TEST(Umbrella, VanishesOnRegularPlanarGridInterior) {
  // On a regular grid the uniform umbrella is zero only where the star is symmetric; the
  // area-weighted one of eq. 3.10 is tangent, and both are zero on the boundary.
  const TriMesh g = grid(10, 10);
  const Mesh m = make_mesh(g.V, g.F);
  for (Umbrella kind : {Umbrella::Uniform, Umbrella::Area}) {
    const MatX3d U = umbrella(m.V, m.topo, kind);
    const MatX3d U2 = bi_umbrella(m.V, m.topo, kind);
    for (int v = 0; v < m.V.rows(); ++v) {
      EXPECT_NEAR(U(v, 2), 0.0, 1e-12);
      EXPECT_NEAR(U2(v, 2), 0.0, 1e-12);
      if (m.topo.on_boundary[v]) {
        EXPECT_EQ(U.row(v).norm(), 0.0);
      }
    }
  }
}

TEST(Umbrella, PointsInwardOnSphere) {
  const TriMesh s = icosphere(3, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  for (Umbrella kind : {Umbrella::Uniform, Umbrella::Area}) {
    const MatX3d U = umbrella(m.V, m.topo, kind);
    for (int v = 0; v < m.V.rows(); ++v) EXPECT_LT(U.row(v).dot(m.V.row(v)), 0.0);
  }
}
