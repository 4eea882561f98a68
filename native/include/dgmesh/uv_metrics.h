/// \file
/// Distortion of a parameterization (thesis 5.3): Sander et al.'s stretch [SSGH01] per triangle
/// (eq. 5.1) and its L2 and Linf norms (eq. 5.5), with the UV map scaled to the surface's area so that
/// 1 is the optimum, and the edge, angle and area distortions. uv_metrics, uv_face_stretch and
/// uv_vertex_stretch are declared in unwrap.h; this header holds the per-face pieces that unwrap()
/// reuses between its equalization steps (not part of the library's interface).
#pragma once
#include <utility>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/mesh.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::detail {

/// Stretch of the affine map P: U -> T of one triangle (thesis 5.2, [SSGH01]): with the partial
/// derivatives S_s, S_t of P, Gamma^2 and gamma^2 are the eigenvalues of [a b; b c], a = S_s.S_s,
/// b = S_s.S_t, c = S_t.S_t. The derivatives are divided by the signed area, so a flipped triangle
/// gets the stretch of its mirror image.
struct TriStretch {
  double uv_area2;  // twice the signed UV area
  double l2sq;      // (Gamma^2 + gamma^2) / 2, not yet area-normalised
  double gamma2;    // Gamma^2
};

inline TriStretch tri_stretch(const Vec3& q1, const Vec3& q2, const Vec3& q3, const Vec2& p1, const Vec2& p2,
                              const Vec2& p3) {
  const double s1 = p1.x(), t1 = p1.y(), s2 = p2.x(), t2 = p2.y(), s3 = p3.x(), t3 = p3.y();
  const double A2 = (s2 - s1) * (t3 - t1) - (s3 - s1) * (t2 - t1);
  if (A2 == 0 || !std::isfinite(A2)) return {0.0, kInf, kInf};
  const Vec3 Ss = (q1 * (t2 - t3) + q2 * (t3 - t1) + q3 * (t1 - t2)) / A2;
  const Vec3 St = (q1 * (s3 - s2) + q2 * (s1 - s3) + q3 * (s2 - s1)) / A2;
  const double a = Ss.squaredNorm(), c = St.squaredNorm(), b = Ss.dot(St);
  const double g2 = 0.5 * ((a + c) + std::sqrt((a - c) * (a - c) + 4 * b * b));
  return {A2, 0.5 * (a + c), g2};
}

/// Angle between two 3D vectors, in [0, pi].
inline double angle3(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

/// Per-face stretch data and the two totals of the area normalisation.
struct FaceData {
  std::vector<TriStretch> tri;
  VecXd area3;
  double sum_area3 = 0, sum_area_uv = 0, signed_area_uv = 0;
};

/// Stretch data of the first n_faces faces of (V, F) with UVs UV.
/// UV rows of the corners: FUV(f, k) when given (UVs indexed apart from the vertices), else F(f, k).
FaceData face_data(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces, const MatX3i* FUV = nullptr);

/// All metrics of the first n_faces faces; edges: the unique undirected edges to measure; angles3:
/// the 3D corner angles (3 per face) when already computed.
UvMetrics metrics_impl(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces,
                       const std::vector<std::pair<int, int>>& edges, double eps,
                       const std::vector<double>* angles3 = nullptr);

/// Per-vertex stretch of eq. 5.1 over the faces around each vertex (all faces of d), area-normalised.
/// Zero-area UV triangles get stretch `cap` so that the weights stay finite.
void vertex_stretch_impl(const FaceData& d, const Topology& topo, double eps, double cap, VecXd& sigma);

}  // namespace dgmesh::detail
