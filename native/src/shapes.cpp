#include "dgmesh/shapes.h"

#include <cmath>
#include <string>
#include <unordered_map>

#include "dgmesh/detail/edge_key.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"

namespace dgmesh {

TriMesh subdivide_linear(const MatX3d& V, const MatX3i& F) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw MeshError("subdivide_linear: face " + std::to_string(f) + " has vertex index " + std::to_string(F(f, k)) +
                        " outside 0.." + std::to_string(n - 1));
  std::unordered_map<long long, int> mid;
  mid.reserve(3 * m);
  std::vector<Vec3> extra;
  auto midpoint = [&](int a, int b) {
    auto [it, inserted] = mid.try_emplace(detail::edge_key(a, b), n + static_cast<int>(extra.size()));
    if (inserted) extra.push_back(0.5 * (V.row(a) + V.row(b)).transpose());
    return it->second;
  };
  TriMesh out;
  out.F.resize(4 * m, 3);
  for (int f = 0; f < m; ++f) {
    const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.F.row(4 * f + 0) << a, ab, ca;
    out.F.row(4 * f + 1) << ab, b, bc;
    out.F.row(4 * f + 2) << ca, bc, c;
    out.F.row(4 * f + 3) << ab, bc, ca;
  }
  out.V.resize(n + static_cast<int>(extra.size()), 3);
  out.V.topRows(n) = V;
  for (size_t i = 0; i < extra.size(); ++i) out.V.row(n + static_cast<int>(i)) = extra[i];
  return out;
}

TriMesh icosphere(int level, double r) {
  if (level < 0) throw Error("icosphere: level must be >= 0");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriMesh m;
  m.V.resize(12, 3);
  m.V << -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0, 0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, t, 0, -1, t, 0, 1, -t, 0, -1,
      -t, 0, 1;
  m.F.resize(20, 3);
  m.F << 0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3,
      4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1;
  for (int i = 0; i < level; ++i) m = subdivide_linear(m.V, m.F);
  m.V.rowwise().normalize();
  m.V *= r;
  return m;
}

TriMesh torus(double R, double r, int nu, int nv) {
  if (nu < 3 || nv < 3) throw Error("torus: need at least 3 x 3 segments");
  TriMesh m;
  m.V.resize(nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * detail::kPi * i / nu, v = 2 * detail::kPi * j / nv;
      m.V.row(i * nv + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  m.F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
                d = i * nv + (j + 1) % nv;
      m.F.row(2 * (i * nv + j)) << a, b, c;  // outward normals
      m.F.row(2 * (i * nv + j) + 1) << a, c, d;
    }
  return m;
}

TriMesh grid(int nx, int ny) {
  if (nx < 1 || ny < 1) throw Error("grid: need at least 1 x 1 cells");
  TriMesh m;
  m.V.resize((nx + 1) * (ny + 1), 3);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.V.row(j * (nx + 1) + i) << double(i) / nx, double(j) / ny, 0.0;
  m.F.resize(2 * nx * ny, 3);
  int f = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
      if ((i + j) % 2 == 0) {
        m.F.row(f++) << a, b, c;
        m.F.row(f++) << a, c, d;
      } else {
        m.F.row(f++) << a, b, d;
        m.F.row(f++) << b, c, d;
      }
    }
  return m;
}

}  // namespace dgmesh
