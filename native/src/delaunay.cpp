// Qhull wrapper: Delaunay by the lifting map (Qhull's 'd'), with the reentrant C API so that
// concurrent calls are safe. Qhull reports errors by longjmp inside qh_new_qhull, which returns
// a non-zero code; we turn that into MeshError after freeing Qhull's memory.
#include "dgmesh/delaunay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include "dgmesh/errors.h"

namespace dgmesh {

namespace {

// Runs qhull on `coords` (n x dim, row-major) and collects the lower Delaunay facets' vertices.
// With `centers`, Qhull runs in Voronoi mode so that the facets Qt splits from a cospherical cell
// (flat tetrahedra among them) share that cell's Voronoi vertex, which their own four points
// cannot define.
std::vector<int> run_qhull(std::vector<double>& coords, int dim, int n, const char* options,
                           std::vector<double>* centers = nullptr) {
  qhT qh_qh;
  qhT* qh = &qh_qh;
  FILE* err = std::tmpfile();  // Qhull's messages, surfaced in the exception text
  qh_zero(qh, err);
  std::string cmd = std::string("qhull ") + options;
  const int code = qh_new_qhull(qh, dim, n, coords.data(), False, const_cast<char*>(cmd.c_str()), nullptr, err);
  std::vector<int> simplices;
  if (!code) {
    if (centers) qh_setvoronoi_all(qh);
    facetT* facet;
    vertexT *vertex, **vertexp;
    FORALLfacets {
      if (facet->upperdelaunay) continue;
      int k = 0;
      FOREACHvertex_(facet->vertices) {
        const int id = qh_pointid(qh, vertex->point);
        if (id < 0 || id >= n) break;  // point at infinity (Qz) or foreign: skip the facet
        simplices.push_back(id);
        ++k;
      }
      if (k != dim + 1) {
        simplices.resize(simplices.size() - k);
      } else if (centers) {
        for (int c = 0; c < dim; ++c) centers->push_back(facet->center ? facet->center[c] : std::nan(""));
      }
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong, totlong;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::string msg;
  if (code && err) {
    std::rewind(err);
    char buf[256];
    while (msg.size() < 400 && std::fgets(buf, sizeof buf, err)) msg += buf;
  }
  if (err) std::fclose(err);
  if (code) {
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    throw MeshError("Delaunay triangulation failed (are the points all " +
                    std::string(dim == 3 ? "coplanar" : "collinear") + "?): qhull error " + std::to_string(code) +
                    (msg.empty() ? "" : ": " + msg.substr(0, msg.find('\n'))));
  }
  return simplices;
}

void check_finite(const double* p, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(p[i])) throw MeshError("Delaunay: point coordinates must be finite");
}

}  // namespace

bool tet_circumcenter(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, Vec3& center) {
  // Solve 2 (p - a) . e_k = |e_k|^2 for the three edges e_k from a, by Cramer's rule.
  const Vec3 u = b - a, v = c - a, w = d - a;
  const double det = u.dot(v.cross(w));
  const double scale = std::max({u.squaredNorm(), v.squaredNorm(), w.squaredNorm()});
  if (!(std::abs(det) > 1e-14 * scale * std::sqrt(scale))) {
    center = (a + b + c + d) / 4;
    return false;
  }
  const Vec3 num = u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v);
  center = a + num / (2 * det);
  return true;
}

Delaunay3 delaunay_3d(const MatX3d& P) {
  const int n = static_cast<int>(P.rows());
  if (n < 4) throw MeshError("Delaunay 3D needs at least 4 points, got " + std::to_string(n));
  check_finite(P.data(), static_cast<size_t>(n) * 3);
  std::vector<double> coords(P.data(), P.data() + static_cast<size_t>(n) * 3);
  // Qbb scales the lifted coordinate (precision), Qt triangulates cospherical cells, Qz adds a
  // point at infinity, which Qhull recommends for cospherical input (spheres, capsules).
  std::vector<double> qcenters;
  const std::vector<int> s = run_qhull(coords, 3, n, "v Qbb Qt Qz", &qcenters);
  const int m = static_cast<int>(s.size() / 4);
  if (m == 0) throw MeshError("Delaunay 3D: no tetrahedra (are the points coplanar?)");
  Delaunay3 out;
  out.tets.resize(m, 4);
  out.circumcenters.resize(m, 3);
  out.circumradii.resize(m);
#pragma omp parallel for schedule(static)
  for (int t = 0; t < m; ++t) {
    int a = s[4 * t], b = s[4 * t + 1], c = s[4 * t + 2], d = s[4 * t + 3];
    const Vec3 pa = row3(P, a), pb = row3(P, b), pc = row3(P, c), pd = row3(P, d);
    if ((pb - pa).dot((pc - pa).cross(pd - pa)) < 0) std::swap(c, d);
    out.tets.row(t) << a, b, c, d;
    Vec3 cc(qcenters[3 * t], qcenters[3 * t + 1], qcenters[3 * t + 2]);
    if (!cc.allFinite()) tet_circumcenter(pa, pb, pc, pd, cc);
    out.circumcenters.row(t) = cc.transpose();
    out.circumradii[t] = (cc - pa).norm();
  }
  out.point_offset.assign(n + 1, 0);
  for (int t = 0; t < m; ++t)
    for (int k = 0; k < 4; ++k) ++out.point_offset[out.tets(t, k) + 1];
  for (int i = 0; i < n; ++i) out.point_offset[i + 1] += out.point_offset[i];
  out.point_tets.resize(out.point_offset[n]);
  std::vector<int> fill(out.point_offset.begin(), out.point_offset.end() - 1);
  for (int t = 0; t < m; ++t)
    for (int k = 0; k < 4; ++k) out.point_tets[fill[out.tets(t, k)]++] = t;
  return out;
}

MatX3i delaunay_2d(const MatX2d& P) {
  const int n = static_cast<int>(P.rows());
  if (n < 3) throw MeshError("Delaunay 2D needs at least 3 points, got " + std::to_string(n));
  check_finite(P.data(), static_cast<size_t>(n) * 2);
  std::vector<double> coords(P.data(), P.data() + static_cast<size_t>(n) * 2);
  const std::vector<int> s = run_qhull(coords, 2, n, "d Qbb Qt Qz");
  const int m = static_cast<int>(s.size() / 3);
  if (m == 0) throw MeshError("Delaunay 2D: no triangles (are the points collinear?)");
  MatX3i F(m, 3);
  for (int t = 0; t < m; ++t) {
    int a = s[3 * t], b = s[3 * t + 1], c = s[3 * t + 2];
    const double cross = (P(b, 0) - P(a, 0)) * (P(c, 1) - P(a, 1)) - (P(b, 1) - P(a, 1)) * (P(c, 0) - P(a, 0));
    if (cross < 0) std::swap(b, c);
    F.row(t) << a, b, c;
  }
  return F;
}

}  // namespace dgmesh
