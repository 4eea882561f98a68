#include "dgmesh/validate.h"

#include <algorithm>
#include <sstream>

#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"

namespace dgmesh {

namespace {

template <class... Args>
[[noreturn]] void fail(const Args&... args) {
  std::ostringstream s;
  (s << ... << args);
  throw MeshError(s.str());
}

double bbox_diagonal(const MatX3d& V) {
  if (V.rows() == 0) return 0.0;
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

}  // namespace

void validate_points(const MatX3d& V) {
  if (V.rows() == 0) fail("point set is empty");
  int bad = 0, first = -1;
  for (int i = 0; i < V.rows(); ++i)
    if (!V.row(i).allFinite()) {
      if (first < 0) first = i;
      ++bad;
    }
  if (bad) fail(bad, " vertex coordinate(s) are NaN or infinite (first: vertex ", first, ")");
}

Topology validate(const MatX3d& V, const MatX3i& F, unsigned checks) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if ((checks & kNonEmpty) && (n == 0 || m == 0)) fail("mesh is empty (", n, " vertices, ", m, " faces)");
  // Indices are always checked: nothing below is safe without them.
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        fail("face ", f, " refers to vertex ", F(f, k), ", but the mesh has ", n, " vertices");
  if (checks & kFinite) validate_points(V);

  if (checks & (kNoRepeatedIndex | kNoZeroArea)) {
    const double diag = bbox_diagonal(V);
    const double min_area = 1e-12 * diag * diag;
    int repeated = 0, zero = 0, first_r = m, first_z = m;
#pragma omp parallel for schedule(static) reduction(+ : repeated, zero) reduction(min : first_r, first_z) if (m >= kParallelMin)
    for (int f = 0; f < m; ++f) {
      const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
      if (a == b || b == c || a == c) {
        first_r = std::min(first_r, f);
        ++repeated;
        continue;
      }
      const Vec3 e1 = V.row(b) - V.row(a), e2 = V.row(c) - V.row(a);
      if (0.5 * e1.cross(e2).norm() <= min_area) {
        first_z = std::min(first_z, f);
        ++zero;
      }
    }
    if ((checks & kNoRepeatedIndex) && repeated)
      fail(repeated, " degenerate face(s) use the same vertex twice (first: face ", first_r, ")");
    if ((checks & kNoZeroArea) && zero)
      fail(zero, " degenerate face(s) have zero area (first: face ", first_z, "); merge or dissolve them first");
  }

  // Vertex corners serve the duplicate check and the topology: one pass over F for both.
  const VertexCorners vc = vertex_corners(F, n);
  if (checks & kNoDuplicateFaces) {
    // A face is owned by its smallest vertex; duplicates share the owner and the other two.
    int dup = 0, first = -1, first_of = -1;
#pragma omp parallel for schedule(dynamic, 4096) reduction(+ : dup) if (n >= kParallelMin)
    for (int v = 0; v < n; ++v) {
      for (int i = vc.offset[v]; i < vc.offset[v + 1]; ++i) {
        const Corner& a = vc.corners[i];
        if (a.next < v || a.prev < v) continue;
        for (int j = i + 1; j < vc.offset[v + 1]; ++j) {
          const Corner& b = vc.corners[j];
          if ((b.next == a.next && b.prev == a.prev) || (b.next == a.prev && b.prev == a.next)) {
            ++dup;
#pragma omp critical(dgmesh_duplicate)
            if (first < 0 || std::max(a.face, b.face) < first)
              first = std::max(a.face, b.face), first_of = std::min(a.face, b.face);
          }
        }
      }
    }
    if (dup) fail(dup, " duplicate face(s) (first: face ", first, " repeats face ", first_of, ")");
  }

  if (checks & kNoLooseVertices) {
    std::vector<char> used(n, 0);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) used[F(f, k)] = 1;
    const auto loose = std::count(used.begin(), used.end(), 0);
    if (loose)
      fail(loose, " loose vertex(es) belong to no face (first: vertex ",
           std::find(used.begin(), used.end(), 0) - used.begin(), ")");
  }

  // Building the topology is the manifold check; without kManifold the caller gets no topology.
  if (!(checks & kManifold)) {
    Topology t;
    t.n_vertices = n;
    t.n_faces = m;
    return t;
  }
  return build_topology(vc, m);
}

Mesh make_mesh(MatX3d V, MatX3i F, unsigned checks) {
  Topology t = validate(V, F, checks);
  return Mesh{std::move(V), std::move(F), std::move(t)};
}

}  // namespace dgmesh
