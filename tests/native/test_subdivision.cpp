#include <gtest/gtest.h>

#include "dgmesh/geometry.h"
#include "dgmesh/subdivision.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

TEST(LoopSubdivision, CountsAndSmoothing) {
  const TriMesh ico = icosphere(0);
  const TriMesh s = loop_subdivide(ico.V, ico.F, 3);
  EXPECT_EQ(s.F.rows(), 20 * 64);
  EXPECT_EQ(s.V.rows(), 2 + 10 * 64);  // closed genus 0: V = F / 2 + 2
  const Topology t = validate(s.V, s.F);
  EXPECT_EQ(t.n_components, 1);
  // Loop surfaces of a convex control mesh stay inside its hull and get rounder: the spread of
  // radii shrinks compared with linear subdivision of the same control mesh.
  const VecXd r = s.V.rowwise().norm();
  TriMesh lin = ico;
  for (int i = 0; i < 3; ++i) lin = subdivide_linear(lin.V, lin.F);
  const VecXd rl = lin.V.rowwise().norm();
  EXPECT_LT((r.maxCoeff() - r.minCoeff()) / r.mean(), 0.5 * (rl.maxCoeff() - rl.minCoeff()) / rl.mean());
  EXPECT_LE(r.maxCoeff(), 1.0 + 1e-12);
  // Orientation is kept: mean curvature stays positive everywhere.
  const Curvature c = curvature(s.V, s.F, t);
  EXPECT_GT(c.mean.minCoeff(), 0.0);
}

TEST(LoopSubdivision, BoundaryIsKeptAsACurve) {
  const TriMesh g = grid(3, 3);
  const TriMesh s = loop_subdivide(g.V, g.F, 2);
  EXPECT_EQ(s.F.rows(), g.F.rows() * 16);
  const Topology t = validate(s.V, s.F);
  ASSERT_EQ(t.boundary_loops.size(), 1u);
  // A planar mesh stays planar.
  EXPECT_LT(s.V.col(2).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(loop_subdivide(g.V, g.F, 0).F.rows(), g.F.rows());
}
