// Quadric decimation: manifoldness, topology, boundary, feature weights, bad input.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <set>

#include "dgmesh/crest_lines.h"
#include "dgmesh/decimate.h"
#include "dgmesh/errors.h"
#include "dgmesh/shapes.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

namespace crest_test {
TriMesh cube_grid(int n);
TriMesh rounded_cube(int n, double r);
}  // namespace crest_test

namespace {

int euler(const MatX3d& V, const MatX3i& F) {
  const Topology t = validate(V, F, kSurface | kNoLooseVertices);
  return static_cast<int>(V.rows()) - t.n_edges() + static_cast<int>(F.rows());
}

}  // namespace

TEST(Decimate, SphereStaysAClosedManifoldSphere) {
  const TriMesh s = icosphere(4, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = 500;
  const DecimateResult r = decimate(m, opt);
  EXPECT_LE(r.F.rows(), 500);
  EXPECT_GE(r.F.rows(), 498);
  EXPECT_EQ(euler(r.V, r.F), 2);  // validate() inside also checks manifoldness and orientation
  EXPECT_TRUE(validate(r.V, r.F).boundary_loops.empty());
  for (int v = 0; v < r.V.rows(); ++v) EXPECT_NEAR(r.V.row(v).norm(), 1.0, 0.03);
  // Every input vertex maps to an output vertex.
  ASSERT_EQ(r.vertex_map.size(), static_cast<size_t>(s.V.rows()));
  for (int w : r.vertex_map) EXPECT_TRUE(w >= 0 && w < r.V.rows());
}

TEST(Decimate, GreedyQueueAlsoKeepsAClosedManifold) {
  const TriMesh s = icosphere(4, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = 500;
  opt.batched = false;
  const DecimateResult r = decimate(m, opt);
  EXPECT_LE(r.F.rows(), 500);
  EXPECT_GE(r.F.rows(), 498);
  EXPECT_EQ(euler(r.V, r.F), 2);
  for (int v = 0; v < r.V.rows(); ++v) EXPECT_NEAR(r.V.row(v).norm(), 1.0, 0.03);
}

TEST(Decimate, TorusKeepsGenus) {
  const TriMesh t = torus(2.0, 0.6, 64, 32);
  const Mesh m = make_mesh(t.V, t.F);
  DecimateOptions opt;
  opt.target_faces = 400;
  const DecimateResult r = decimate(m, opt);
  EXPECT_LE(r.F.rows(), 400);
  EXPECT_EQ(euler(r.V, r.F), 0);
}

TEST(Decimate, BoundaryIsKeptExactly) {
  const TriMesh g = grid(30, 30);
  const Mesh m = make_mesh(g.V, g.F);
  DecimateOptions opt;
  opt.target_faces = 300;
  const DecimateResult r = decimate(m, opt);
  const Topology t = validate(r.V, r.F, kSurface | kNoLooseVertices);
  ASSERT_EQ(t.boundary_loops.size(), 1u);
  // All 120 boundary vertices survive, unmoved; the plane stays flat.
  std::set<std::pair<double, double>> in, out;
  for (int v = 0; v < g.V.rows(); ++v)
    if (m.topo.on_boundary[v]) in.insert({g.V(v, 0), g.V(v, 1)});
  for (int v : t.boundary_loops[0]) out.insert({r.V(v, 0), r.V(v, 1)});
  EXPECT_EQ(in, out);
  EXPECT_LT(r.V.col(2).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE(r.F.rows(), 300);
}

TEST(Decimate, BoundaryCanCollapseWhenNotPreserved) {
  const TriMesh g = grid(30, 30);
  const Mesh m = make_mesh(g.V, g.F);
  DecimateOptions opt;
  opt.target_faces = 100;
  opt.preserve_boundary = false;
  const DecimateResult r = decimate(m, opt);
  const Topology t = validate(r.V, r.F, kSurface | kNoLooseVertices);
  EXPECT_EQ(t.boundary_loops.size(), 1u);
  EXPECT_LE(r.F.rows(), 100);
  // Boundary vertices stay on the square's sides (constraint planes), the corners stay.
  for (int v : t.boundary_loops[0]) {
    const double x = r.V(v, 0), y = r.V(v, 1);
    EXPECT_LT(std::min({std::abs(x), std::abs(x - 1), std::abs(y), std::abs(y - 1)}), 1e-6);
  }
}

TEST(Decimate, LockedVerticesStayAndMapsAreConsistent) {
  const TriMesh s = icosphere(4, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = 400;
  opt.locked.assign(s.V.rows(), 0);
  for (int v = 0; v < s.V.rows(); ++v) opt.locked[v] = std::abs(s.V(v, 2)) < 0.05;  // an equator band
  const DecimateResult r = decimate(m, opt);
  EXPECT_EQ(euler(r.V, r.F), 2);
  for (int v = 0; v < s.V.rows(); ++v) {
    if (!opt.locked[v]) continue;
    const int w = r.vertex_map[v];
    ASSERT_GE(w, 0);
    EXPECT_EQ(r.source_vertex[w], v);
    EXPECT_EQ((r.V.row(w) - s.V.row(v)).norm(), 0.0);
  }
  // Output face j is input face face_map[j] with its corners sent through the vertex map.
  ASSERT_EQ(r.face_map.size(), static_cast<size_t>(r.F.rows()));
  for (int j = 0; j < r.F.rows(); ++j)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.F(j, k), r.vertex_map[s.F(r.face_map[j], k)]);
  opt.locked.pop_back();
  EXPECT_THROW(decimate(m, opt), MeshError);
}

// A UV sphere (32 segments, 16 rings, like Blender's) with its seam meridian locked, decimated
// near the topological limit: collapses pile up against the locked arc, and before the fold guard
// left back-to-back face pairs (dihedral angles near 180 degrees).
TEST(Decimate, LockedSeamAtExtremeRatioMakesNoFolds) {
  const int seg = 32, rings = 16;
  std::vector<Vec3> P{Vec3(0, 0, 1)};
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < seg; ++j) {
      const double th = M_PI * i / rings, ph = 2 * M_PI * j / seg;
      P.emplace_back(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    }
  P.emplace_back(0, 0, -1);
  std::vector<std::array<int, 3>> T;
  const int south = static_cast<int>(P.size()) - 1, last = 1 + (rings - 2) * seg;
  for (int j = 0; j < seg; ++j) T.push_back({0, 1 + j, 1 + (j + 1) % seg});
  for (int i = 0; i < rings - 2; ++i)
    for (int j = 0; j < seg; ++j) {
      const int a = 1 + i * seg + j, b = 1 + i * seg + (j + 1) % seg;
      T.push_back({a, a + seg, b + seg});
      T.push_back({a, b + seg, b});
    }
  for (int j = 0; j < seg; ++j) T.push_back({south, last + (j + 1) % seg, last + j});
  MatX3d V(P.size(), 3);
  for (size_t i = 0; i < P.size(); ++i) V.row(i) = P[i].transpose();
  MatX3i F(T.size(), 3);
  for (size_t i = 0; i < T.size(); ++i) F.row(i) << T[i][0], T[i][1], T[i][2];
  const Mesh m = make_mesh(V, F);
  DecimateOptions opt;
  opt.locked.assign(V.rows(), 0);
  for (int v = 0; v < V.rows(); ++v) opt.locked[v] = std::abs(V(v, 1)) < 1e-9 && V(v, 0) >= 0;
  for (double ratio : {0.03, 0.02}) {
    opt.target_faces = static_cast<int>(ratio * F.rows());
    const DecimateResult r = decimate(m, opt);
    EXPECT_EQ(euler(r.V, r.F), 2);
    const Topology t = validate(r.V, r.F);
    int folds = 0;
    for (int e = 0; e < t.n_edges(); ++e) {
      const int f = t.edge_faces(e, 0), g = t.edge_faces(e, 1);
      const auto normal = [&](int i) {
        const Vec3 a = r.V.row(r.F(i, 0)), b = r.V.row(r.F(i, 1)), c = r.V.row(r.F(i, 2));
        return Vec3((b - a).cross(c - a).normalized());
      };
      folds += normal(f).dot(normal(g)) < -0.5;
    }
    EXPECT_EQ(folds, 0) << "ratio " << ratio << ", " << r.F.rows() << " faces";
  }
}

TEST(Decimate, FeatureWeightsKeepDensityNearCrestLines) {
  const TriMesh rc = crest_test::rounded_cube(24, 0.3);
  const Mesh m = make_mesh(rc.V, rc.F);
  CrestOptions co;
  co.threshold = 8.0;
  const CrestLines cl = crest_lines(m, DerivativeOptions{}, co);
  ASSERT_GT(cl.n_lines(), 0);
  const VecXd Fd = feature_function(crest_face_distance(m, cl), 6.0);
  // Vertices in the rounded band around the crest lines (the edges' middles) after decimating
  // to 10%.
  const double mid = 0.7 + 0.3 / std::sqrt(2.0);
  auto near_lines = [&](const DecimateResult& r) {
    int n = 0;
    for (int v = 0; v < r.V.rows(); ++v) n += ((r.V.row(v).cwiseAbs().array() - mid).abs() < 0.08).count() >= 2;
    return n;
  };
  DecimateOptions plain;
  plain.target_faces = static_cast<int>(rc.F.rows() / 10);
  DecimateOptions weighted = plain;
  weighted.face_weights = Fd.cwiseInverse();
  const DecimateResult a = decimate(m, plain), b = decimate(m, weighted);
  EXPECT_EQ(euler(b.V, b.F), 2);
  EXPECT_LE(b.F.rows(), weighted.target_faces);
  // Weighted: more of the budget stays at the crest lines.
  EXPECT_GT(near_lines(b), 1.2 * near_lines(a));
}

TEST(Decimate, CubeCornersAndEdgesSurvive) {
  const TriMesh c = crest_test::cube_grid(10);
  const Mesh m = make_mesh(c.V, c.F);
  DecimateOptions opt;
  opt.target_faces = 12;
  const DecimateResult r = decimate(m, opt);
  EXPECT_EQ(r.F.rows(), 12);
  EXPECT_EQ(r.V.rows(), 8);
  for (int v = 0; v < r.V.rows(); ++v) EXPECT_NEAR(r.V.row(v).cwiseAbs().minCoeff(), 1.0, 1e-9);
}

TEST(Decimate, MinQualityGuardAvoidsSlivers) {
  const TriMesh s = icosphere(4, 1.0);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = 300;
  opt.min_quality = 0.3;
  const DecimateResult r = decimate(m, opt);
  double worst = 1;
  for (int f = 0; f < r.F.rows(); ++f) {
    const Vec3 a = r.V.row(r.F(f, 0)), b = r.V.row(r.F(f, 1)), c = r.V.row(r.F(f, 2));
    const double l = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
    worst = std::min(worst, 2 * std::sqrt(3.0) * (b - a).cross(c - a).norm() / l);
  }
  EXPECT_GT(worst, 0.3);
  EXPECT_LE(r.F.rows(), 310);
}

TEST(Decimate, RejectsBadOptions) {
  const TriMesh s = icosphere(2);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = -1;
  EXPECT_THROW(decimate(m, opt), MeshError);
  opt.target_faces = 10;
  opt.face_weights = VecXd::Ones(3);
  EXPECT_THROW(decimate(m, opt), MeshError);
  opt.face_weights = VecXd::Ones(s.F.rows());
  opt.face_weights[0] = std::nan("");
  EXPECT_THROW(decimate(m, opt), MeshError);
  opt.face_weights.resize(0);
  opt.min_quality = 1.5;
  EXPECT_THROW(decimate(m, opt), MeshError);
}

TEST(Decimate, TargetAboveFaceCountIsANoOp) {
  const TriMesh s = icosphere(2);
  const Mesh m = make_mesh(s.V, s.F);
  DecimateOptions opt;
  opt.target_faces = 10000;
  const DecimateResult r = decimate(m, opt);
  EXPECT_EQ(r.F.rows(), s.F.rows());
  EXPECT_EQ((r.V - s.V).cwiseAbs().maxCoeff(), 0.0);
}
