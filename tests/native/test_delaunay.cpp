// Qhull wrapper: empty-circumsphere property, Voronoi vertices of a sphere sample at its centre,
// 2D triangulation of a grid (Euler count, orientation, empty circles), bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "dgmesh/delaunay.h"
#include "dgmesh/errors.h"
#include "dgmesh/shapes.h"

using namespace dgmesh;

TEST(Delaunay, CubeCornersAndCentreGiveTwelveTets) {
  MatX3d P(9, 3);
  int k = 0;
  for (int x = 0; x < 2; ++x)
    for (int y = 0; y < 2; ++y)
      for (int z = 0; z < 2; ++z) P.row(k++) << x, y, z;
  P.row(8) << 0.5, 0.5, 0.5;
  const Delaunay3 d = delaunay_3d(P);
  ASSERT_EQ(d.tets.rows(), 12);  // centre joined to the 6 faces, 2 triangles each
  double vol = 0;
  for (int t = 0; t < d.tets.rows(); ++t) {
    const Vec3 a = row3(P, d.tets(t, 0));
    const double v = (row3(P, d.tets(t, 1)) - a).dot((row3(P, d.tets(t, 2)) - a).cross(row3(P, d.tets(t, 3)) - a)) / 6;
    EXPECT_GT(v, 0);
    vol += v;
  }
  EXPECT_NEAR(vol, 1.0, 1e-12);
  EXPECT_EQ(d.point_offset[9] - d.point_offset[8], 12);  // the centre is in every tet
}

TEST(Delaunay, RandomPointsHaveEmptyCircumspheres) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  MatX3d P(400, 3);
  for (int i = 0; i < P.rows(); ++i) P.row(i) << u(rng), u(rng), u(rng);
  const Delaunay3 d = delaunay_3d(P);
  ASSERT_GT(d.tets.rows(), 400);
  double vol = 0;
  for (int t = 0; t < d.tets.rows(); ++t) {
    const Vec3 c = row3(d.circumcenters, t);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR((row3(P, d.tets(t, k)) - c).norm(), d.circumradii[t], 1e-9);
    for (int i = 0; i < P.rows(); ++i) EXPECT_GE((row3(P, i) - c).norm(), d.circumradii[t] * (1 - 1e-9));
    const Vec3 a = row3(P, d.tets(t, 0));
    vol += (row3(P, d.tets(t, 1)) - a).dot((row3(P, d.tets(t, 2)) - a).cross(row3(P, d.tets(t, 3)) - a)) / 6;
  }
  EXPECT_GT(vol, 0);
  for (int i = 0; i < P.rows(); ++i) EXPECT_GT(d.point_offset[i + 1] - d.point_offset[i], 0);
}

TEST(Delaunay, SphereSampleVoronoiPolesAtCentre) {
  // Cospherical input: every Delaunay tet has the sphere's centre as circumcentre (up to the
  // triangulation of the degenerate cell), so the inner Voronoi poles are the centre.
  const TriMesh s = icosphere(2, 2.0);
  MatX3d P = s.V;
  for (int i = 0; i < P.rows(); ++i) P.row(i) += Eigen::RowVector3d(1, -2, 3);
  const Delaunay3 d = delaunay_3d(P);
  int far = 0;
  for (int i = 0; i < P.rows(); ++i) {
    double best = 0;
    Vec3 pole(0, 0, 0);
    for (int k = d.point_offset[i]; k < d.point_offset[i + 1]; ++k) {
      const Vec3 c = row3(d.circumcenters, d.point_tets[k]);
      const double r = (c - row3(P, i)).norm();
      if (r > best) best = r, pole = c;
    }
    if ((pole - Vec3(1, -2, 3)).norm() > 1e-6) ++far;
  }
  EXPECT_EQ(far, 0);
}

TEST(Delaunay, Grid2dTriangulation) {
  MatX2d P(36, 2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> j(-0.01, 0.01);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 6; ++x) P.row(y * 6 + x) << x + j(rng), y + j(rng);
  const MatX3i F = delaunay_2d(P);
  // Euler: a triangulation of n points with h on its convex boundary has 2n - h - 2 triangles.
  std::map<std::pair<int, int>, int> edge_count;
  for (int t = 0; t < F.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = F(t, k), b = F(t, (k + 1) % 3);
      ++edge_count[{std::min(a, b), std::max(a, b)}];
    }
  int h = 0;
  for (const auto& e : edge_count) h += e.second == 1;
  EXPECT_GE(h, 4);
  EXPECT_EQ(F.rows(), 2 * 36 - h - 2);
  double area = 0;
  for (int t = 0; t < F.rows(); ++t) {
    const Eigen::RowVector2d a = P.row(F(t, 0)), b = P.row(F(t, 1)), c = P.row(F(t, 2));
    const double cr = (b - a)(0) * (c - a)(1) - (b - a)(1) * (c - a)(0);
    EXPECT_GT(cr, 0);
    area += cr / 2;
    // empty circumcircle
    const double d = 2 * cr;
    const double ux =
        ((a.squaredNorm()) * (b(1) - c(1)) + b.squaredNorm() * (c(1) - a(1)) + c.squaredNorm() * (a(1) - b(1))) / d;
    const double uy =
        ((a.squaredNorm()) * (c(0) - b(0)) + b.squaredNorm() * (a(0) - c(0)) + c.squaredNorm() * (b(0) - a(0))) / d;
    const Eigen::RowVector2d cc(ux, uy);
    const double r = (a - cc).norm();
    for (int i = 0; i < P.rows(); ++i) EXPECT_GE((P.row(i) - cc).norm(), r * (1 - 1e-9));
  }
  EXPECT_NEAR(area, 25.0, 0.2);
}

TEST(Delaunay, BadInputThrows) {
  MatX3d flat(10, 3);
  for (int i = 0; i < 10; ++i) flat.row(i) << i % 3, i / 3, 0;
  EXPECT_THROW(delaunay_3d(flat), MeshError);
  EXPECT_THROW(delaunay_3d(MatX3d::Zero(3, 3)), MeshError);
  MatX3d nan = MatX3d::Random(10, 3);
  nan(4, 1) = std::nan("");
  EXPECT_THROW(delaunay_3d(nan), MeshError);
  MatX2d line(5, 2);
  for (int i = 0; i < 5; ++i) line.row(i) << i, 2 * i;
  EXPECT_THROW(delaunay_2d(line), MeshError);
}
