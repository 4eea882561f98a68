// Parameterization distortion metrics (thesis 5.3); see uv_metrics.h and unwrap.h.
#include "dgmesh/uv_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "dgmesh/detail/parallel_rows.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace detail {

namespace {

inline double angle2(const Vec2& a, const Vec2& b) { return std::atan2(std::abs(cross2(a, b)), a.dot(b)); }

// Unique undirected edges of F (sorted (min, max) pairs).
std::vector<std::pair<int, int>> unique_edges(const MatX3i& F) {
  std::vector<std::pair<int, int>> e;
  e.reserve(static_cast<size_t>(F.rows()) * 3);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      e.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

inline bool is_zero_area(const TriStretch& t, double sum_area_uv, double eps) {
  return !(0.5 * std::abs(t.uv_area2) > eps * sum_area_uv) || !std::isfinite(t.l2sq);
}

}  // namespace

FaceData face_data(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces, const MatX3i* FUV) {
  const MatX3i& G = FUV ? *FUV : F;
  FaceData d;
  d.tri.resize(n_faces);
  d.area3.resize(n_faces);
  const auto sums = ordered_sums<3>(n_faces, n_faces > 2 * kParallelRows, [&](int f, std::array<double, 3>& s) {
    const int i = F(f, 0), j = F(f, 1), k = F(f, 2);
    const Vec3 q1 = V.row(i), q2 = V.row(j), q3 = V.row(k);
    d.tri[f] = tri_stretch(q1, q2, q3, UV.row(G(f, 0)), UV.row(G(f, 1)), UV.row(G(f, 2)));
    d.area3[f] = 0.5 * (q2 - q1).cross(q3 - q1).norm();
    s[0] += d.area3[f];
    s[1] += 0.5 * std::abs(d.tri[f].uv_area2);
    s[2] += 0.5 * d.tri[f].uv_area2;
  });
  d.sum_area3 = sums[0];
  d.sum_area_uv = sums[1];
  d.signed_area_uv = sums[2];
  return d;
}

UvMetrics metrics_impl(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces,
                       const std::vector<std::pair<int, int>>& edges, double eps, const std::vector<double>* angles3) {
  UvMetrics m;
  const FaceData d = face_data(V, F, UV, n_faces);
  if (d.sum_area3 <= 0 || d.sum_area_uv <= 0) {
    m.stretch_l2 = m.stretch_linf = m.stretch_l2_finite = kInf;
    m.zero_area = n_faces;
    return m;
  }
  // Sander's normalisation: scale the UV map to the surface area, so sigma^2 scales by this.
  const double norm = d.sum_area_uv / d.sum_area3;
  const double orient = d.signed_area_uv >= 0 ? 1.0 : -1.0;
  const bool par = n_faces > 2 * kParallelRows;
  // Sums: L2 stretch, its area, angle and area distortion, flipped and zero-area counts.
  const auto sums = ordered_sums<6>(n_faces, par, [&](int f, std::array<double, 6>& s) {
    const TriStretch& t = d.tri[f];
    if (is_zero_area(t, d.sum_area_uv, eps)) {
      s[5] += 1;
    } else {
      s[0] += d.area3[f] * t.l2sq;
      s[1] += d.area3[f];
      if (orient * t.uv_area2 < 0) s[4] += 1;
    }
    s[3] += std::abs(d.area3[f] / d.sum_area3 - 0.5 * std::abs(t.uv_area2) / d.sum_area_uv);
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3), c = F(f, (k + 2) % 3);
      const double th = angles3 ? (*angles3)[3 * f + k] : angle3(V.row(b) - V.row(a), V.row(c) - V.row(a));
      const double ph = angle2(UV.row(b) - UV.row(a), UV.row(c) - UV.row(a));
      s[2] += std::abs(th - ph);
    }
  });
  const double l2 = sums[0], l2_area = sums[1], angle = sums[2], area = sums[3];
  const int flipped = static_cast<int>(sums[4]), zero = static_cast<int>(sums[5]);
  double g2max = 0;
#pragma omp parallel for schedule(static) reduction(max : g2max) if (par)
  for (int f = 0; f < n_faces; ++f)
    if (!is_zero_area(d.tri[f], d.sum_area_uv, eps)) g2max = std::max(g2max, d.tri[f].gamma2);
  m.flipped = flipped;
  m.zero_area = zero;
  m.stretch_l2_finite = l2_area > 0 ? std::sqrt(norm * l2 / l2_area) : kInf;
  m.stretch_l2 = zero ? kInf : m.stretch_l2_finite;
  m.stretch_linf = zero ? kInf : std::sqrt(norm * g2max);
  m.angle = angle / (3.0 * n_faces);
  m.area = area;

  const int ne = static_cast<int>(edges.size());
  const auto len = ordered_sums<2>(ne, ne > 3 * kParallelRows, [&](int e, std::array<double, 2>& s) {
    s[0] += (V.row(edges[e].first) - V.row(edges[e].second)).norm();
    s[1] += (UV.row(edges[e].first) - UV.row(edges[e].second)).norm();
  });
  const double s3 = len[0], suv = len[1];
  double edge = 0;
  if (s3 > 0 && suv > 0)
    edge = ordered_sums<1>(ne, ne > 3 * kParallelRows, [&](int e, std::array<double, 1>& s) {
      const double l3 = (V.row(edges[e].first) - V.row(edges[e].second)).norm();
      const double luv = (UV.row(edges[e].first) - UV.row(edges[e].second)).norm();
      s[0] += std::abs(l3 / s3 - luv / suv);
    })[0];
  m.edge = edge;
  return m;
}

void vertex_stretch_impl(const FaceData& d, const Topology& topo, double eps, double cap, VecXd& sigma) {
  const double norm = d.sum_area_uv > 0 ? d.sum_area_uv / d.sum_area3 : 1.0;
  sigma.resize(topo.n_vertices);
#pragma omp parallel for schedule(static) if (topo.n_vertices > kParallelRows)
  for (int v = 0; v < topo.n_vertices; ++v) {
    double num = 0, den = 0;
    for (int i = topo.vf_offset[v]; i < topo.vf_offset[v + 1]; ++i) {
      const int f = topo.vf_index[i];
      const TriStretch& t = d.tri[f];
      const double s2 = is_zero_area(t, d.sum_area_uv, eps) ? cap * cap : std::min(norm * t.l2sq, cap * cap);
      num += d.area3[f] * s2;
      den += d.area3[f];
    }
    sigma[v] = den > 0 ? std::sqrt(num / den) : 1.0;
  }
}

}  // namespace detail

namespace {

using detail::face_data;
using detail::FaceData;
using detail::is_zero_area;
using detail::kInf;
using detail::metrics_impl;
using detail::unique_edges;

void check_uv_input(const MatX3d& V, const MatX3i& F, const MatX2d& UV) {
  validate(V, F, kNonEmpty | kIndices | kFinite | kNoRepeatedIndex);
  if (UV.rows() != V.rows())
    throw MeshError("UV must have one row per vertex: " + std::to_string(V.rows()) + " vertices, " +
                    std::to_string(UV.rows()) + " UV rows");
  if (!UV.allFinite()) throw MeshError("UV has NaN or infinite coordinates");
}

// check_uv_input for UVs indexed by FUV: indices in range, finite vertices and UVs where the
// triangles use them (a loose vertex is not looked at, as in the triangle soup this replaces).
void check_indexed_uv_input(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i& FUV) {
  validate(V, F, kNonEmpty | kIndices);
  if (FUV.rows() != F.rows())
    throw MeshError("FUV must have one row per triangle: " + std::to_string(F.rows()) + " triangles, " +
                    std::to_string(FUV.rows()) + " FUV rows");
  const int nuv = static_cast<int>(UV.rows());
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (FUV(f, k) < 0 || FUV(f, k) >= nuv)
        throw MeshError("FUV: triangle " + std::to_string(f) + " refers to UV row " + std::to_string(FUV(f, k)) +
                        ", but UV has " + std::to_string(nuv) + " rows");
  int bad_v = 0, first_v = -1;
  bool bad_uv = false;
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      if (!V.row(F(f, k)).allFinite()) {
        if (first_v < 0 || F(f, k) < first_v) first_v = F(f, k);
        ++bad_v;
      }
      bad_uv = bad_uv || !UV.row(FUV(f, k)).allFinite();
    }
  if (bad_v)
    throw MeshError("vertex coordinates are NaN or infinite at " + std::to_string(bad_v) +
                    " triangle corner(s) (first: vertex " + std::to_string(first_v) + ")");
  if (bad_uv) throw MeshError("UV has NaN or infinite coordinates");
}

VecXd face_stretch_impl(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i* FUV, double zero_area_eps) {
  const int nf = static_cast<int>(F.rows());
  const FaceData d = face_data(V, F, UV, nf, FUV);
  const double norm = d.sum_area3 > 0 ? d.sum_area_uv / d.sum_area3 : 0.0;
  VecXd s(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f)
    s[f] = is_zero_area(d.tri[f], d.sum_area_uv, zero_area_eps) ? kInf : std::sqrt(norm * d.tri[f].l2sq);
  return s;
}

}  // namespace

UvMetrics uv_metrics(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps) {
  check_uv_input(V, F, UV);
  return metrics_impl(V, F, UV, static_cast<int>(F.rows()), unique_edges(F), zero_area_eps);
}

VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps) {
  check_uv_input(V, F, UV);
  return face_stretch_impl(V, F, UV, nullptr, zero_area_eps);
}

VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i& FUV, double zero_area_eps) {
  check_indexed_uv_input(V, F, UV, FUV);
  return face_stretch_impl(V, F, UV, &FUV, zero_area_eps);
}

VecXd uv_vertex_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps) {
  const VecXd fs = uv_face_stretch(V, F, UV, zero_area_eps);
  const VecXd a = face_areas(V, F);
  VecXd num = VecXd::Zero(V.rows()), den = VecXd::Zero(V.rows());
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      num[F(f, k)] += a[f] * fs[f] * fs[f];
      den[F(f, k)] += a[f];
    }
  VecXd s(V.rows());
  for (int v = 0; v < V.rows(); ++v) s[v] = den[v] > 0 ? std::sqrt(num[v] / den[v]) : 0.0;
  return s;
}

}  // namespace dgmesh
