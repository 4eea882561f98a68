// Variational shape approximation with crest-line weights (thesis 4.9).
#include <gtest/gtest.h>

#include <vector>

#include "dgmesh/crest_lines.h"
#include "dgmesh/errors.h"
#include "dgmesh/segment.h"
#include "dgmesh/shapes.h"
#include "dgmesh/validate.h"

using namespace dgmesh;

namespace crest_test {
TriMesh cube_grid(int n);
TriMesh rounded_cube(int n, double r);
}  // namespace crest_test

namespace {

// Every face labelled, labels in range, each segment non-empty and edge-connected.
void expect_connected_cover(const Mesh& m, const SegmentResult& r) {
  const int nf = static_cast<int>(m.F.rows());
  ASSERT_EQ(static_cast<int>(r.labels.size()), nf);
  std::vector<int> size(r.n_segments, 0), seen(nf, 0);
  for (int l : r.labels) {
    ASSERT_GE(l, 0);
    ASSERT_LT(l, r.n_segments);
    ++size[l];
  }
  for (int k = 0; k < r.n_segments; ++k) {
    EXPECT_GT(size[k], 0) << "segment " << k;
    int start = -1;
    for (int f = 0; f < nf && start < 0; ++f)
      if (r.labels[f] == k) start = f;
    std::vector<int> stack{start};
    seen[start] = 1;
    int reached = 0;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      ++reached;
      for (int j = 0; j < 3; ++j) {
        const int e = m.topo.face_edges(f, j);
        const int g = m.topo.edge_faces(e, 0) == f ? m.topo.edge_faces(e, 1) : m.topo.edge_faces(e, 0);
        if (g >= 0 && !seen[g] && r.labels[g] == k) seen[g] = 1, stack.push_back(g);
      }
    }
    EXPECT_EQ(reached, size[k]) << "segment " << k << " is not connected";
  }
}

}  // namespace

TEST(Segment, CubeSplitsIntoItsSixSides) {
  const TriMesh c = crest_test::cube_grid(8);
  const Mesh m = make_mesh(c.V, c.F);
  SegmentOptions opt;
  opt.segments = 6;
  const SegmentResult r = segment(m, opt);
  expect_connected_cover(m, r);
  EXPECT_EQ(r.n_segments, 6);
  EXPECT_NEAR(r.error, 0.0, 1e-9);  // every segment planar
  const MatX3d N = [&] {
    MatX3d n(m.F.rows(), 3);
    for (int f = 0; f < m.F.rows(); ++f)
      n.row(f) = (m.V.row(m.F(f, 1)) - m.V.row(m.F(f, 0))).cross(m.V.row(m.F(f, 2)) - m.V.row(m.F(f, 0))).normalized();
    return n;
  }();
  for (int f = 0; f < m.F.rows(); ++f) EXPECT_GT(N.row(f).dot(r.proxy_normals.row(r.labels[f])), 1 - 1e-9);
}

TEST(Segment, SegmentsAreConnectedAndCoverEveryFace) {
  const TriMesh t = torus(2.0, 0.7, 48, 24);
  const Mesh m = make_mesh(t.V, t.F);
  for (int k : {1, 7, 25}) {
    SegmentOptions opt;
    opt.segments = k;
    const SegmentResult r = segment(m, opt);
    EXPECT_EQ(r.n_segments, k);
    expect_connected_cover(m, r);
  }
}

TEST(Segment, MoreSegmentsLowerTheDistortion) {
  const TriMesh s = icosphere(3);
  const Mesh m = make_mesh(s.V, s.F);
  double prev = 1e9;
  for (int k : {4, 12, 40}) {
    SegmentOptions opt;
    opt.segments = k;
    const double e = segment(m, opt).error;
    EXPECT_LT(e, prev);
    prev = e;
  }
}

TEST(Segment, FeatureWeightsAlignBordersWithCrestLines) {
  const TriMesh rc = crest_test::rounded_cube(20, 0.3);
  const Mesh m = make_mesh(rc.V, rc.F);
  CrestOptions co;
  co.threshold = 8.0;
  const CrestLines cl = crest_lines(m, DerivativeOptions{}, co);
  const VecXd d = crest_face_distance(m, cl);
  SegmentOptions opt;
  opt.segments = 6;
  opt.face_feature = feature_function(d, 2.0);
  const SegmentResult r = segment(m, opt);
  expect_connected_cover(m, r);
  // Borders between segments run close to the crest lines (the rounded edges' midlines).
  double border_d = 0;
  int n = 0;
  for (int e = 0; e < m.topo.n_edges(); ++e) {
    const int f = m.topo.edge_faces(e, 0), g = m.topo.edge_faces(e, 1);
    if (f >= 0 && g >= 0 && r.labels[f] != r.labels[g]) border_d += 0.5 * (d[f] + d[g]), ++n;
  }
  ASSERT_GT(n, 0);
  EXPECT_LT(border_d / n, 0.1 * d.maxCoeff());
}

TEST(Segment, OneSegmentPerComponentAtLeast) {
  const TriMesh a = icosphere(2);
  TriMesh two;
  two.V.resize(2 * a.V.rows(), 3);
  two.V << a.V, (a.V.rowwise() + Eigen::RowVector3d(5, 0, 0));
  two.F.resize(2 * a.F.rows(), 3);
  two.F << a.F, (a.F.array() + static_cast<int>(a.V.rows())).matrix();
  const Mesh m = make_mesh(two.V, two.F);
  SegmentOptions opt;
  opt.segments = 1;
  const SegmentResult r = segment(m, opt);
  EXPECT_EQ(r.n_segments, 2);
  expect_connected_cover(m, r);
}

TEST(Segment, RejectsBadOptions) {
  const TriMesh s = icosphere(1);
  const Mesh m = make_mesh(s.V, s.F);
  SegmentOptions opt;
  opt.segments = 0;
  EXPECT_THROW(segment(m, opt), MeshError);
  opt.segments = 1000;
  EXPECT_THROW(segment(m, opt), MeshError);
  opt.segments = 4;
  opt.face_feature = VecXd::Ones(2);
  EXPECT_THROW(segment(m, opt), MeshError);
  opt.face_feature = VecXd::Zero(s.F.rows());
  EXPECT_THROW(segment(m, opt), MeshError);
}
