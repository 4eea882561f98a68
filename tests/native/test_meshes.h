// Mesh helpers shared by the native tests.
#pragma once
#include <vector>

#include "dgmesh/shapes.h"

namespace dgmesh::test {

// Mean edge length over the triangles' corners (interior edges counted twice).
inline double mean_edge(const MatX3d& V, const MatX3i& F) {
  double s = 0;
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) s += (V.row(F(f, k)) - V.row(F(f, (k + 1) % 3))).norm();
  return s / (3.0 * F.rows());
}

// Keeps the faces whose centroid satisfies keep(c), and compacts the vertices.
template <class Keep>
TriMesh select_faces(const TriMesh& m, Keep keep) {
  std::vector<int> faces;
  for (int f = 0; f < m.F.rows(); ++f) {
    const Vec3 c = (m.V.row(m.F(f, 0)) + m.V.row(m.F(f, 1)) + m.V.row(m.F(f, 2))) / 3.0;
    if (keep(c)) faces.push_back(f);
  }
  std::vector<int> id(m.V.rows(), -1);
  TriMesh out;
  out.F.resize(static_cast<int>(faces.size()), 3);
  int nv = 0;
  for (size_t i = 0; i < faces.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      int& v = id[m.F(faces[i], k)];
      if (v < 0) v = nv++;
      out.F(static_cast<int>(i), k) = v;
    }
  out.V.resize(nv, 3);
  for (int v = 0; v < m.V.rows(); ++v)
    if (id[v] >= 0) out.V.row(id[v]) = m.V.row(v);
  return out;
}

}  // namespace dgmesh::test
