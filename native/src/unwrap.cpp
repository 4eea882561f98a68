#include "dgmesh/unwrap.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/parallel.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/validate.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace dgmesh {

namespace {

using detail::Clock;
using detail::cross2;
using detail::kPi;
using detail::profile_mark;
using detail::seconds_since;
using detail::Vec2;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Loops over fewer rows (vertices; faces and ring entries are about 2x and 6x as many) run
// serially: on a loaded machine OpenMP's fork/join and spin-waiting cost more than the work (see
// kFairParallelMin in fair.cpp).
constexpr int kParallelRows = 20000;
// Row blocks of the parallel multigrid smoother, fixed so that the sweep does not depend on the
// thread count. More blocks make a weaker smoother (more of each sweep is Jacobi): with 8, the
// 133K-vertex lion-head's free-boundary unwrap took 12 solves instead of 8 and ended at L2 stretch
// 1.539 instead of 1.386 (bench unwrap_speed).
constexpr int kSmootherBlocks = 2;

// Stretch of the affine map P: U -> T of one triangle (thesis 5.2, [SSGH01]): with the partial
// derivatives S_s, S_t of P, Gamma^2 and gamma^2 are the eigenvalues of [a b; b c], a = S_s.S_s,
// b = S_s.S_t, c = S_t.S_t. The derivatives are divided by the signed area, so a flipped triangle
// gets the stretch of its mirror image.
struct TriStretch {
  double uv_area2;  // twice the signed UV area
  double l2sq;      // (Gamma^2 + gamma^2) / 2, not yet area-normalised
  double gamma2;    // Gamma^2
};

inline TriStretch tri_stretch(const Vec3& q1, const Vec3& q2, const Vec3& q3, const Vec2& p1,
                              const Vec2& p2, const Vec2& p3) {
  const double s1 = p1.x(), t1 = p1.y(), s2 = p2.x(), t2 = p2.y(), s3 = p3.x(), t3 = p3.y();
  const double A2 = (s2 - s1) * (t3 - t1) - (s3 - s1) * (t2 - t1);
  if (A2 == 0 || !std::isfinite(A2)) return {0.0, kInf, kInf};
  const Vec3 Ss = (q1 * (t2 - t3) + q2 * (t3 - t1) + q3 * (t1 - t2)) / A2;
  const Vec3 St = (q1 * (s3 - s2) + q2 * (s1 - s3) + q3 * (s2 - s1)) / A2;
  const double a = Ss.squaredNorm(), c = St.squaredNorm(), b = Ss.dot(St);
  const double g2 = 0.5 * ((a + c) + std::sqrt((a - c) * (a - c) + 4 * b * b));
  return {A2, 0.5 * (a + c), g2};
}

inline double angle3(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }
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

// Per-face stretch data and the two totals of the area normalisation.
struct FaceData {
  std::vector<TriStretch> tri;
  VecXd area3;
  double sum_area3 = 0, sum_area_uv = 0, signed_area_uv = 0;
};

// UV rows of the corners: FUV(f, k) when given (UVs indexed apart from the vertices), else F(f, k).
FaceData face_data(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces, const MatX3i* FUV = nullptr) {
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

inline bool is_zero_area(const TriStretch& t, double sum_area_uv, double eps) {
  return !(0.5 * std::abs(t.uv_area2) > eps * sum_area_uv) || !std::isfinite(t.l2sq);
}

UvMetrics metrics_impl(const MatX3d& V, const MatX3i& F, const MatX2d& UV, int n_faces,
                       const std::vector<std::pair<int, int>>& edges, double eps,
                       const std::vector<double>* angles3 = nullptr) {
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

VecXd face_stretch_impl(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i* FUV,
                        double zero_area_eps) {
  const int nf = static_cast<int>(F.rows());
  const FaceData d = face_data(V, F, UV, nf, FUV);
  const double norm = d.sum_area3 > 0 ? d.sum_area_uv / d.sum_area3 : 0.0;
  VecXd s(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f)
    s[f] = is_zero_area(d.tri[f], d.sum_area_uv, zero_area_eps) ? kInf : std::sqrt(norm * d.tri[f].l2sq);
  return s;
}

// The stretch part of the metrics (L2, Linf, flips, zero area, area distortion) from the face data
// of the first nf faces of d: what the Uopt stopping rule needs, without the edge and angle
// distortions (NaN here), whose square roots and arc tangents cost more than the rest together.
UvMetrics stretch_metrics(const FaceData& d, int nf, double eps) {
  UvMetrics m;
  m.edge = m.angle = std::numeric_limits<double>::quiet_NaN();
  double s3 = 0, suv = 0, ssigned = 0;
  for (int f = 0; f < nf; ++f) {
    s3 += d.area3[f];
    suv += 0.5 * std::abs(d.tri[f].uv_area2);
    ssigned += 0.5 * d.tri[f].uv_area2;
  }
  if (s3 <= 0 || suv <= 0) {
    m.stretch_l2 = m.stretch_linf = m.stretch_l2_finite = kInf;
    m.zero_area = nf;
    return m;
  }
  const double norm = suv / s3, orient = ssigned >= 0 ? 1.0 : -1.0;
  double l2 = 0, l2_area = 0, g2max = 0, area = 0;
  int flipped = 0, zero = 0;
  for (int f = 0; f < nf; ++f) {
    const TriStretch& t = d.tri[f];
    if (is_zero_area(t, suv, eps)) {
      ++zero;
    } else {
      l2 += d.area3[f] * t.l2sq;
      l2_area += d.area3[f];
      g2max = std::max(g2max, t.gamma2);
      if (orient * t.uv_area2 < 0) ++flipped;
    }
    area += std::abs(d.area3[f] / s3 - 0.5 * std::abs(t.uv_area2) / suv);
  }
  m.flipped = flipped;
  m.zero_area = zero;
  m.stretch_l2_finite = l2_area > 0 ? std::sqrt(norm * l2 / l2_area) : kInf;
  m.stretch_l2 = zero ? kInf : m.stretch_l2_finite;
  m.stretch_linf = zero ? kInf : std::sqrt(norm * g2max);
  m.area = area;
  return m;
}

// Per-vertex stretch of eq. 5.1 over the faces around each vertex (all faces of d), area-normalised.
// Zero-area UV triangles get stretch `cap` so that the weights stay finite.
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

// ----- weights of eq. 5.2 ------------------------------------------------------------------------

struct RingScratch {
  std::vector<Vec3> e;
  std::vector<double> len, theta, lambda;
  std::vector<Vec2> q;
  void resize(size_t d) {
    e.resize(d), len.resize(d), theta.resize(d), lambda.resize(d), q.resize(d);
  }
};

// Mean-value weights [Flo03] of an interior vertex with closed ring: (tan(a_{j-1}/2) + tan(a_j/2)) / |e_j|.
void mean_value_ring(RingScratch& s, int d, double* w) {
  for (int j = 0; j < d; ++j) {
    const int jp = (j + d - 1) % d;
    // tan(a/2) = |a x b| / (|a||b| + a.b)
    auto half_tan = [&](int a, int b) {
      const double den = s.len[a] * s.len[b] + s.e[a].dot(s.e[b]);
      const double num = s.e[a].cross(s.e[b]).norm();
      return den > 1e-300 ? num / den : 1e12;
    };
    w[j] = (half_tan(jp, j) + half_tan(j, (j + 1) % d)) / std::max(s.len[j], 1e-300);
  }
}

// Floater's shape-preserving weights [Flo97]: flatten the ring by the geodesic polar map (lengths
// kept, angles scaled to sum 2 pi), then average, over every neighbour k, the barycentric
// coordinates of the centre in the triangle formed by q_k and the ring segment the ray from q_k
// through the centre crosses. Returns false if the flattened ring does not contain the centre.
bool floater_ring(RingScratch& s, int d, double* w) {
  double total = 0;
  for (int k = 0; k < d; ++k) total += s.theta[k];
  if (!(total > 0)) return false;
  double psi = 0;
  for (int k = 0; k < d; ++k) {
    s.q[k] = s.len[k] * Vec2(std::cos(psi), std::sin(psi));
    psi += s.theta[k] * 2 * kPi / total;
    s.lambda[k] = 0;
  }
  for (int k = 0; k < d; ++k) {
    bool found = false;
    for (int l = 0; l < d && !found; ++l) {
      const int l1 = (l + 1) % d;
      if (l == k || l1 == k) continue;
      const double A = cross2(s.q[l] - s.q[k], s.q[l1] - s.q[k]);
      if (!(std::abs(A) > 0)) continue;
      const double bk = cross2(s.q[l], s.q[l1]) / A, bl = cross2(s.q[l1], s.q[k]) / A,
                   bl1 = cross2(s.q[k], s.q[l]) / A;
      const double tol = -1e-12;
      if (bk >= tol && bl >= tol && bl1 >= tol) {
        s.lambda[k] += std::max(bk, 0.0);
        s.lambda[l] += std::max(bl, 0.0);
        s.lambda[l1] += std::max(bl1, 0.0);
        found = true;
      }
    }
    if (!found) return false;
  }
  double sum = 0;
  for (int k = 0; k < d; ++k) sum += s.lambda[k];
  if (!(sum > 0)) return false;
  for (int k = 0; k < d; ++k) w[k] = s.lambda[k] / sum;
  return true;
}

struct WeightStats {
  int fallback = 0;  // Floater rings that used mean-value weights instead
  int negative = 0;  // negative cotangent weights
};

// Base weights w_ij of every free vertex, stored at the ring positions of topo.vv_index.
std::vector<double> base_weights(const MatX3d& V, const Topology& topo,
                                 const std::vector<char>& fixed, UvWeights kind, WeightStats& stats) {
  std::vector<double> w(topo.vv_index.size(), 0.0);
  int fallback = 0, negative = 0;
  int max_d = 0;
  for (int v = 0; v < topo.n_vertices; ++v) max_d = std::max(max_d, topo.valence(v));
#pragma omp parallel reduction(+ : fallback, negative) if (topo.n_vertices > kParallelRows)
  {
    RingScratch s;
    s.resize(static_cast<size_t>(max_d));
#pragma omp for schedule(dynamic, 512)
    for (int v = 0; v < topo.n_vertices; ++v) {
      if (fixed[v]) continue;
      const int o = topo.vv_offset[v], d = topo.valence(v);
      double* wv = w.data() + o;
      if (kind == UvWeights::Uniform) {
        for (int k = 0; k < d; ++k) wv[k] = 1.0;
        continue;
      }
      const Vec3 p = V.row(v);
      for (int k = 0; k < d; ++k) {
        s.e[k] = V.row(topo.vv_index[o + k]).transpose() - p;
        s.len[k] = s.e[k].norm();
      }
      for (int k = 0; k < d; ++k) s.theta[k] = angle3(s.e[k], s.e[(k + 1) % d]);
      if (kind == UvWeights::Cotangent) {
        for (int k = 0; k < d; ++k) {
          const int kp = (k + d - 1) % d, kn = (k + 1) % d;
          // Angles opposite the edge (v, k): at k-1 in triangle (v, k-1, k), at k+1 in (v, k, k+1).
          const Vec3 u1 = -s.e[kp], v1 = s.e[k] - s.e[kp];
          const Vec3 u2 = -s.e[kn], v2 = s.e[k] - s.e[kn];
          const double c1 = u1.dot(v1) / std::max(u1.cross(v1).norm(), 1e-300);
          const double c2 = u2.dot(v2) / std::max(u2.cross(v2).norm(), 1e-300);
          wv[k] = c1 + c2;
          if (wv[k] < 0) ++negative;
        }
        continue;
      }
      if (kind == UvWeights::Floater && floater_ring(s, d, wv)) continue;
      if (kind == UvWeights::Floater) ++fallback;
      mean_value_ring(s, d, wv);
    }
  }
  stats.fallback = fallback;
  stats.negative = negative;
  return w;
}

// ----- boundary polygons --------------------------------------------------------------------------

std::vector<double> arc_length(const MatX3d& V, const std::vector<int>& loop) {
  const size_t nb = loop.size();
  std::vector<double> t(nb + 1, 0.0);
  for (size_t k = 0; k < nb; ++k) t[k + 1] = t[k] + (V.row(loop[(k + 1) % nb]) - V.row(loop[k])).norm();
  const double total = t[nb] > 0 ? t[nb] : 1.0;
  for (double& x : t) x /= total;
  return t;  // t[nb] == 1
}

void place_circle(const std::vector<int>& loop, const std::vector<double>& t, MatX2d& U) {
  for (size_t k = 0; k < loop.size(); ++k) {
    const double a = 2 * kPi * t[k];
    U.row(loop[k]) << 0.5 + 0.5 * std::cos(a), 0.5 + 0.5 * std::sin(a);
  }
}

// Square corners: quarter arc-length spacing, rotated until no chord (an edge joining two outer
// boundary vertices through the interior) has both ends on one closed side. Such a chord cuts off
// a region that the convex-combination map flattens to zero area (degenerate ears).
bool square_corners(const std::vector<int>& loop, const std::vector<double>& t,
                    const std::vector<std::pair<int, int>>& chords, int (&c)[4]) {
  const int nb = static_cast<int>(loop.size());
  if (nb < 4) return false;
  auto nearest = [&](double x) {
    x -= std::floor(x);
    const int hi = static_cast<int>(std::lower_bound(t.begin(), t.begin() + nb + 1, x) - t.begin());
    const int lo = std::max(hi - 1, 0);
    const int k = (hi <= nb && std::abs(t[hi] - x) < std::abs(x - t[lo])) ? hi : lo;
    return k % nb;
  };
  for (int r = 0; r < nb; ++r) {
    int d[5];
    d[0] = 0;
    bool ok = true;
    for (int s = 1; s < 4 && ok; ++s) {
      d[s] = (nearest(t[r] + 0.25 * s) - r + nb) % nb;
      ok = d[s] > d[s - 1];
    }
    if (!ok) continue;
    d[4] = nb;
    auto sides = [&](int o) {  // bit mask of the closed sides holding loop offset o
      unsigned m = 0;
      for (int s = 0; s < 4; ++s)
        if (d[s] <= o && o <= d[s + 1]) m |= 1u << s;
      if (o == 0) m |= 1u << 3;
      return m;
    };
    for (const auto& ch : chords) {
      if (sides((ch.first - r + nb) % nb) & sides((ch.second - r + nb) % nb)) {
        ok = false;
        break;
      }
    }
    if (!ok) continue;
    for (int s = 0; s < 4; ++s) c[s] = (r + d[s]) % nb;
    return true;
  }
  return false;
}

void place_square(const std::vector<int>& loop, const std::vector<double>& t, const int (&c)[4], MatX2d& U) {
  const int nb = static_cast<int>(loop.size());
  const Vec2 P[5] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}};
  for (int s = 0; s < 4; ++s) {
    const int a = c[s], b = c[(s + 1) % 4];
    const int n = (b - a + nb) % nb;
    auto tt = [&](int k) {  // arc length from the loop start, unwrapped past a
      const int idx = (a + k) % nb;
      return t[idx] + (idx < a ? 1.0 : 0.0);
    };
    const double ta = tt(0), len = tt(n) + ((a + n) % nb == a ? 1.0 : 0.0) - ta;
    for (int k = 0; k < n; ++k) {
      const double f = len > 0 ? (tt(k) - ta) / len : double(k) / n;
      U.row(loop[(a + k) % nb]) = P[s] + f * (P[s + 1] - P[s]);
    }
  }
}

// The closed convex curve the outer loop lies on, parameterised by arc length s in [0, period):
// a circle, or a polygon (the square's corners, or the free boundary's points). Loop vertex k sits
// at at(s[k]); anchors (the square's corners) never move.
struct BoundaryCurve {
  bool circle = false;
  std::vector<Vec2> P;    // polygon vertices
  std::vector<double> S;  // cumulative length at P[i], S.back() == period
  double period = 1;
  std::vector<double> s;  // parameter of each loop vertex, increasing from s[0]
  std::vector<int> anchors;

  void set_polygon(std::vector<Vec2> pts) {
    P = std::move(pts);
    S.assign(P.size() + 1, 0.0);
    for (size_t i = 0; i < P.size(); ++i) S[i + 1] = S[i] + (P[(i + 1) % P.size()] - P[i]).norm();
    period = S.back();
  }
  Vec2 at(double x) const {
    x -= period * std::floor(x / period);
    if (circle) {
      const double a = 2 * kPi * x / period;
      return Vec2(0.5 + 0.5 * std::cos(a), 0.5 + 0.5 * std::sin(a));
    }
    const size_t i = std::min(static_cast<size_t>(std::upper_bound(S.begin(), S.end(), x) - S.begin()), S.size() - 1) - 1;
    const double len = S[i + 1] - S[i];
    const double f = len > 0 ? (x - S[i]) / len : 0.0;
    return P[i] + f * (P[(i + 1) % P.size()] - P[i]);
  }
  void place(const std::vector<int>& loop, MatX2d& U) const {
    for (size_t k = 0; k < loop.size(); ++k) U.row(loop[k]) = at(s[k]).transpose();
  }
  // One-dimensional stretch equalization along the curve (the boundary analogue of eq. 5.4): the
  // UV length of boundary edge k grows by ((sigma_k + sigma_k+1) / 2)^eta, then every run
  // between two anchors is rescaled to keep its anchors in place.
  void slide(const std::vector<int>& loop, const VecXd& sigma, double eta) {
    const int nb = static_cast<int>(loop.size());
    std::vector<double> su(nb + 1);
    for (int k = 0; k < nb; ++k) su[k] = s[k];
    su[nb] = s[0] + period;
    const int na = static_cast<int>(anchors.size());
    for (int a = 0; a < na; ++a) {
      const int k0 = anchors[a], k1 = a + 1 < na ? anchors[a + 1] : anchors[0] + nb;
      double total_new = 0;
      std::vector<double> d(k1 - k0);
      for (int k = k0; k < k1; ++k) {
        const double sg = 0.5 * (sigma[loop[k % nb]] + sigma[loop[(k + 1) % nb]]);
        d[k - k0] = (su[k + 1] - su[k]) * (eta == 1.0 ? sg : std::pow(sg, eta));
        total_new += d[k - k0];
      }
      if (!(total_new > 0) || !std::isfinite(total_new)) continue;
      const double scale = (su[k1] - su[k0]) / total_new;
      double x = su[k0];
      for (int k = k0 + 1; k < k1; ++k) {
        x += d[k - 1 - k0] * scale;
        s[k % nb] = k >= nb ? x - period : x;
      }
    }
    if (na == 1) {
      // One anchor (circle, free boundary) only fixes the curve's sliding gauge: shift the whole
      // loop so its mean move along the curve is zero instead of pinning the loop's first vertex,
      // which would make the map depend on the vertex order.
      double mean = 0;
      for (int k = 0; k < nb; ++k) mean += s[k] - su[k];
      mean /= nb;
      for (int k = 0; k < nb; ++k) s[k] -= mean;
      while (s[0] < 0) for (int k = 0; k < nb; ++k) s[k] += period;
    }
    // Keep s increasing from s[0] (wrap-around runs may have produced values below s[0]).
    for (int k = 1; k < nb; ++k)
      while (s[k] < s[0]) s[k] += period;
  }
};

// Least-squares conformal map with two pinned boundary vertices (LSCM; its free boundary is the
// natural boundary of Desbrun et al.'s discrete conformal map [DMA02]). The conformal energy is
// E_D(u) + E_D(v) - A(u, v), with the cotangent Dirichlet energy and the signed area of the image,
// whose boundary terms come from the boundary edges of the faces.
MatX2d lscm(const MatX3d& V, const MatX3i& F, const Topology& topo, int pin0, int pin1) {
  const int n = static_cast<int>(V.rows());
  const int m = static_cast<int>(F.rows());
  // Unknowns: u and v of every vertex but the pins, interleaved (each vertex's 2x2 block together:
  // on lion-head the LDL^T factorisation takes half the time of u-block-then-v-block); the pins'
  // values move to the right-hand side.
  std::vector<int> idx(2 * n, -1);
  int nf = 0;
  for (int v = 0; v < n; ++v) {
    if (v != pin0 && v != pin1) idx[v] = nf++, idx[v + n] = nf++;
  }
  Eigen::VectorXd xp = Eigen::VectorXd::Zero(2 * n);
  xp[pin1] = 1;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nf);
  // One pass straight into the reduced system's lower triangle (SimplicialLDLT reads only that).
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(m) * 12 + topo.n_vertices * 4);
  auto add = [&](int r, int c, double x) {
    const int ir = idx[r], ic = idx[c];
    if (ir < 0) return;
    if (ic < 0) {
      rhs[ir] -= x * xp[c];
    } else if (ic <= ir) {
      trip.emplace_back(ir, ic, x);
    }
  };
  // E_D(u) + E_D(v) with the cotangent Dirichlet energy E_D(u) = 1/4 sum_edges (cot a + cot b) (u_i - u_j)^2.
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = F(f, (k + 1) % 3), j = F(f, (k + 2) % 3);
      const Vec3 ab = V.row(i) - V.row(F(f, k)), ac = V.row(j) - V.row(F(f, k));
      const double w = 0.5 * ab.dot(ac) / std::max(ab.cross(ac).norm(), 1e-300);  // cot / 2
      for (int o = 0; o <= n; o += n) {
        add(i + o, i + o, w), add(j + o, j + o, w);
        add(i + o, j + o, -w), add(j + o, i + o, -w);
      }
    }
  // -A(u,v) = -1/2 sum over boundary half-edges a->b of (u_a v_b - u_b v_a), as 1/2 x^T M x.
  for (int e = 0; e < topo.n_edges(); ++e) {
    if (topo.edge_faces(e, 1) >= 0) continue;
    const int f = topo.edge_faces(e, 0);
    int a = -1, b = -1;
    for (int k = 0; k < 3; ++k) {
      if (topo.face_edges(f, k) == e) a = F(f, k), b = F(f, (k + 1) % 3);
    }
    add(a, b + n, -0.5), add(b + n, a, -0.5);
    add(b, a + n, 0.5), add(a + n, b, 0.5);
  }
  SpMat Qf(nf, nf);
  Qf.setFromTriplets(trip.begin(), trip.end());
  profile_mark("lscm_build");
  SparseSolver solver;
  solver.factor(Qf, SparseSolver::Kind::Cholesky);
  profile_mark("lscm_factor");
  const Eigen::VectorXd x = solver.solve(rhs);
  MatX2d U(n, 2);
  for (int v = 0; v < n; ++v) {
    U(v, 0) = idx[v] >= 0 ? x[idx[v]] : xp[v];
    U(v, 1) = idx[v + n] >= 0 ? x[idx[v + n]] : xp[v + n];
  }
  return U;
}

// Fits the points of `loop` into [0,1]^2 (uniform scale, centred).
void fit_unit_box(MatX2d& U, const std::vector<int>& rows) {
  Vec2 lo(kInf, kInf), hi(-kInf, -kInf);
  for (int v : rows) lo = lo.cwiseMin(U.row(v).transpose()), hi = hi.cwiseMax(U.row(v).transpose());
  const double s = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  const Vec2 off = 0.5 * (Vec2(1, 1) - (hi - lo) / s);
  for (int v : rows) U.row(v) = ((U.row(v).transpose() - lo) / s + off).transpose();
}

// Reflex vertices of the closed polygon loop (counter-clockwise).
int reflex_count(const MatX2d& U, const std::vector<int>& loop) {
  const int nb = static_cast<int>(loop.size());
  int reflex = 0;
  for (int k = 0; k < nb; ++k) {
    const Vec2 a = U.row(loop[(k + nb - 1) % nb]), b = U.row(loop[k]), c = U.row(loop[(k + 1) % nb]);
    const Vec2 e0 = b - a, e1 = c - b;
    if (cross2(e0, e1) < -1e-12 * e0.norm() * e1.norm()) ++reflex;
  }
  return reflex;
}

// A diameter-like pair of loop vertices that does not depend on the vertex numbering: the farthest
// from the lexicographically smallest position, then the farthest from that (ties likewise).
std::pair<int, int> diameter_pair(const MatX3d& V, const std::vector<int>& loop) {
  auto less = [&](int a, int b) {
    for (int c = 0; c < 3; ++c)
      if (V(a, c) != V(b, c)) return V(a, c) < V(b, c);
    return false;
  };
  auto farthest = [&](int from) {
    int best = loop[0];
    double bd = -1;
    for (int v : loop) {
      const double d = (V.row(v) - V.row(from)).squaredNorm();
      if (d > bd || (d == bd && less(v, best))) bd = d, best = v;
    }
    return best;
  };
  const int start = *std::min_element(loop.begin(), loop.end(), less);
  const int p0 = farthest(start);
  return {p0, farthest(p0)};
}

// ----- linear solves of eq. 5.3 -------------------------------------------------------------------

// The two coordinates u and v share the matrix of eq. 5.3, so they are solved together: every
// sparse sweep reads the matrix once for both columns (the solves are memory-bound).
using Blk = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

constexpr int kCoarseRows = 4000;       // coarsest multigrid level above kSmallChart unknowns
constexpr int kSmallChart = 50000;
constexpr int kDenseCoarseRows = 300;   // coarsest level (dense LU) up to kSmallChart unknowns
constexpr int kDirectRows = 1000;       // UvSolver::Auto solves charts up to this size by UMFPACK
// Equalization steps between multigrid rebuilds: the steps change the weights gradually, so a
// hierarchy (aggregates, prolongators, coarse operators) built for one step still preconditions
// the next ones with the current finest level. Measured on lion-head (free boundary, eta 0.5,
// 14 solves): 57 BiCGSTAB iterations in all when rebuilt every 4th solve, 61 every 6th, 77 every
// 9th; rebuilding for every solve saved about one iteration in all for four times the setup.
// Only on charts up to kSmallAmgRows unknowns: on larger ones the early steps change the weights
// by more (stretches up to stretch_cap) and a stale hierarchy cost more than its setup (measured on
// mannequin-devil x16, 207K: 26-30 instead of 12-19 iterations per step).
constexpr int kAmgReuse = 3;
constexpr int kCheapIters = 6;
// UvWeights::Auto drops the cotangent weights when a solve needs more BiCGSTAB iterations than
// this (their negative weights can make the system indefinite: 704 iterations for U0 of a 207K
// chart, against 9 with Floater's weights).
constexpr int kGiveUpIters = 100;
constexpr int kSmallAmgRows = 20000;  // also: stricter aggregation strength up to here (Amg::setup)
// Charts above this many faces compute the free boundary's conformal map on one thread while the
// other builds the weights, the matrix and the multigrid hierarchy of eq. 5.3.
constexpr int kOverlapFaces = 4000;

// Y = A X (beta = 0) or Y += A X (beta = 1) for a row-major CSR matrix and two columns.
void spmm(const SpMatR& A, const Blk& X, Blk& Y, bool add = false) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* val = A.valuePtr();
  const double* x = X.data();
  double* y = Y.data();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (int i = 0; i < n; ++i) {
    double s0 = 0, s1 = 0;
    for (int p = outer[i]; p < outer[i + 1]; ++p) {
      const double a = val[p];
      const int j = inner[p];
      s0 += a * x[2 * j], s1 += a * x[2 * j + 1];
    }
    if (add) {
      y[2 * i] += s0, y[2 * i + 1] += s1;
    } else {
      y[2 * i] = s0, y[2 * i + 1] = s1;
    }
  }
}

// R = B - A X
void residual(const SpMatR& A, const Blk& X, const Blk& B, Blk& R) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* val = A.valuePtr();
  const double* x = X.data();
  const double* b = B.data();
  double* r = R.data();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
  for (int i = 0; i < n; ++i) {
    double s0 = b[2 * i], s1 = b[2 * i + 1];
    for (int p = outer[i]; p < outer[i + 1]; ++p) {
      const double a = val[p];
      const int j = inner[p];
      s0 -= a * x[2 * j], s1 -= a * x[2 * j + 1];
    }
    r[2 * i] = s0, r[2 * i + 1] = s1;
  }
}

// X * Y for row-major sparse matrices, by blocks of rows in parallel (Eigen's product is serial).
SpMatR par_product(const SpMatR& X, const SpMatR& Y) {
  const int n = static_cast<int>(X.rows());
#ifdef _OPENMP
  const int nt = n > kParallelRows ? omp_get_max_threads() : 1;
#else
  const int nt = 1;
#endif
  if (nt <= 1) return SpMatR(X * Y);
  std::vector<SpMatR> part(nt);
#pragma omp parallel for schedule(static, 1) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    const int lo = static_cast<int>(static_cast<long long>(n) * t / nt);
    const int hi = static_cast<int>(static_cast<long long>(n) * (t + 1) / nt);
    part[t] = X.middleRows(lo, hi - lo) * Y;
    part[t].makeCompressed();
  }
  Eigen::Index nnz = 0;
  for (const SpMatR& p : part) nnz += p.nonZeros();
  SpMatR Z(n, Y.cols());
  Z.resizeNonZeros(nnz);
  int* outer = Z.outerIndexPtr();
  int row = 0, off = 0;
  outer[0] = 0;
  for (const SpMatR& p : part) {
    std::copy(p.innerIndexPtr(), p.innerIndexPtr() + p.nonZeros(), Z.innerIndexPtr() + off);
    std::copy(p.valuePtr(), p.valuePtr() + p.nonZeros(), Z.valuePtr() + off);
    for (int i = 0; i < p.rows(); ++i) outer[row + i + 1] = off + p.outerIndexPtr()[i + 1];
    row += static_cast<int>(p.rows());
    off += static_cast<int>(p.nonZeros());
  }
  return Z;
}

// Column-wise dot products of two n x 2 blocks.
Vec2 coldot(const Blk& a, const Blk& b) {
  const int n = static_cast<int>(a.rows());
  const double* x = a.data();
  const double* y = b.data();
  const auto s = ordered_sums<2>(n, n > 4 * kParallelRows, [&](int i, std::array<double, 2>& a) {
    a[0] += x[2 * i] * y[2 * i], a[1] += x[2 * i + 1] * y[2 * i + 1];
  });
  return Vec2(s[0], s[1]);
}

// Dense LU with partial pivoting of the coarsest multigrid level (at most kDenseCoarseRows rows),
// unblocked and serial: Eigen's blocked LU forks OpenMP threads for its products even at this
// size, which costs more than the factorisation on a loaded machine.
class SmallLU {
 public:
  void factor(const SpMatR& A) {
    n_ = static_cast<int>(A.rows());
    lu_.assign(static_cast<size_t>(n_) * n_, 0.0);
    perm_.resize(n_);
    for (int i = 0; i < n_; ++i)
      for (SpMatR::InnerIterator it(A, i); it; ++it) lu_[static_cast<size_t>(i) * n_ + it.col()] = it.value();
    for (int k = 0; k < n_; ++k) {
      int p = k;
      for (int i = k + 1; i < n_; ++i)
        if (std::abs(at(i, k)) > std::abs(at(p, k))) p = i;
      perm_[k] = p;
      if (p != k)
        for (int j = 0; j < n_; ++j) std::swap(at(k, j), at(p, j));
      const double d = at(k, k);
      if (d == 0) throw SolverError("unwrap: multigrid coarse level is singular");
      const double inv = 1.0 / d;
      double* rk = &lu_[static_cast<size_t>(k) * n_];
      for (int i = k + 1; i < n_; ++i) {
        double* ri = &lu_[static_cast<size_t>(i) * n_];
        const double l = ri[k] * inv;
        ri[k] = l;
        if (l != 0)
          for (int j = k + 1; j < n_; ++j) ri[j] -= l * rk[j];
      }
    }
  }
  // X = A^-1 B for the two columns.
  void solve(const Blk& B, Blk& X) const {
    X = B;
    for (int k = 0; k < n_; ++k)
      if (perm_[k] != k) std::swap(X(k, 0), X(perm_[k], 0)), std::swap(X(k, 1), X(perm_[k], 1));
    for (int i = 1; i < n_; ++i) {
      const double* ri = &lu_[static_cast<size_t>(i) * n_];
      double s0 = X(i, 0), s1 = X(i, 1);
      for (int j = 0; j < i; ++j) s0 -= ri[j] * X(j, 0), s1 -= ri[j] * X(j, 1);
      X(i, 0) = s0, X(i, 1) = s1;
    }
    for (int i = n_ - 1; i >= 0; --i) {
      const double* ri = &lu_[static_cast<size_t>(i) * n_];
      double s0 = X(i, 0), s1 = X(i, 1);
      for (int j = i + 1; j < n_; ++j) s0 -= ri[j] * X(j, 0), s1 -= ri[j] * X(j, 1);
      X(i, 0) = s0 / ri[i], X(i, 1) = s1 / ri[i];
    }
  }

 private:
  double& at(int i, int j) { return lu_[static_cast<size_t>(i) * n_ + j]; }
  int n_ = 0;
  std::vector<double> lu_;
  std::vector<int> perm_;
};

// Smoothed-aggregation algebraic multigrid (Vanek, Mandel, Brezina 1996) as the preconditioner
// of BiCGSTAB: the systems of eq. 5.3 are M-matrices on a planar mesh graph, where a V-cycle costs
// a few sparse products and reduces the error by a constant factor, so a solve is O(n) instead of
// the O(n^1.5) and BLAS-bound work of a sparse LU. The aggregates follow the strong connections,
// which equalization makes anisotropic, so the hierarchy is rebuilt every kAmgReuse + 1 solves
// (in between, refresh() swaps in the finest level's new values); a hierarchy kept for all steps
// costs more iterations than the setup saves.
class Amg {
 public:
  void setup(const SpMatR& A0) {
    levels_.resize(1);
    levels_[0].A = A0;
    // Coarsen down to a level solved directly. On large charts a larger coarsest level (solved
    // by a sparse LU) costs a little more to factor but keeps the strongly anisotropic first
    // equalization steps (weights divided by stretches up to stretch_cap) at ~20 iterations
    // instead of ~40. On small and medium charts the sparse LU of that level (~800 rows at 8K
    // unknowns) cost more than the whole rest of a step, so they coarsen further, to a level
    // small enough for a dense LU (measured on lion-head: 7 instead of 5.5 iterations per step,
    // but about a quarter less CPU per step).
    const int kc = A0.rows() > kSmallChart ? kCoarseRows : kDenseCoarseRows;
    // Strength threshold of the aggregation: on charts up to kSmallAmgRows unknowns the stricter
    // 0.25 follows the equalization's anisotropy better (lion-head, 8K: 3 instead of 4 BiCGSTAB
    // iterations per step, a quarter less solve time); at 33K the usual 0.1 was slightly faster.
    const double theta = A0.rows() > kSmallAmgRows ? 0.1 : 0.25;
    while (levels_.back().A.rows() > kc && levels_.size() < 16) {
      Level& L = levels_.back();
      const SpMatR& A = L.A;
      const int n = static_cast<int>(A.rows());
      L.inv_diag.resize(n);
      for (int i = 0; i < n; ++i) {
        double d = 0;
        for (SpMatR::InnerIterator it(A, i); it; ++it)
          if (it.col() == i) d = it.value();
        L.inv_diag[i] = d != 0 ? 1.0 / d : 0.0;
      }
      int na = 0;
      const std::vector<int> agg = aggregate(A, theta, na);
      if (na >= n * 0.8 || na < 1) break;  // not coarsening: stop here
      // Smoothed prolongator P = (I - omega D^-1 A) P_tent, omega = 2/3 (rows of A are normalised),
      // built row by row: row i holds, per aggregate of i's neighbours, the sum of their entries.
      const double omega = 2.0 / 3.0;
      const int* outer = A.outerIndexPtr();
      const int* inner = A.innerIndexPtr();
      const double* val = A.valuePtr();
      std::vector<int> tcol(A.nonZeros()), count(n);
      std::vector<double> tval(A.nonZeros());
#pragma omp parallel for schedule(static) if (n > kParallelRows)
      for (int i = 0; i < n; ++i) {
        const int b = outer[i];
        int k = b;  // row i's sorted, merged entries in [b, k) (at most one per entry of A)
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const int a = agg[inner[p]];
          const double v = (inner[p] == i ? 1.0 : 0.0) - omega * L.inv_diag[i] * val[p];
          int q = b;
          while (q < k && tcol[q] < a) ++q;
          if (q < k && tcol[q] == a) {
            tval[q] += v;
            continue;
          }
          for (int r = k; r > q; --r) tcol[r] = tcol[r - 1], tval[r] = tval[r - 1];
          tcol[q] = a, tval[q] = v, ++k;
        }
        count[i] = k - b;
      }
      L.P.resize(n, na);
      int* pout = L.P.outerIndexPtr();
      pout[0] = 0;
      for (int i = 0; i < n; ++i) pout[i + 1] = pout[i] + count[i];
      L.P.resizeNonZeros(pout[n]);
      int* pin = L.P.innerIndexPtr();
      double* pval = L.P.valuePtr();
#pragma omp parallel for schedule(static) if (n > kParallelRows)
      for (int i = 0; i < n; ++i) {
        std::copy(tcol.begin() + outer[i], tcol.begin() + outer[i] + count[i], pin + pout[i]);
        std::copy(tval.begin() + outer[i], tval.begin() + outer[i] + count[i], pval + pout[i]);
      }
      L.R = L.P.transpose();
      const SpMatR AP = par_product(A, L.P);
      Level next;
      next.A = par_product(L.R, AP).pruned(1e-14, 1.0);
      levels_.emplace_back(std::move(next));
    }
    Level& C = levels_.back();
    dense_ = C.A.rows() <= kDenseCoarseRows;
    if (dense_) {
      dlu_.factor(C.A);
    } else {
      const SpMat Ac = C.A;
      coarse_.compute(Ac);
      if (coarse_.info() != Eigen::Success) throw SolverError("unwrap: multigrid coarse solve failed");
    }
    for (Level& L : levels_) {
      const int n = static_cast<int>(L.A.rows());
      L.x.resize(n, 2), L.b.resize(n, 2), L.r.resize(n, 2), L.xo.resize(n, 2);
    }
  }

  // Keeps the aggregates, prolongators and coarse operators of the last setup() and only takes
  // the finest level's values from A0 (same sparsity pattern): the smoother sees the current
  // system, the coarse correction the one of an earlier step. Equalization changes the weights
  // gradually, so the stale coarse levels still remove the smooth error.
  bool refresh(const SpMatR& A0) {
    if (levels_.empty() || levels_[0].A.rows() != A0.rows() || levels_[0].A.nonZeros() != A0.nonZeros()) return false;
    Level& L = levels_[0];
    std::copy(A0.valuePtr(), A0.valuePtr() + A0.nonZeros(), L.A.valuePtr());
    if (levels_.size() == 1) return false;  // the finest level is the coarse direct solve
    const int n = static_cast<int>(L.A.rows());
    for (int i = 0; i < n; ++i) {
      double d = 0;
      for (SpMatR::InnerIterator it(L.A, i); it; ++it)
        if (it.col() == i) d = it.value();
      L.inv_diag[i] = d != 0 ? 1.0 / d : 0.0;
    }
    return true;
  }

  // One V-cycle for A X = B from X = 0.
  void apply(const Blk& b, Blk& x) {
    levels_[0].b = b;
    cycle(0);
    x = levels_[0].x;
  }
  int n_levels() const { return static_cast<int>(levels_.size()); }

 private:
  struct Level {
    SpMatR A, P, R;
    VecXd inv_diag;
    Blk x, b, r, xo;
  };

  // Aggregation of smoothed aggregation (phases 1 and 2 of Vanek et al.): strong connections are
  // |a_ij| >= theta max_k |a_ik|. Returns the aggregate of every node.
  static std::vector<int> aggregate(const SpMatR& A, double theta, int& na) {
    const int n = static_cast<int>(A.rows());
    std::vector<int> agg(n, -1);
    na = 0;
    std::vector<double> rmax(n, 0.0);
    for (int i = 0; i < n; ++i)
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (it.col() != i) rmax[i] = std::max(rmax[i], std::abs(it.value()));
    auto strong = [&](int i, const SpMatR::InnerIterator& it) {
      return it.col() != i && std::abs(it.value()) >= theta * rmax[i];
    };
    // Phase 1: a node whose strong neighbours are all free starts an aggregate with them.
    for (int i = 0; i < n; ++i) {
      if (agg[i] >= 0) continue;
      bool free = true;
      for (SpMatR::InnerIterator it(A, i); it && free; ++it)
        if (strong(i, it) && agg[it.col()] >= 0) free = false;
      if (!free) continue;
      agg[i] = na;
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (strong(i, it)) agg[it.col()] = na;
      ++na;
    }
    // Phase 2: the rest join the aggregate of their strongest aggregated neighbour.
    std::vector<int> agg2 = agg;
    for (int i = 0; i < n; ++i) {
      if (agg[i] >= 0) continue;
      double best = -1;
      for (SpMatR::InnerIterator it(A, i); it; ++it)
        if (it.col() != i && agg[it.col()] >= 0 && std::abs(it.value()) > best)
          best = std::abs(it.value()), agg2[i] = agg[it.col()];
      if (agg2[i] < 0) agg2[i] = na++;
    }
    return agg2;
  }

  // Hybrid Gauss-Seidel sweep (forward or backward) on both columns: Gauss-Seidel inside each
  // block of rows, Jacobi across blocks (values of other blocks are read from the copy
  // xo), so the sweep runs in parallel without data races.
  static void gauss_seidel(Level& L, bool forward) {
    const int n = static_cast<int>(L.A.rows());
    const int* outer = L.A.outerIndexPtr();
    const int* inner = L.A.innerIndexPtr();
    const double* val = L.A.valuePtr();
    const double* b = L.b.data();
    double* x = L.x.data();
    const bool par = n > kParallelRows;
    if (!par) {
      // Serial sweep: x_i += (b_i - A_i x) / a_ii over the whole row (diagonal included), which
      // equals the Gauss-Seidel update without a branch per entry.
      const double* dinv = L.inv_diag.data();
      for (int k = 0; k < n; ++k) {
        const int i = forward ? k : n - 1 - k;
        double s0 = b[2 * i], s1 = b[2 * i + 1];
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const double a = val[p];
          const int j = inner[p];
          s0 -= a * x[2 * j], s1 -= a * x[2 * j + 1];
        }
        x[2 * i] += s0 * dinv[i], x[2 * i + 1] += s1 * dinv[i];
      }
      return;
    }
    L.xo = L.x;
    const double* xo = L.xo.data();
    // A fixed number of row blocks, not one per thread: the sweep (Gauss-Seidel inside a block,
    // Jacobi across blocks) then does not depend on the thread count.
#pragma omp parallel for schedule(static) if (par)
    for (int blk = 0; blk < kSmootherBlocks; ++blk) {
      const int lo = static_cast<int>(static_cast<long long>(n) * blk / kSmootherBlocks);
      const int hi = static_cast<int>(static_cast<long long>(n) * (blk + 1) / kSmootherBlocks);
      for (int k = lo; k < hi; ++k) {
        const int i = forward ? k : lo + hi - 1 - k;
        double s0 = b[2 * i], s1 = b[2 * i + 1];
        for (int p = outer[i]; p < outer[i + 1]; ++p) {
          const int j = inner[p];
          if (j == i) continue;
          const double* xj = (j >= lo && j < hi) ? x : xo;
          s0 -= val[p] * xj[2 * j], s1 -= val[p] * xj[2 * j + 1];
        }
        x[2 * i] = s0 * L.inv_diag[i], x[2 * i + 1] = s1 * L.inv_diag[i];
      }
    }
  }

  void cycle(size_t l) {
    Level& L = levels_[l];
    if (l + 1 == levels_.size()) {
      if (dense_) {
        dlu_.solve(L.b, L.x);
        return;
      }
      const Eigen::MatrixXd bc = L.b;
      const Eigen::MatrixXd xc = coarse_.solve(bc);
      L.x = xc;
      return;
    }
    L.x.setZero();
    gauss_seidel(L, true);
    residual(L.A, L.x, L.b, L.r);
    Level& C = levels_[l + 1];
    spmm(L.R, L.r, C.b);
    cycle(l + 1);
    spmm(L.P, C.x, L.x, true);
    gauss_seidel(L, false);
  }

  std::vector<Level> levels_;
  Eigen::SparseLU<SpMat, Eigen::COLAMDOrdering<int>> coarse_;
  bool dense_ = false;
  SmallLU dlu_;
};

// Right-preconditioned BiCGSTAB (van der Vorst 1992) on A X = B for both columns at once, each
// with its own scalars, from the guess in X. A column stops when its relative residual reaches
// tol (its updates become no-ops). Returns the iterations, or -1 if a column did not converge.
int bicgstab_amg(const SpMatR& A, Amg& M, const Blk& B, Blk& X, double tol, int max_it) {
  const int n = static_cast<int>(A.rows());
  const Vec2 bnorm = coldot(B, B).cwiseSqrt();
  Blk r(n, 2), r0, p = Blk::Zero(n, 2), v = Blk::Zero(n, 2), y(n, 2), z(n, 2), s(n, 2), t(n, 2);
  residual(A, X, B, r);
  bool active[2];
  const Vec2 rn = coldot(r, r).cwiseSqrt();
  for (int c = 0; c < 2; ++c) {
    if (bnorm[c] == 0) X.col(c).setZero();
    active[c] = bnorm[c] > 0 && rn[c] > tol * bnorm[c];
    if (!active[c]) r.col(c).setZero();
  }
  if (!active[0] && !active[1]) return 0;
  r0 = r;
  Vec2 rho(1, 1), alpha(1, 1), omega(1, 1);
  for (int it = 1; it <= max_it; ++it) {
    const Vec2 rho1 = coldot(r0, r);
    Vec2 beta;
    for (int c = 0; c < 2; ++c) {
      if (active[c] && std::abs(rho1[c]) < 1e-300) return -1;
      beta[c] = active[c] ? (rho1[c] / rho[c]) * (alpha[c] / omega[c]) : 0.0;
    }
    // p = r + beta (p - omega v)
#pragma omp parallel for schedule(static) if (n > 4 * kParallelRows)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) p(i, c) = r(i, c) + beta[c] * (p(i, c) - omega[c] * v(i, c));
    M.apply(p, y);
    spmm(A, y, v);
    const Vec2 r0v = coldot(r0, v);
    for (int c = 0; c < 2; ++c) alpha[c] = active[c] ? rho1[c] / r0v[c] : 0.0;
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) s(i, c) = r(i, c) - alpha[c] * v(i, c);
    const Vec2 sn = coldot(s, s).cwiseSqrt();
    for (int c = 0; c < 2; ++c)
      if (active[c] && sn[c] <= tol * bnorm[c]) {
        X.col(c) += alpha[c] * y.col(c);
        active[c] = false;
        alpha[c] = 0;
        s.col(c).setZero();
      }
    if (!active[0] && !active[1]) return it;
    M.apply(s, z);
    spmm(A, z, t);
    const Vec2 ts = coldot(t, s), tt = coldot(t, t);
    for (int c = 0; c < 2; ++c) omega[c] = active[c] ? ts[c] / tt[c] : 0.0;
#pragma omp parallel for schedule(static) if (n > 4 * kParallelRows)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 2; ++c) {
        X(i, c) += alpha[c] * y(i, c) + omega[c] * z(i, c);
        r(i, c) = s(i, c) - omega[c] * t(i, c);
      }
    const Vec2 rn2 = coldot(r, r).cwiseSqrt();
    for (int c = 0; c < 2; ++c) {
      if (!active[c]) continue;
      if (!std::isfinite(omega[c]) || omega[c] == 0) return -1;
      if (rn2[c] <= tol * bnorm[c]) active[c] = false, r.col(c).setZero();
    }
    if (!active[0] && !active[1]) return it;
    rho = rho1;
  }
  return -1;
}

class ChartSolver {
 public:
  // Auto: multigrid above kDirectRows unknowns. With a dense coarsest level on small and medium
  // charts it is faster than UMFPACK (whose BLAS-bound fronts grow faster than n, and whose BLAS
  // spawns threads): measured median wall seconds of a whole Uopt (free boundary, eta 0.5,
  // sliding), multigrid vs UMFPACK: 0.044 vs 0.096 on head (1.5K vertices), 0.05 vs 0.10 on
  // mushroom (2.3K); 0.84 vs 1.54 CPU at 52K. Below, a whole Uopt takes milliseconds either way
  // and the exact solve keeps Floater's linear precision exact (a planar chart maps to itself to
  // rounding, not to the iterative tolerance).
  ChartSolver(UvSolver kind, double tol, int n)
      : kind_(kind != UvSolver::Auto ? kind : n > kDirectRows ? UvSolver::Multigrid : UvSolver::Umfpack), tol_(tol) {}

  const char* name() const {
    switch (kind_) {
      case UvSolver::Umfpack: return "umfpack";
      case UvSolver::SparseLU: return "sparselu";
      case UvSolver::BiCGSTAB: return "bicgstab+ilut";
      case UvSolver::Multigrid: return "bicgstab+amg";
      default: return "?";
    }
  }

  // Solves A X = B; X holds the initial guess (the previous map) on entry. Ar is A in row-major
  // storage (the multigrid works on rows).
  int solve(const SpMat& A, const SpMatR& Ar, const Eigen::MatrixXd& B, Eigen::MatrixXd& X) {
    if (kind_ == UvSolver::Multigrid) {
      profile_mark("other");
      // Large charts keep a hierarchy only while it stays cheap: after a solve of at most
      // kCheapIters iterations (the late, small equalization steps).
      const int reuse = Ar.rows() <= kSmallAmgRows || last_iters_ <= kCheapIters ? kAmgReuse : 0;
      if (prepared_ && amg_.refresh(Ar)) {
        reuse_left_ = reuse;
      } else if (reuse_left_ > 0 && amg_.refresh(Ar)) {
        --reuse_left_;
      } else {
        amg_.setup(Ar);
        reuse_left_ = reuse;
      }
      prepared_ = false;
      profile_mark("amg_setup");
      Blk Bb = B, Xb = X;
      const int iters = bicgstab_amg(Ar, amg_, Bb, Xb, tol_, max_iters_);
      last_iters_ = iters >= 0 ? iters : 1 << 20;
      if (last_iters_ > kCheapIters && Ar.rows() > kSmallAmgRows) reuse_left_ = 0;
      const bool ok = iters >= 0 && Xb.allFinite();
      if (ok) X = Xb;
      profile_mark("krylov");
      if (ok) return iters;
      if (!fallback_) return -1;
      kind_ = UvSolver::Umfpack;
      fell_back_ = true;
    }
    if (kind_ == UvSolver::BiCGSTAB) {
      bicg_.setTolerance(tol_);
      bicg_.setMaxIterations(std::max(1000, static_cast<int>(A.rows() / 4)));
      bicg_.preconditioner().setDroptol(1e-4);
      bicg_.preconditioner().setFillfactor(10);
      bicg_.compute(A);
      int iters = 0;
      bool ok = bicg_.info() == Eigen::Success;
      for (int c = 0; c < B.cols() && ok; ++c) {
        Eigen::VectorXd x = bicg_.solveWithGuess(B.col(c), X.col(c));
        ok = bicg_.info() == Eigen::Success && x.allFinite();
        iters += static_cast<int>(bicg_.iterations());
        if (ok) X.col(c) = x;
      }
      if (ok) return iters;
      // Did not converge: fall back to a direct solve for this and the later steps.
      kind_ = UvSolver::Umfpack;
      fell_back_ = true;
    }
    if (!direct_.factored() || direct_.rows() != A.rows()) {
      direct_.factor(A, kind_ == UvSolver::SparseLU ? SparseSolver::Kind::LU : SparseSolver::Kind::Umfpack);
    } else {
      direct_.refactor(A);  // same pattern: the symbolic analysis is reused
    }
    X = direct_.solve(B);
    return 0;
  }
  // Builds the multigrid hierarchy for Ar ahead of the first solve (which then only refreshes
  // the finest level's values).
  void prepare(const SpMatR& Ar) {
    if (kind_ != UvSolver::Multigrid) return;
    amg_.setup(Ar);
    prepared_ = true;
  }
  bool fell_back() const { return fell_back_; }
  // A multigrid solve that does not converge within `max_iterations` returns -1 instead of
  // falling back to UMFPACK (UvWeights::Auto's cotangent attempt gives up instead).
  void give_up_after(int max_iterations) { max_iters_ = max_iterations, fallback_ = false; }
  bool iterative() const { return kind_ == UvSolver::Multigrid || kind_ == UvSolver::BiCGSTAB; }
  double tolerance() const { return tol_; }
  void set_tolerance(double t) { tol_ = t; }

 private:
  UvSolver kind_;
  double tol_;
  bool fell_back_ = false;
  bool fallback_ = true;
  int max_iters_ = 500;
  int reuse_left_ = 0;  // solves left before the multigrid hierarchy is rebuilt
  int last_iters_ = 1 << 20;
  bool prepared_ = false;
  SparseSolver direct_;
  Eigen::BiCGSTAB<SpMat, Eigen::IncompleteLUT<double>> bicg_;
  Amg amg_;
};

// The system of eq. 5.3 over the free vertices, row-normalised (A_ii = 1, A_ij = -w_ij / sum_k w_ik),
// with the pattern built once and the values refilled in place for every step.
struct System {
  std::vector<int> row;       // free vertex -> row, -1 if fixed
  std::vector<int> free_v;    // row -> vertex
  std::vector<int> pos;       // per ring entry: index into A's values, -1 if the neighbour is fixed
  std::vector<int> diag_pos;  // per row
  std::vector<int> pos_r, diag_pos_r;  // the same for Ar
  SpMat A;
  SpMatR Ar;  // A in row-major storage, filled alongside (no conversion per step)
  Eigen::MatrixXd B;

  void build(const Topology& topo, const std::vector<char>& fixed) {
    const int n = topo.n_vertices;
    row.assign(n, -1);
    free_v.clear();
    for (int v = 0; v < n; ++v)
      if (!fixed[v]) row[v] = static_cast<int>(free_v.size()), free_v.push_back(v);
    const int m = static_cast<int>(free_v.size());
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(topo.vv_index.size() + m);
    for (int r = 0; r < m; ++r) {
      const int v = free_v[r];
      trip.emplace_back(r, r, 1.0);
      for (int k = topo.vv_offset[v]; k < topo.vv_offset[v + 1]; ++k)
        if (row[topo.vv_index[k]] >= 0) trip.emplace_back(r, row[topo.vv_index[k]], 1.0);
    }
    A.resize(m, m);
    A.setFromTriplets(trip.begin(), trip.end());
    A.makeCompressed();
    auto find = [&](int r, int c) {
      const int* inner = A.innerIndexPtr();
      const int b = A.outerIndexPtr()[c], e = A.outerIndexPtr()[c + 1];
      return static_cast<int>(std::lower_bound(inner + b, inner + e, r) - inner);
    };
    Ar = A;
    auto find_r = [&](int r, int c) {
      const int* inner = Ar.innerIndexPtr();
      const int b = Ar.outerIndexPtr()[r], e = Ar.outerIndexPtr()[r + 1];
      return static_cast<int>(std::lower_bound(inner + b, inner + e, c) - inner);
    };
    pos.assign(topo.vv_index.size(), -1);
    pos_r.assign(topo.vv_index.size(), -1);
    diag_pos.resize(m);
    diag_pos_r.resize(m);
#pragma omp parallel for schedule(static) if (m > kParallelRows)
    for (int r = 0; r < m; ++r) {
      const int v = free_v[r];
      diag_pos[r] = find(r, r);
      diag_pos_r[r] = find_r(r, r);
      for (int k = topo.vv_offset[v]; k < topo.vv_offset[v + 1]; ++k) {
        const int c = row[topo.vv_index[k]];
        if (c >= 0) pos[k] = find(r, c), pos_r[k] = find_r(r, c);
      }
    }
    B.resize(m, 2);
  }

  // Fills A and B from the weights w (ring positions) and the fixed positions in U.
  // Returns the number of rows whose weights do not sum to a positive value (uniform used there).
  int fill(const Topology& topo, const std::vector<double>& w, const MatX2d& U) {
    double* val = A.valuePtr();
    double* val_r = Ar.valuePtr();
    const int m = static_cast<int>(free_v.size());
    int bad = 0;
#pragma omp parallel for schedule(static) reduction(+ : bad) if (m > kParallelRows)
    for (int r = 0; r < m; ++r) {
      const int v = free_v[r], o = topo.vv_offset[v], d = topo.valence(v);
      double sum = 0;
      for (int k = 0; k < d; ++k) sum += w[o + k];
      const bool uniform = !(sum > 0) || !std::isfinite(sum);
      if (uniform) ++bad, sum = d;
      double bx = 0, by = 0;
      val[diag_pos[r]] = val_r[diag_pos_r[r]] = 1.0;
      for (int k = 0; k < d; ++k) {
        const double lam = (uniform ? 1.0 : w[o + k]) / sum;
        if (pos[o + k] >= 0) {
          val[pos[o + k]] = val_r[pos_r[o + k]] = -lam;
        } else {
          const int j = topo.vv_index[o + k];
          bx += lam * U(j, 0), by += lam * U(j, 1);
        }
      }
      B(r, 0) = bx, B(r, 1) = by;
    }
    return bad;
  }
};

}  // namespace

// ----- public API ---------------------------------------------------------------------------------

UvMetrics uv_metrics(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps) {
  check_uv_input(V, F, UV);
  return metrics_impl(V, F, UV, static_cast<int>(F.rows()), unique_edges(F), zero_area_eps);
}

VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, double zero_area_eps) {
  check_uv_input(V, F, UV);
  return face_stretch_impl(V, F, UV, nullptr, zero_area_eps);
}

VecXd uv_face_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const MatX3i& FUV,
                      double zero_area_eps) {
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

VecXi connected_labels(int n, const MatX2i& pairs) {
  if (n < 0) throw MeshError("connected_labels: negative size");
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int p = 0; p < pairs.rows(); ++p) {
    const int a = pairs(p, 0), b = pairs(p, 1);
    if (a < 0 || b < 0 || a >= n || b >= n)
      throw MeshError("connected_labels: pair " + std::to_string(p) + " has an index out of range");
    const int ra = root(a), rb = root(b);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  VecXi label(n);
  std::vector<int> id(n, -1);
  int next = 0;
  for (int i = 0; i < n; ++i) {
    const int r = root(i);
    if (id[r] < 0) id[r] = next++;
    label[i] = id[r];
  }
  return label;
}

namespace {

// unwrap() for one kind of weights. With `fold_stops`, the first map with flipped triangles (not
// re-solved tighter) or a solve that gives up (kGiveUpIters) ends the call at once with `folded`
// set: UvWeights::Auto then starts again with Floater's weights instead of equalizing a folded map.
// `lscm`: the free boundary's conformal map, computed here when empty (it does not depend on the
// weights, so Auto's second attempt reuses the first one's).
UnwrapResult unwrap_weights(const MatX3d& Vin, const MatX3i& Fin, const UnwrapOptions& opt,
                            const ProgressFn& progress_fn, bool fold_stops, bool& folded, MatX2d& lscm_map) {
  folded = false;
  // CPU seconds per phase on stderr when DGMESH_UNWRAP_PROFILE is set (how the speed work was measured).
  detail::ProfileScope profile("DGMESH_UNWRAP_PROFILE");
  Progress progress(progress_fn);
  progress(0.0);
  Mesh mesh = make_mesh(Vin, Fin, kSurface | kNoLooseVertices);
  const Topology& topo = mesh.topo;
  const int n = topo.n_vertices, nf = topo.n_faces;
  if (topo.n_components != 1)
    throw MeshError("unwrap: the mesh has " + std::to_string(topo.n_components) +
                    " connected components; a chart must be one connected piece (unwrap them separately)");
  const int nb = static_cast<int>(topo.boundary_loops.size());
  if (nb == 0)
    throw MeshError("unwrap: the mesh is closed (no boundary loop); cut it into disk-like charts along seams first");
  const int chi = n - topo.n_edges() + nf;
  const int genus2 = 2 - chi - nb;
  if (genus2 != 0)
    throw MeshError("unwrap: the chart has " + std::to_string(genus2 / 2) +
                    " handle(s) (genus > 0, Euler characteristic " + std::to_string(chi) + " with " +
                    std::to_string(nb) + " boundary loop(s)); cut it along seams into disks first");

  UnwrapResult res;
  const auto t_start = Clock::now();

  // Outer loop: the longest; the others are holes.
  int outer = 0;
  std::vector<double> loop_len(nb, 0.0);
  for (int l = 0; l < nb; ++l) {
    const auto& L = topo.boundary_loops[l];
    for (size_t k = 0; k < L.size(); ++k) loop_len[l] += (mesh.V.row(L[(k + 1) % L.size()]) - mesh.V.row(L[k])).norm();
    if (loop_len[l] > loop_len[outer]) outer = l;
  }
  res.n_holes = nb - 1;

  // Fill every hole by a fan around a virtual vertex at the loop's centroid (thesis 5.5).
  MatX3d Vf = mesh.V;
  MatX3i Ff = mesh.F;
  Topology topo_filled;
  const Topology* T = &topo;
  if (nb > 1) {
    int extra_f = 0;
    for (int l = 0; l < nb; ++l)
      if (l != outer) extra_f += static_cast<int>(topo.boundary_loops[l].size());
    Vf.conservativeResize(n + nb - 1, 3);
    Ff.conservativeResize(nf + extra_f, 3);
    int vi = n, fi = nf;
    for (int l = 0; l < nb; ++l) {
      if (l == outer) continue;
      const auto& L = topo.boundary_loops[l];
      Vec3 c = Vec3::Zero();
      for (int v : L) c += mesh.V.row(v).transpose();
      Vf.row(vi) = (c / static_cast<double>(L.size())).transpose();
      // The loop runs along its faces' edges a->b, so the fan face holds b->a.
      for (size_t k = 0; k < L.size(); ++k) Ff.row(fi++) << L[(k + 1) % L.size()], L[k], vi;
      ++vi;
    }
    topo_filled = build_topology(Ff, static_cast<int>(Vf.rows()));
    T = &topo_filled;
  }
  const int nv = T->n_vertices;
  std::vector<int> loop = topo.boundary_loops[outer];
  std::vector<char> fixed(nv, 0);
  // Ears: outer boundary vertices with a single triangle (a, tip, b). All three corners would lie
  // on the polygon, a zero-area (on a straight side) or sliver (on the circle) UV triangle. The tips
  // are taken off the polygon and placed after every solve with the ear's own 3D shape on the UV
  // chord (a, b), outside the convex polygon, where they cannot overlap anything.
  struct Ear {
    int tip, a, b;
  };
  std::vector<Ear> ears;
  if (loop.size() > 5) {
    std::vector<int> kept;
    for (size_t k = 0; k < loop.size(); ++k) {
      const int v = loop[k];
      const bool single = topo.vf_offset[v + 1] - topo.vf_offset[v] == 1;
      const bool prev_tip = !ears.empty() && ears.back().tip == loop[(k + loop.size() - 1) % loop.size()];
      const bool wraps = k + 1 == loop.size() && !ears.empty() && ears.front().tip == loop[0];
      if (single && !prev_tip && !wraps) {
        const int f = topo.vf_index[topo.vf_offset[v]];
        const int c = mesh.F(f, 0) == v ? 0 : mesh.F(f, 1) == v ? 1 : 2;
        ears.push_back({v, mesh.F(f, (c + 1) % 3), mesh.F(f, (c + 2) % 3)});  // (tip, a, b) in face order
        fixed[v] = 1;
      } else {
        kept.push_back(v);
      }
    }
    if (kept.size() >= 4) {
      loop.swap(kept);
    } else {
      for (const Ear& e : ears) fixed[e.tip] = 0;
      ears.clear();
    }
  }
  std::vector<int> loop_pos(nv, -1);
  for (size_t k = 0; k < loop.size(); ++k) fixed[loop[k]] = 1, loop_pos[loop[k]] = static_cast<int>(k);
  auto place_ears = [&](MatX2d& Ucur) {
    for (const Ear& e : ears) {
      const Vec3 A = mesh.V.row(e.a), B = mesh.V.row(e.b), P = mesh.V.row(e.tip);
      const Vec3 ab = B - A;
      const double l2 = std::max(ab.squaredNorm(), 1e-300);
      const double along = (P - A).dot(ab) / l2, across = (P - A).cross(ab).norm() / l2;
      const Vec2 ua = Ucur.row(e.a), ub = Ucur.row(e.b), d = ub - ua, perp(-d.y(), d.x());
      Vec2 t = ua + along * d + across * perp;
      if (cross2(ua - t, ub - t) < 0) t = ua + along * d - across * perp;  // face (tip, a, b) counter-clockwise
      Ucur.row(e.tip) = t.transpose();
    }
  };

  // ---- weights and matrix of eq. 5.3 (they do not depend on where the polygon puts the boundary) ----
  WeightStats ws;
  std::vector<double> w;
  System sys;
  const int n_free = static_cast<int>(std::count(fixed.begin(), fixed.begin() + nv, 0));
  ChartSolver solver(opt.solver, opt.tolerance, n_free);
  res.solver = solver.name();
  std::vector<std::pair<int, int>> edges(topo.n_edges());
  for (int e = 0; e < topo.n_edges(); ++e) edges[e] = {topo.edges(e, 0), topo.edges(e, 1)};
  // The 3D angles of the angle distortion do not change between steps.
  std::vector<double> angles3(3 * static_cast<size_t>(nf));
  auto prepare_system = [&] {
    w = base_weights(Vf, *T, fixed, opt.weights, ws);
    sys.build(*T, fixed);
    sys.fill(*T, w, MatX2d::Zero(nv, 2));  // the matrix; the right-hand side follows the boundary
    if (n_free > 0) solver.prepare(sys.Ar);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3), c = mesh.F(f, (k + 2) % 3);
        angles3[3 * f + k] = angle3(mesh.V.row(b) - mesh.V.row(a), mesh.V.row(c) - mesh.V.row(a));
      }
  };

  // ---- boundary polygon ----
  bool system_ready = false;
  MatX2d U = MatX2d::Zero(nv, 2);
  const std::vector<double> t = arc_length(mesh.V, loop);
  UvBoundary bnd = opt.boundary;
  BoundaryCurve curve;
  curve.anchors = {0};
  if (bnd == UvBoundary::Free) {
    // LSCM depends (mildly) on the pins, so they must not depend on the vertex order.
    const auto [p0, p1] = diameter_pair(mesh.V, loop);
    profile_mark("setup");
    // The conformal map and the system of eq. 5.3 are independent: on two threads they overlap
    // (one fork; each side runs serially inside).
    MatX2d L;
    std::exception_ptr err[2];
#pragma omp parallel sections num_threads(2) if (nf > kOverlapFaces)
    {
#pragma omp section
      {
        try {
          L = lscm_map.rows() ? lscm_map : lscm(mesh.V, mesh.F, topo, p0, p1);
        } catch (...) {
          err[0] = std::current_exception();
        }
      }
#pragma omp section
      {
        try {
          prepare_system();
        } catch (...) {
          err[1] = std::current_exception();
        }
      }
    }
    for (const auto& e : err)
      if (e) std::rethrow_exception(e);
    system_ready = true;
    lscm_map = L;
    profile_mark("lscm+system");
    // The conformal energy favours the faces' orientation; mirror if the image came out negative.
    double signed_area = 0;
    for (int f = 0; f < nf; ++f) {
      const Vec2 a = L.row(mesh.F(f, 0)), b = L.row(mesh.F(f, 1)), c = L.row(mesh.F(f, 2));
      signed_area += cross2(b - a, c - a);
    }
    if (signed_area < 0) L.col(1) *= -1;
    for (int v : loop) U.row(v) = L.row(v);
    fit_unit_box(U, loop);
    // A non-convex natural boundary usually still gives an embedding; where it does not, the
    // equalization falls back to the circle (below).
    res.boundary_convex = reflex_count(U, loop) == 0;
    std::vector<Vec2> pts;
    for (int v : loop) pts.push_back(U.row(v).transpose());
    curve.set_polygon(std::move(pts));
    curve.s.assign(curve.S.begin(), curve.S.end() - 1);
  }
  if (bnd == UvBoundary::Square) {
    std::vector<std::pair<int, int>> chords;
    for (int e = 0; e < T->n_edges(); ++e) {
      const int a = T->edges(e, 0), b = T->edges(e, 1);
      if (loop_pos[a] < 0 || loop_pos[b] < 0) continue;
      const int gap = std::abs(loop_pos[a] - loop_pos[b]);
      if (gap != 1 && gap != static_cast<int>(loop.size()) - 1) chords.emplace_back(loop_pos[a], loop_pos[b]);
    }
    int c[4];
    if (square_corners(loop, t, chords, c)) {
      place_square(loop, t, c, U);
      for (int s = 0; s < 4; ++s) res.corners.push_back(loop[c[s]]);
      // Rotate the loop so that it starts at the first corner: then s increases from 0.
      std::rotate(loop.begin(), loop.begin() + c[0], loop.end());
      for (size_t k = 0; k < loop.size(); ++k) loop_pos[loop[k]] = static_cast<int>(k);
      curve.set_polygon({Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)});
      curve.s.resize(loop.size());
      for (size_t k = 0; k < loop.size(); ++k) {
        const Vec2 p = U.row(loop[k]);
        // Perimeter parameter of a point on the square, walking counter-clockwise from (0,0).
        double x = p.y() <= 0 ? p.x() : p.x() >= 1 ? 1 + p.y() : p.y() >= 1 ? 3 - p.x() : 4 - p.y();
        if (k == 0) x = 0;
        while (k > 0 && x < curve.s[k - 1]) x += 4;
        curve.s[k] = x;
      }
      curve.anchors.clear();
      for (int q = 0; q < 4; ++q) curve.anchors.push_back(loop_pos[res.corners[q]]);
    } else {
      res.warnings.push_back("no placement of the square's corners avoids degenerate triangles (" +
                             std::to_string(loop.size()) + " boundary vertices); used a circle");
      bnd = UvBoundary::Circle;
    }
  }
  if (bnd == UvBoundary::Circle) {
    place_circle(loop, t, U);
    curve.circle = true;
    curve.period = 1;
    curve.s.assign(t.begin(), t.end() - 1);
  }
  res.boundary_used = bnd;

  // ---- U0 (eq. 5.3) ----
  if (!system_ready) prepare_system();
  profile_mark("weights+system");
  if (ws.fallback)
    res.warnings.push_back(std::to_string(ws.fallback) + " vertices with rings Floater's construction cannot flatten used mean-value weights");
  if (ws.negative)
    res.warnings.push_back(std::to_string(ws.negative) + " negative cotangent weights: the initial map may fold");
  // Face data of the filled mesh for the last map measured: the stretch metrics of a step and the
  // vertex stretches of the next step (eq. 5.1) come from the same pass over the faces.
  FaceData fd;
  bool fd_valid = false;
  const int nff = static_cast<int>(Ff.rows());
  bool gave_up = false;  // a solve gave up (solver.give_up_after)
  if (fold_stops) solver.give_up_after(kGiveUpIters);
  auto solve_step = [&](MatX2d& Ucur) {
    profile_mark("other");
    const int bad = sys.fill(*T, w, Ucur);
    profile_mark("fill");
    (void)bad;
    const int m = static_cast<int>(sys.free_v.size());
    Eigen::MatrixXd X(m, 2);
    for (int r = 0; r < m; ++r) X.row(r) = Ucur.row(sys.free_v[r]);
    // A chart without interior vertices (e.g. a fan-triangulated n-gon) has nothing to solve.
    const int it = m > 0 ? solver.solve(sys.A, sys.Ar, sys.B, X) : 0;
    if (it < 0) {
      gave_up = true;
      return 0;
    }
    fd_valid = false;
    for (int r = 0; r < m; ++r) Ucur.row(sys.free_v[r]) = X.row(r);
    place_ears(Ucur);
    return it;
  };
  auto metrics_of = [&](const MatX2d& Ucur, bool full = false) {
    profile_mark("other");
    fd = face_data(Vf, Ff, Ucur, nff);
    fd_valid = true;
    auto m = full ? metrics_impl(mesh.V, mesh.F, Ucur, nf, edges, opt.zero_area_eps, &angles3)
                  : stretch_metrics(fd, nf, opt.zero_area_eps);
    profile_mark("metrics");
    return m;
  };
  // An iterative solve stops at a relative residual; the exact solution of eq. 5.3 has no flips
  // when the polygon is convex and the weights positive [Flo97], so flips in an inexact map are
  // solver error: re-solve from it with a 100 times tighter tolerance, twice at most (not below 1e-10).
  auto solve_checked = [&](MatX2d& Ucur, UnwrapStep& st, bool full = false) {
    st.solver_iterations = solve_step(Ucur);
    st.metrics = metrics_of(Ucur, full);
    const double tol = solver.tolerance();
    double t = tol;
    for (int k = 0; k < 2 && st.metrics.flipped && solver.iterative() && !fold_stops; ++k) {
      t = std::max(t * 1e-2, 1e-10);
      solver.set_tolerance(t);
      st.solver_iterations += solve_step(Ucur);
      st.metrics = metrics_of(Ucur, full);
    }
    solver.set_tolerance(tol);
  };
  const bool optimal = opt.iterations < 0;
  const int max_steps = optimal ? opt.max_iterations : opt.iterations;
  auto frac = [&](int h) { return optimal ? std::min(0.95, 0.1 + 0.85 * h / (h + 3.0)) : 0.1 + 0.9 * h / (max_steps + 1.0); };

  {
    UnwrapStep st;
    // Free vertices start at the polygon's centre (only the iterative solver uses the guess).
    for (int v : sys.free_v) U.row(v) = Vec2(0.5, 0.5).transpose();
    if (bnd == UvBoundary::Free) {
      Vec2 c = Vec2::Zero();
      for (int v : loop) c += U.row(v).transpose();
      c /= static_cast<double>(loop.size());
      for (int v : sys.free_v) U.row(v) = c.transpose();
    }
    solve_checked(U, st, true);
    st.seconds = seconds_since(t_start);  // includes the boundary and the weights
    res.steps.push_back(st);
  }
  // A free boundary that is not convex may fold the map (Tutte's guarantee needs a convex polygon):
  // the map is then redone on the circle, from the initial weights. (Zero-area triangles are not a
  // sign of folding: a circle gives them too on near-degenerate scan triangles.)
  const std::vector<double> w_base = bnd == UvBoundary::Free ? w : std::vector<double>();
  auto to_circle = [&](const std::string& why) {
    res.warnings.push_back(why + "; used a circle instead");
    bnd = UvBoundary::Circle;
    res.boundary_used = bnd;
    res.boundary_convex = true;
    place_circle(loop, t, U);
    curve = BoundaryCurve();
    curve.circle = true;
    curve.anchors = {0};
    curve.s.assign(t.begin(), t.end() - 1);
    w = w_base;
    const auto t0 = Clock::now();
    UnwrapStep st;
    solver.set_tolerance(opt.tolerance);
    solve_checked(U, st, true);
    st.seconds = seconds_since(t0);
    res.steps.assign(1, st);
    res.uv_initial = U.topRows(n);
  };
  if (fold_stops && (gave_up || res.steps[0].metrics.flipped)) {
    folded = true;
    return res;
  }
  if (bnd == UvBoundary::Free && res.steps[0].metrics.flipped)
    to_circle("the free boundary folded the initial map (" + std::to_string(res.steps[0].metrics.flipped) +
              " flipped, " + std::to_string(res.steps[0].metrics.zero_area) + " zero-area triangles)");
  progress(frac(0));
  res.uv_initial = U.topRows(n);

  // ---- stretch equalization (eq. 5.1, 5.4-5.6) ----
  // The steps solve to step_tolerance: the next step changes the weights again, so a tighter
  // intermediate map buys nothing (measured on lion-head: the same Uopt stretch to 4 digits with
  // half the multigrid iterations of 1e-6).
  MatX2d best = U;
  res.chosen = 0;
  VecXd sigma;
  const double cap = opt.stretch_cap;
  const double step_tol = std::max(opt.step_tolerance, opt.tolerance);
  solver.set_tolerance(step_tol);
  for (int h = 1; h <= max_steps; ++h) {
    const auto t0 = Clock::now();
    profile_mark("other");
    if (!fd_valid) fd = face_data(Vf, Ff, U, nff);
    vertex_stretch_impl(fd, *T, opt.zero_area_eps, cap, sigma);
    profile_mark("vstretch");
    if (opt.slide_boundary) {
      curve.slide(loop, sigma, opt.eta);
      curve.place(loop, U);
    }
    // w^{h+1}_ij = w^h_ij / sigma_j^eta
    const int nw = static_cast<int>(w.size());
#pragma omp parallel for schedule(static) if (nw > 6 * kParallelRows)
    for (int k = 0; k < nw; ++k) {
      if (w[k] == 0) continue;
      const double s = std::max(sigma[T->vv_index[k]], 1.0 / cap);
      w[k] /= opt.eta == 1.0 ? s : opt.eta == 0.5 ? std::sqrt(s) : std::pow(s, opt.eta);
    }
    // Keep the weights in range: rows are normalised anyway, so a global rescale changes nothing.
    double wmax = 0;
    for (int k = 0; k < nw; ++k) wmax = std::max(wmax, std::abs(w[k]));
    if (wmax > 1e100 || (wmax > 0 && wmax < 1e-100)) {
      for (double& x : w) x /= wmax;
    }
    UnwrapStep st;
    solve_checked(U, st);
    st.seconds = seconds_since(t0);
    if (fold_stops && (gave_up || st.metrics.flipped)) {
      res.steps.push_back(st);
      folded = true;
      return res;
    }
    if (bnd == UvBoundary::Free && !res.boundary_convex && st.metrics.flipped) {
      to_circle("the non-convex free boundary folded equalization step " + std::to_string(h) + " (" +
                std::to_string(st.metrics.flipped) + " flipped triangles)");
      solver.set_tolerance(step_tol);
      best = U;
      res.chosen = 0;
      h = 0;  // start the equalization again
      continue;
    }
    res.steps.push_back(st);
    progress(frac(h));
    if (!optimal) {
      best = U;
      res.chosen = h;
      continue;
    }
    const UvMetrics& prev = res.steps[res.chosen].metrics;
    // Fewer failed (flipped or zero-area) triangles first, then eq. 5.5 over the others.
    const int fail_prev = prev.flipped + prev.zero_area;
    auto better = [&](const UvMetrics& cur) {
      const int fail_cur = cur.flipped + cur.zero_area;
      return fail_cur < fail_prev || (fail_cur == fail_prev && cur.stretch_l2_finite < prev.stretch_l2_finite * (1 - 1e-12));
    };
    bool ok = better(res.steps.back().metrics);
    if (!ok && solver.iterative() && step_tol > opt.tolerance) {
      // A loose solve can make a good step look worse: judge it again solved to `tolerance`.
      UnwrapStep& again = res.steps.back();
      solver.set_tolerance(opt.tolerance);
      again.solver_iterations += solve_step(U);
      again.metrics = metrics_of(U);
      solver.set_tolerance(step_tol);
      again.seconds = seconds_since(t0);
      ok = better(again.metrics);
    }
    if (!ok) break;
    const UvMetrics& cur = res.steps.back().metrics;
    const bool small = cur.flipped + cur.zero_area == fail_prev &&
                       cur.stretch_l2_finite > prev.stretch_l2_finite * (1 - opt.min_improvement);
    best = U;
    res.chosen = h;
    if (small) break;
  }
  solver.set_tolerance(opt.tolerance);
  if (solver.fell_back()) res.warnings.push_back("BiCGSTAB did not converge; switched to UMFPACK");
  res.solver = solver.name();
  // Steps carry the stretch metrics; the returned map gets all of thesis 5.3.
  if (res.chosen > 0) res.steps[res.chosen].metrics = metrics_of(best, true);
  res.uv = best.topRows(n);
  progress(1.0);
  return res;
}

}  // namespace

UnwrapResult unwrap(const MatX3d& V, const MatX3i& F, const UnwrapOptions& opt, const ProgressFn& progress) {
  if (!(opt.eta > 0 && opt.eta <= 1)) throw MeshError("unwrap: eta must be in (0, 1], got " + std::to_string(opt.eta));
  if (opt.iterations < -1) throw MeshError("unwrap: iterations must be -1 (optimal) or >= 0");
  if (opt.max_iterations < 0) throw MeshError("unwrap: max_iterations must be >= 0");
  bool folded = false;
  MatX2d lscm_map;
  if (opt.weights != UvWeights::Auto) return unwrap_weights(V, F, opt, progress, false, folded, lscm_map);
  UnwrapOptions o = opt;
  o.weights = UvWeights::Cotangent;
  UnwrapResult r = unwrap_weights(V, F, o, progress, true, folded, lscm_map);
  const UvMetrics& m = r.steps[r.chosen].metrics;
  if (!folded && m.zero_area == 0) {
    // The negative weights did no harm: not worth a warning.
    r.warnings.erase(std::remove_if(r.warnings.begin(), r.warnings.end(),
                                    [](const std::string& w) { return w.find("cotangent") != std::string::npos; }),
                     r.warnings.end());
    return r;
  }
  const UvMetrics& last = r.steps.back().metrics;
  // A chart with holes (inner boundaries, e.g. slits cut by open seams) gets mean-value weights:
  // shape-preserving weights suit it poorly (thesis 5.5), and on the fans that close its holes they
  // gave L2 stretch 140-380 where mean-value weights give 3 (lion-head cut along its crest lines).
  const bool holes = r.n_holes > 0;
  o.weights = holes ? UvWeights::MeanValue : UvWeights::Floater;
  UnwrapResult fl = unwrap_weights(V, F, o, progress, false, folded, lscm_map);
  fl.warnings.insert(fl.warnings.begin(), "the cotangent weights' map folded (" + std::to_string(last.flipped) +
                                              " flipped, " + std::to_string(last.zero_area) +
                                              " zero-area triangles) or its solve did not converge; used " +
                                              (holes ? "mean-value weights (the chart has holes)" : "Floater's weights"));
  return fl;
}

}  // namespace dgmesh
