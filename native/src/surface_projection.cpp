// Closest points on triangle meshes; see surface_projection.h.
#include "dgmesh/surface_projection.h"

#include <algorithm>
#include <limits>
#include <string>

#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"
#include "dgmesh/remesh.h"

namespace dgmesh {

namespace {
Vec3 closest_point_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double l2 = ab.squaredNorm();
  return l2 > 0 ? Vec3(a + std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) * ab) : a;
}

// Ericson's Voronoi-region walk (Real-Time Collision Detection, 5.1.5). On a degenerate triangle
// (collinear or coincident corners) one of its divisions is by zero and the result not finite.
Vec3 closest_point_by_regions(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}
}  // namespace

Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 q = closest_point_by_regions(p, a, b, c);
  if (q.allFinite() || !p.allFinite()) return q;
  // Degenerate triangle: the nearest point of its edges (checked only then: this is a hot path).
  Vec3 best = closest_point_on_segment(p, a, b);
  for (const Vec3& e : {closest_point_on_segment(p, b, c), closest_point_on_segment(p, c, a)})
    if ((e - p).squaredNorm() < (best - p).squaredNorm()) best = e;
  return best;
}

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  return (p - closest_point_on_triangle(p, a, b, c)).norm();
}

double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

SurfaceProjector::SurfaceProjector(const MatX3d& V, const MatX3i& F, const Topology& t)
    : V_(V), F_(F), topo_(t), tree_(V) {}

Vec3 SurfaceProjector::project(const Vec3& p, std::vector<int>& idx, std::vector<double>& d2) const {
  const int k = tree_.knn(p, 4, idx, d2);
  double best = std::numeric_limits<double>::infinity();
  Vec3 q = p;
  for (int i = 0; i < k; ++i)
    for (int j = topo_.vf_offset[idx[i]]; j < topo_.vf_offset[idx[i] + 1]; ++j) {
      const int f = topo_.vf_index[j];
      const Vec3 c = closest_point_on_triangle(p, V_.row(F_(f, 0)), V_.row(F_(f, 1)), V_.row(F_(f, 2)));
      const double dd = (c - p).squaredNorm();
      if (dd < best) best = dd, q = c;
    }
  return q;
}

// Declared in remesh.h.
VecXd point_mesh_distance(const MatX3d& P, const MatX3d& V, const MatX3i& F, int candidates) {
  if (F.rows() == 0) throw MeshError("point_mesh_distance: the mesh has no faces");
  if (!V.allFinite()) throw MeshError("point_mesh_distance: the mesh has NaN or infinite coordinates");
  if (!P.allFinite()) throw MeshError("point_mesh_distance: the points have NaN or infinite coordinates");
  if (candidates < 1)
    throw MeshError("point_mesh_distance: candidates must be >= 1, got " + std::to_string(candidates));
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= V.rows()) throw MeshError("point_mesh_distance: face index out of range");
  MatX3d C(F.rows(), 3);
  for (int f = 0; f < F.rows(); ++f) C.row(f) = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))) / 3.0;
  const KdTree tree(C);
  const int k = std::max(1, std::min<int>(candidates, int(F.rows())));
  const int n = int(P.rows());
  VecXd d(n);
#pragma omp parallel if (n > kParallelMin)
  {
    std::vector<int> idx;
    std::vector<double> sq;
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const Vec3 p = row3(P, i);
      const int m = tree.knn(p, k, idx, sq);
      double best = std::numeric_limits<double>::infinity();
      for (int q = 0; q < m; ++q) {
        const int f = idx[q];
        best = std::min(best, point_triangle_distance(p, row3(V, F(f, 0)), row3(V, F(f, 1)), row3(V, F(f, 2))));
      }
      d[i] = best;
    }
  }
  return d;
}
}  // namespace dgmesh
