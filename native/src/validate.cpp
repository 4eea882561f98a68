#include "dgmesh/validate.h"

#include <algorithm>
#include <array>
#include <sstream>

#include "dgmesh/errors.h"

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
  if ((checks & kNonEmpty) && (n == 0 || m == 0))
    fail("mesh is empty (", n, " vertices, ", m, " faces)");
  // Indices are always checked: nothing below is safe without them.
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        fail("face ", f, " refers to vertex ", F(f, k), ", but the mesh has ", n, " vertices");
  if (checks & kFinite) validate_points(V);

  if (checks & (kNoRepeatedIndex | kNoZeroArea)) {
    const double diag = bbox_diagonal(V);
    const double min_area = 1e-12 * diag * diag;
    int repeated = 0, zero = 0, first_r = -1, first_z = -1;
    for (int f = 0; f < m; ++f) {
      const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
      if (a == b || b == c || a == c) {
        if (first_r < 0) first_r = f;
        ++repeated;
        continue;
      }
      const Vec3 e1 = V.row(b) - V.row(a), e2 = V.row(c) - V.row(a);
      if (0.5 * e1.cross(e2).norm() <= min_area) {
        if (first_z < 0) first_z = f;
        ++zero;
      }
    }
    if ((checks & kNoRepeatedIndex) && repeated)
      fail(repeated, " degenerate face(s) use the same vertex twice (first: face ", first_r, ")");
    if ((checks & kNoZeroArea) && zero)
      fail(zero, " degenerate face(s) have zero area (first: face ", first_z,
           "); merge or dissolve them first");
  }

  if (checks & kNoDuplicateFaces) {
    // Sort the faces by their sorted vertex triple; equal neighbours are duplicates.
    std::vector<std::array<int, 4>> key(m);
    for (int f = 0; f < m; ++f) {
      std::array<int, 3> t = {F(f, 0), F(f, 1), F(f, 2)};
      std::sort(t.begin(), t.end());
      key[f] = {t[0], t[1], t[2], f};
    }
    std::sort(key.begin(), key.end());
    int dup = 0, first = -1, first_of = -1;
    for (int i = 1; i < m; ++i)
      if (key[i][0] == key[i - 1][0] && key[i][1] == key[i - 1][1] && key[i][2] == key[i - 1][2]) {
        if (first < 0) first = key[i][3], first_of = key[i - 1][3];
        ++dup;
      }
    if (dup) fail(dup, " duplicate face(s) (first: face ", std::max(first, first_of),
                  " repeats face ", std::min(first, first_of), ")");
  }

  if (checks & kNoLooseVertices) {
    std::vector<char> used(n, 0);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) used[F(f, k)] = 1;
    const auto loose = std::count(used.begin(), used.end(), 0);
    if (loose) fail(loose, " loose vertex(es) belong to no face (first: vertex ",
                    std::find(used.begin(), used.end(), 0) - used.begin(), ")");
  }

  // Building the topology is the manifold check; without kManifold the caller gets no topology.
  if (!(checks & kManifold)) {
    Topology t;
    t.n_vertices = n;
    t.n_faces = m;
    return t;
  }
  return build_topology(F, n);
}

Mesh make_mesh(MatX3d V, MatX3i F, unsigned checks) {
  Topology t = validate(V, F, checks);
  return Mesh{std::move(V), std::move(F), std::move(t)};
}

}  // namespace dgmesh
