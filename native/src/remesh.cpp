// Remeshing by double parameterization (thesis 5.4, after Alliez et al. [AMD02]). See remesh.h.
#include "dgmesh/remesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dgmesh/delaunay.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/detail/remesh_map.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/parallel.h"
#include "dgmesh/remesh_flips.h"
#include "dgmesh/remesh_smoothing.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {

using detail::Clock;
using detail::cross2;
using detail::delaunay_flips_3d;
using detail::delaunay_flips_map;
using detail::kPi;
using detail::locate_in_map;
using detail::Sample;
using detail::seconds_since;
using detail::smooth_remeshed;
using detail::uv_row;
using detail::Vec2;
constexpr double kSqrt3 = 1.7320508075688772;
constexpr int kBand = 16;               // raster rows per band (one band per task, no write races)
constexpr double kPixelsPerSample = 256;  // at most this many chart pixels per interior sample
constexpr double kLloydPointsPerCell = 32;  // Lloyd quadrature points wanted per Voronoi cell
constexpr int kLloydMaxResolution = 1024;   // ... up to this grid size
constexpr double kLloydTolerance = 0.003;  // Lloyd steps end when the samples' RMS move is under this (spacings)

// Target edge length of a near-equilateral mesh with `density` vertices per unit area: each vertex
// owns sqrt(3)/2 h^2 of area.
inline double spacing(double density) { return std::sqrt(2.0 / (kSqrt3 * std::max(density, 1e-300))); }

// Deterministic sub-pixel offset in [-0.5, 0.5): breaks the co-circularity of pixel-centred samples
// so the Delaunay triangulation is unique (Qhull's Qt could otherwise emit flat triangles).
inline double jitter(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return (x & 0xffffff) / double(1 << 24) - 0.5;
}


double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

// Point-in-polygon for a (weakly) convex counter-clockwise polygon in O(log n): binary search of
// the wedge around an inner point, then one edge test. `margin` is a distance.
class ConvexPolygon {
 public:
  explicit ConvexPolygon(std::vector<Vec2> pts) : p_(std::move(pts)) {
    c_ = Vec2::Zero();
    for (const Vec2& q : p_) c_ += q;
    c_ /= double(p_.size());
    const int n = int(p_.size());
    int start = 0;
    ang_.resize(n);
    for (int k = 0; k < n; ++k) {
      ang_[k] = std::atan2(p_[k].y() - c_.y(), p_[k].x() - c_.x());
      if (ang_[k] < ang_[start]) start = k;
    }
    std::rotate(p_.begin(), p_.begin() + start, p_.end());
    std::rotate(ang_.begin(), ang_.begin() + start, ang_.end());
  }
  // Signed distance-like test: true when q is inside by more than margin from the wedge's edge.
  bool inside(const Vec2& q, double margin) const {
    const int n = int(p_.size());
    const double a = std::atan2(q.y() - c_.y(), q.x() - c_.x());
    // Edge k -> k+1 covers angles [ang_k, ang_{k+1}); the last edge wraps around.
    int k = int(std::upper_bound(ang_.begin(), ang_.end(), a) - ang_.begin()) - 1;
    if (k < 0) k = n - 1;
    const Vec2& p0 = p_[k];
    const Vec2& p1 = p_[(k + 1) % n];
    const Vec2 e = p1 - p0;
    const double len = e.norm();
    if (len <= 0) return false;
    return cross2(e, q - p0) / len > margin;
  }

 private:
  std::vector<Vec2> p_;
  std::vector<double> ang_;
  Vec2 c_;
};

// Distance from a 3D point to the chart's boundary polyline: a kd-tree over points placed densely
// along the loop, then exact distances to the segment of the nearest point and its neighbours.
class BoundaryDistance {
 public:
  BoundaryDistance(const MatX3d& V, const std::vector<int>& loop, double step) : V_(V), loop_(loop) {
    const int nb = int(loop.size());
    double total = 0;
    for (int k = 0; k < nb; ++k) total += (row3(V, loop[(k + 1) % nb]) - row3(V, loop[k])).norm();
    step = std::max(step, total / 400000.0);  // bounded memory on long, dense boundaries
    std::vector<Vec3> pts;
    for (int k = 0; k < nb; ++k) {
      const Vec3 a = row3(V, loop[k]), b = row3(V, loop[(k + 1) % nb]);
      const int m = std::max(1, int(std::ceil((b - a).norm() / step)));
      for (int s = 0; s < m; ++s) {
        pts.push_back(a + (b - a) * (double(s) / m));
        seg_.push_back(k);
      }
    }
    MatX3d P(int(pts.size()), 3);
    for (int i = 0; i < P.rows(); ++i) P.row(i) = pts[i].transpose();
    tree_ = std::make_unique<KdTree>(P);
  }
  double operator()(const Vec3& q) const {
    const int i = tree_->nearest(q);
    const int nb = int(loop_.size());
    const int k = seg_[i];
    double d = std::numeric_limits<double>::infinity();
    for (int o = -1; o <= 1; ++o) {
      const int s = ((k + o) % nb + nb) % nb;
      d = std::min(d, point_segment_distance(q, row3(V_, loop_[s]), row3(V_, loop_[(s + 1) % nb])));
    }
    return d;
  }

 private:
  const MatX3d& V_;
  const std::vector<int>& loop_;
  std::vector<int> seg_;
  std::unique_ptr<KdTree> tree_;
};

// Rejects non-disk input with a message that says what is wrong and what to do.
Topology check_disk(const MatX3d& V, const MatX3i& F) {
  Topology t = validate(V, F, kSurface | kNoLooseVertices);
  const std::string hint = " Remeshing needs one disk-shaped chart: select a disk-shaped region of faces or cut the mesh open.";
  if (t.n_components != 1)
    throw MeshError("remesh: the mesh has " + std::to_string(t.n_components) + " separate pieces." + hint);
  if (t.boundary_loops.empty()) throw MeshError("remesh: the mesh is closed (it has no boundary)." + hint);
  if (t.boundary_loops.size() > 1)
    throw MeshError("remesh: the mesh has " + std::to_string(t.boundary_loops.size()) +
                    " boundary loops (an annulus or a region with holes)." + hint);
  const long chi = long(t.n_vertices) - long(t.n_edges()) + long(t.n_faces);
  if (chi != 1)
    throw MeshError("remesh: the mesh has one boundary loop but handles (Euler characteristic " + std::to_string(chi) +
                    ", a disk has 1)." + hint);
  return t;
}

ProgressFn sub_progress(const ProgressFn& p, double a, double b) {
  if (!p) return {};
  return [p, a, b](double f) { return p(a + (b - a) * f); };
}


}  // namespace

RemeshResult remesh(const MatX3d& V, const MatX3i& F, const RemeshOptions& o, const ProgressFn& progress) {
  if (o.target_vertices < 4) throw MeshError("remesh: target_vertices must be at least 4, got " + std::to_string(o.target_vertices));
  if (!(o.adaptivity >= 0 && o.adaptivity <= 1))
    throw MeshError("remesh: adaptivity must be in [0, 1], got " + std::to_string(o.adaptivity));
  if (o.resolution < 16 || o.resolution > 4096)
    throw MeshError("remesh: resolution must be in 16..4096, got " + std::to_string(o.resolution));
  if (o.domain == UvBoundary::Free)
    throw MeshError("remesh: the parameter domain must be convex (square or circle), not free");
  if (!(o.eta > 0 && o.eta <= 1)) throw MeshError("remesh: eta must be in (0, 1]");
  if (o.lloyd_iterations < 0 || o.lloyd_iterations > 100)
    throw MeshError("remesh: lloyd_iterations must be in 0..100, got " + std::to_string(o.lloyd_iterations));
  if (o.smooth_iterations < 0 || o.smooth_iterations > 100)
    throw MeshError("remesh: smooth_iterations must be in 0..100, got " + std::to_string(o.smooth_iterations));
  if (!(o.min_separation >= 0 && o.min_separation < 1))
    throw MeshError("remesh: min_separation must be in [0, 1), got " + std::to_string(o.min_separation));
  if (!(o.boundary_clearance >= 0 && o.boundary_clearance < 2))
    throw MeshError("remesh: boundary_clearance must be in [0, 2)");
  Progress report(progress);
  report(0);
  const Topology topo = check_disk(V, F);
  // Squared lengths and areas of coordinates beyond ~1e19 overflow (the raster and the Lloyd step
  // then index memory out of range): a clear error instead.
  if (V.size() > 0 && V.cwiseAbs().maxCoeff() > 1e15)
    throw MeshError("remesh: coordinates beyond 1e15 in magnitude; scale the mesh down first");
  const std::vector<int>& loop = topo.boundary_loops[0];
  const int nv = topo.n_vertices, nf = topo.n_faces, nbl = int(loop.size());
  RemeshResult res;
  const auto t_param = Clock::now();

  // 1. The two maps (thesis 5.2): U0 with Floater's weights on the convex domain, Uopt by stretch
  // equalization (eq. 5.1, 5.3, 5.4) from it.
  UnwrapOptions uo;
  uo.boundary = o.domain;
  uo.weights = UvWeights::Floater;
  uo.max_iterations = o.max_uopt_iterations;
  MatX2d U0, Uopt;
  const bool need_u0 = o.mode != RemeshMode::SingleUopt;
  const bool need_uopt = o.mode != RemeshMode::SingleU0;
  // One call gives both: Uopt starts from U0 (uv_initial), so U0 is not solved twice.
  uo.iterations = !need_uopt ? 0 : o.uopt_steps < 0 ? -1 : o.uopt_steps;
  if (need_uopt) uo.eta = o.eta;
  UnwrapResult r = unwrap(V, F, uo, sub_progress(progress, 0.0, 0.4));
  if (need_u0) U0 = std::move(r.uv_initial);
  if (need_uopt) {
    Uopt = std::move(r.uv);
    res.uopt_iterations = r.chosen;
  }
  for (auto& w : r.warnings) res.warnings.push_back(w);
  const MatX2d& Us = o.mode == RemeshMode::SingleU0 ? U0 : Uopt;  // sampling map
  const MatX2d& Ut = o.mode == RemeshMode::SingleUopt ? Uopt : U0; // triangulation map
  res.seconds_parameterize = seconds_since(t_param);
  report(0.4);
  const auto t_sample = Clock::now();

  // 2. Density per vertex: rho = (1 - a) + a * min(kappa / mean kappa, clip), kappa = sqrt(k1^2 + k2^2)
  // = sqrt(4H^2 - 2K); its integral over the surface normalises the control map.
  VecXd rho = VecXd::Ones(nv);
  if (o.adaptivity > 0) {
    const Curvature c = curvature(V, F, topo);
    VecXd kappa(nv);
    double num = 0, den = 0;
    for (int v = 0; v < nv; ++v) {
      kappa[v] = std::sqrt(std::max(4 * c.mean[v] * c.mean[v] - 2 * c.gaussian[v], 0.0));
      if (std::isfinite(kappa[v])) {
        num += kappa[v] * c.area[v];
        den += c.area[v];
      } else {
        kappa[v] = 0;
      }
    }
    const double mean = den > 0 ? num / den : 0;
    if (mean > 0)
      for (int v = 0; v < nv; ++v) rho[v] = (1 - o.adaptivity) + o.adaptivity * std::min(kappa[v] / mean, o.curvature_clip);
  }
  const VecXd area3 = face_areas(V, F);
  double rho_integral = 0;  // int rho dA over the surface
  for (int f = 0; f < nf; ++f) rho_integral += area3[f] * (rho[F(f, 0)] + rho[F(f, 1)] + rho[F(f, 2)]) / 3.0;
  double surface_area = area3.sum();
  if (!(rho_integral > 0) || !(surface_area > 0)) throw MeshError("remesh: the mesh has zero area");

  // Boundary samples.
  const int N = o.target_vertices;
  std::vector<Vec3> bnd_x;
  std::vector<Vec2> bnd_u;
  std::vector<Vec2> bnd_s;  // the same boundary samples in the sampling map (Lloyd generators)
  std::vector<Sample> bnd_src;  // the same on the input: face and barycentric weights
  // A point (1 - t) a + t b of the boundary edge (a, b), on the input face holding that edge.
  auto on_edge = [&](int a, int b, double t) {
    for (int q = topo.vf_offset[a]; q < topo.vf_offset[a + 1]; ++q) {
      const int f = topo.vf_index[q];
      double w[3] = {0, 0, 0};
      int hits = 0;
      for (int k = 0; k < 3; ++k) {
        if (F(f, k) == a) w[k] += 1 - t, ++hits;
        else if (F(f, k) == b) w[k] += t, ++hits;
      }
      if (a == b ? hits == 1 : hits == 2) return Sample{f, w[0], w[1], w[2]};
    }
    return Sample{-1, 0, 0, 0};
  };
  if (o.boundary == RemeshBoundary::Keep) {
    res.boundary_source.resize(nbl);
    for (int k = 0; k < nbl; ++k) {
      bnd_x.push_back(row3(V, loop[k]));
      bnd_u.push_back(uv_row(Ut, loop[k]));
      bnd_s.push_back(uv_row(Us, loop[k]));
      bnd_src.push_back(on_edge(loop[k], loop[k], 0.0));
      res.boundary_source[k] = loop[k];
    }
  } else {
    // Spacing follows the density with all N vertices: count measure = int ds / h(s).
    std::vector<double> cum(nbl + 1, 0.0);
    for (int k = 0; k < nbl; ++k) {
      const int a = loop[k], b = loop[(k + 1) % nbl];
      const double len = (row3(V, b) - row3(V, a)).norm();
      const double ha = spacing(N * rho[a] / rho_integral), hb = spacing(N * rho[b] / rho_integral);
      cum[k + 1] = cum[k] + len * 0.5 * (1 / ha + 1 / hb);
    }
    // Anchors that must be samples: the square's corners (else the polygon would cut them off).
    std::vector<int> anchors;
    if (o.domain == UvBoundary::Square)
      for (int k = 0; k < nbl; ++k) {
        const Vec2 u = uv_row(Ut, loop[k]);
        const bool cx = std::abs(u.x()) < 1e-9 || std::abs(u.x() - 1) < 1e-9;
        const bool cy = std::abs(u.y()) < 1e-9 || std::abs(u.y() - 1) < 1e-9;
        if (cx && cy) anchors.push_back(k);
      }
    if (anchors.empty()) anchors.push_back(0);
    const double total = cum[nbl];
    auto place = [&](double c) {
      c = std::fmod(c, total);
      if (c < 0) c += total;
      int k = int(std::upper_bound(cum.begin(), cum.end(), c) - cum.begin()) - 1;
      k = std::clamp(k, 0, nbl - 1);
      const double t = cum[k + 1] > cum[k] ? std::clamp((c - cum[k]) / (cum[k + 1] - cum[k]), 0.0, 1.0) : 0.0;
      const int a = loop[k], b = loop[(k + 1) % nbl];
      bnd_x.push_back((1 - t) * row3(V, a) + t * row3(V, b));
      bnd_u.push_back((1 - t) * uv_row(Ut, a) + t * uv_row(Ut, b));
      bnd_s.push_back((1 - t) * uv_row(Us, a) + t * uv_row(Us, b));
      bnd_src.push_back(on_edge(a, b, t));
    };
    const int na = int(anchors.size());
    const int min_per_piece = na == 1 ? 3 : 1;
    for (int m = 0; m < na; ++m) {
      const double c0 = cum[anchors[m]];
      const double c1 = m + 1 < na ? cum[anchors[m + 1]] : total + cum[anchors[0]];
      const int n_piece = std::max(min_per_piece, int(std::lround(c1 - c0)));
      for (int q = 0; q < n_piece; ++q) {
        if (q == 0) {  // the anchor itself, exactly
          bnd_x.push_back(row3(V, loop[anchors[m]]));
          bnd_u.push_back(uv_row(Ut, loop[anchors[m]]));
          bnd_src.push_back(on_edge(loop[anchors[m]], loop[anchors[m]], 0.0));
          bnd_s.push_back(uv_row(Us, loop[anchors[m]]));
        } else {
          place(c0 + (c1 - c0) * q / n_piece);
        }
      }
    }
  }
  const int nb = int(bnd_x.size());
  const int n_int = N - nb;
  if (n_int < 1)
    throw MeshError("remesh: target_vertices (" + std::to_string(N) + ") must exceed the number of boundary vertices (" +
                    std::to_string(nb) + ")" +
                    (o.boundary == RemeshBoundary::Keep ? ", which are kept; raise the target or resample the boundary" : ""));
  res.n_interior_target = n_int;
  res.n_boundary = nb;

  // Orientation of the chart in the triangulation map (the Delaunay triangles come out CCW).
  double signed_area = 0;
  for (int f = 0; f < nf; ++f)
    signed_area += cross2(uv_row(Ut, F(f, 1)) - uv_row(Ut, F(f, 0)), uv_row(Ut, F(f, 2)) - uv_row(Ut, F(f, 0)));
  const bool flip = signed_area < 0;
  // Ears of the kept boundary: a boundary vertex with a single input face, (prev, tip, next) (a
  // grid's corner; a region cut out of a finer mesh has many). The unwrap takes the tip off the
  // convex domain and lays the ear out in its 3D shape beyond the chord (prev, next), so in the
  // triangulation map the chart is a convex core (the other boundary vertices, on the domain's
  // boundary) with one triangle glued onto each chord. One Delaunay triangulation of all the points
  // need not have the ears' sides: a needle ear leaning along the boundary holds the tip of the ear
  // on the other side of its base vertex in its circumcircle (the left half of a subdivided
  // lion-head has 20 such ears out of 85), and ears that lean far even overlap each other in the map,
  // where no planar triangulation has the boundary's edges. So the core and each ear are
  // triangulated on their own (step 5) and joined along the chords. Every interior sample goes with
  // its input face: an ear's face to the ear, any other face to the core. (Two ears are never loop
  // neighbours; with fewer than 3 core vertices there are no ears.)
  struct Ear {
    int tip, prev, next;  // boundary sample indices
    int face;             // the ear's input face
  };
  std::vector<Ear> ears;
  std::vector<int> ear_of_face(nf, -1);
  std::vector<char> is_tip(nb, 0);
  if (o.boundary == RemeshBoundary::Keep && nb > 3) {
    for (int k = 0; k < nb; ++k) {
      const int v = loop[k];
      if (topo.vf_offset[v + 1] - topo.vf_offset[v] != 1) continue;
      if (is_tip[(k + nb - 1) % nb] || (k + 1 == nb && is_tip[0])) continue;
      is_tip[k] = 1;
      ears.push_back({k, (k + nb - 1) % nb, (k + 1) % nb, topo.vf_index[topo.vf_offset[v]]});
    }
    if (nb - int(ears.size()) < 3) {
      ears.clear();
      std::fill(is_tip.begin(), is_tip.end(), 0);
    }
    for (int e = 0; e < int(ears.size()); ++e) ear_of_face[ears[e].face] = e;
  }
  std::vector<int> core;  // boundary samples of the core, in loop order
  for (int k = 0; k < nb; ++k)
    if (!is_tip[k]) core.push_back(k);
  // The core polygon, counter-clockwise, for the inside test.
  std::vector<Vec2> poly;
  for (int k : core) poly.push_back(bnd_u[k]);
  {
    double a2 = 0;
    for (size_t k = 0; k < poly.size(); ++k) a2 += cross2(poly[k], poly[(k + 1) % poly.size()]);
    if (a2 < 0) std::reverse(poly.begin(), poly.end());
  }
  const ConvexPolygon polygon(poly);
  // Whether a point u of the triangulation map on input face f is strictly inside (by margin) its
  // piece of the chart: the ear's triangle for an ear's face, the core polygon for any other.
  auto inside_chart = [&](int f, const Vec2& u, double margin) {
    const int e = ear_of_face[f];
    if (e < 0) return polygon.inside(u, margin);
    Vec2 c[3] = {bnd_u[ears[e].prev], bnd_u[ears[e].tip], bnd_u[ears[e].next]};
    const double s = cross2(c[1] - c[0], c[2] - c[0]);
    if (s == 0) return false;
    if (s < 0) std::swap(c[1], c[2]);
    for (int k = 0; k < 3; ++k) {
      const Vec2 d = c[(k + 1) % 3] - c[k];
      if (!(cross2(d, u - c[k]) > margin * d.norm())) return false;
    }
    return true;
  };

  // 3. Rasterize the control map over the sampling map: pixel value = (3D area / UV area) of the
  // covering face times the interpolated density, i.e. the density per unit of UV area [AMD02].
  // Error diffusion needs some samples per hundred pixels: with fewer, a row's carried error only
  // fires where the row leaves the chart, the samples line the chart's border and the boundary
  // clearance drops them all (a 150-vertex target on a grid at 512^2 kept no interior sample). So
  // the raster is made coarser until there are at most kPixelsPerSample chart pixels per interior
  // sample; larger targets keep the resolution asked for.
  double chart_uv_area = 0;
  for (int f = 0; f < nf; ++f)
    chart_uv_area += 0.5 * std::abs(cross2(uv_row(Us, F(f, 1)) - uv_row(Us, F(f, 0)), uv_row(Us, F(f, 2)) - uv_row(Us, F(f, 0))));
  const double r_fit = std::ceil(std::sqrt(kPixelsPerSample * n_int / std::max(chart_uv_area, 1e-12)));
  const int R = std::max(16, int(std::min(r_fit, double(o.resolution))));
  res.resolution = R;
  const long npix = long(R) * R;
  // At most one sample per pixel: a target beyond the chart's pixels cannot be met, and error
  // diffusion at several samples a pixel fell apart (5M asked at 512^2 gave 94 vertices).
  const double chart_pixels = chart_uv_area * double(npix);
  if (n_int > chart_pixels) {
    const int needed = int(std::ceil(std::sqrt(n_int / std::max(chart_uv_area, 1e-12))));
    throw MeshError("remesh: " + std::to_string(n_int) + " interior vertices do not fit the chart's " +
                    std::to_string(long(chart_pixels)) + " pixels at resolution " + std::to_string(R) +
                    " (at most one per pixel): raise the resolution to at least " + std::to_string(needed) +
                    " or lower the target");
  }
  if (n_int > npix / 4)
    res.warnings.push_back("resolution " + std::to_string(R) + " is low for " + std::to_string(n_int) +
                           " interior samples (at most one per pixel): raise the resolution");
  const bool relax = o.lloyd_iterations > 0;
  const bool relax_surface = relax && o.relax_metric == RemeshRelaxMetric::Surface;
  VecXd ratio(nf);
  // Rasterizes the sampling map at Rr x Rr: covering face, control-map value and (want_x) the
  // surface point of each pixel centre (floats: 12 bytes a pixel, distances only need to rank
  // Lloyd generators).
  auto rasterize = [&](int Rr, std::vector<int>& pf, std::vector<double>& pv, std::vector<float>& px, bool want_x) {
    const long np = long(Rr) * Rr;
    pf.assign(np, -1);
    pv.assign(np, 0.0);
    px.assign(want_x ? 3 * np : 0, 0.0f);
    const int nbands = (Rr + kBand - 1) / kBand;
    std::vector<int> band_off(nbands + 1, 0);
    std::vector<int> row0(nf), row1(nf);
    for (int f = 0; f < nf; ++f) {
      const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
      const double uva = 0.5 * std::abs(cross2(b - a, c - a));
      ratio[f] = uva > 0 ? area3[f] / uva : 0.0;
      const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
      row0[f] = std::max(0, int(std::ceil(ymin * Rr - 0.5 - 1e-9)));
      row1[f] = std::min(Rr - 1, int(std::floor(ymax * Rr - 0.5 + 1e-9)));
      if (uva <= 0 || row0[f] > row1[f]) continue;
      for (int bnd = row0[f] / kBand; bnd <= row1[f] / kBand; ++bnd) ++band_off[bnd + 1];
    }
    for (int b = 0; b < nbands; ++b) band_off[b + 1] += band_off[b];
    std::vector<int> band_faces(band_off[nbands]);
    {
      std::vector<int> fill(band_off.begin(), band_off.end() - 1);
      for (int f = 0; f < nf; ++f) {
        if (ratio[f] <= 0 || row0[f] > row1[f]) continue;
        for (int bnd = row0[f] / kBand; bnd <= row1[f] / kBand; ++bnd) band_faces[fill[bnd]++] = f;
      }
    }
#pragma omp parallel for schedule(dynamic, 1) if (long(Rr) * Rr > kParallelMin * 4)
    for (int bnd = 0; bnd < nbands; ++bnd) {
      const int j_lo = bnd * kBand, j_hi = std::min(Rr - 1, j_lo + kBand - 1);
      for (int q = band_off[bnd]; q < band_off[bnd + 1]; ++q) {
        const int f = band_faces[q];
        const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
        const double det = cross2(b - a, c - a);
        const double xmin = std::min({a.x(), b.x(), c.x()}), xmax = std::max({a.x(), b.x(), c.x()});
        const int i0 = std::max(0, int(std::ceil(xmin * Rr - 0.5 - 1e-9)));
        const int i1 = std::min(Rr - 1, int(std::floor(xmax * Rr - 0.5 + 1e-9)));
        const double tol = -1e-9;
        for (int j = std::max(j_lo, row0[f]); j <= std::min(j_hi, row1[f]); ++j) {
          const double y = (j + 0.5) / Rr;
          for (int i = i0; i <= i1; ++i) {
            const Vec2 p((i + 0.5) / Rr, y);
            const double w0 = cross2(b - p, c - p) / det, w1 = cross2(c - p, a - p) / det, w2 = 1 - w0 - w1;
            if (w0 < tol || w1 < tol || w2 < tol) continue;
            const long idx = long(j) * Rr + i;
            pf[idx] = f;
            pv[idx] = ratio[f] * (w0 * rho[F(f, 0)] + w1 * rho[F(f, 1)] + w2 * rho[F(f, 2)]);
            if (want_x) {
              const Vec3 x = w0 * row3(V, F(f, 0)) + w1 * row3(V, F(f, 1)) + w2 * row3(V, F(f, 2));
              for (int c = 0; c < 3; ++c) px[3 * idx + c] = float(x[c]);
            }
          }
        }
      }
    }
  };
  std::vector<int> pix_face;
  std::vector<double> pix_val;
  std::vector<float> pix_x;
  // The Lloyd step's quadrature grid, apart from the diffusion raster: a Voronoi cell of the
  // relaxation should hold some kLloydPointsPerCell grid points, else its pixel-quantized boundary
  // stalls the relaxation (at 256^2 and 5000 samples a cell holds ~10 pixels, and after ~6 steps no
  // pixel changes its cell: the samples stop short of a centroidal tessellation, and more so on the
  // map whose pixels are the more anisotropic on the surface). So the sampling map is rasterized
  // once more at an integer multiple of R, capped at kLloydMaxResolution (the cost bound: 1024^2
  // holds the 100K-vertex target at its own pixels).
  int RL = R;
  if (relax) {
    int ss = int(std::ceil(std::sqrt(kLloydPointsPerCell * n_int / std::max(chart_pixels, 1.0))));
    ss = std::max(1, std::min(ss, kLloydMaxResolution / R));
    RL = R * ss;
  }
  rasterize(R, pix_face, pix_val, pix_x, relax_surface && RL == R);
  std::vector<int> lpix_face_own;
  std::vector<double> lpix_val_own;
  std::vector<float> lpix_x_own;
  if (RL != R) rasterize(RL, lpix_face_own, lpix_val_own, lpix_x_own, relax_surface);
  const std::vector<int>& lpix_face = RL != R ? lpix_face_own : pix_face;
  const std::vector<double>& lpix_val = RL != R ? lpix_val_own : pix_val;
  const std::vector<float>& lpix_x = RL != R ? lpix_x_own : pix_x;
  const long nlpix = long(RL) * RL;
  double pix_sum = 0;
  for (long i = 0; i < npix; ++i) pix_sum += pix_val[i];
  if (!(pix_sum > 0)) throw MeshError("remesh: the chart covers no pixel of the control map; raise the resolution");
  report(0.55);

  // 4. Error diffusion (serpentine Floyd-Steinberg), then the samples: the same face and barycentric
  // coordinates give the point in the triangulation map and in 3D. Interior samples too close to
  // the boundary are dropped, and the density is rescaled until the count hits the target.
  const bool clearance = o.boundary_clearance > 0;
  std::unique_ptr<BoundaryDistance> bdist;
  // Faces certainly farther from the boundary than the clearance at any of their points: their
  // samples need no query (a lower bound: centroid distance minus the centroid-vertex radius).
  std::vector<char> face_far(nf, 1);
  if (clearance) {
    bdist = std::make_unique<BoundaryDistance>(
        V, loop, 0.5 * o.boundary_clearance * spacing(n_int * rho.maxCoeff() / rho_integral));
#pragma omp parallel for schedule(static) if (nf > kParallelMin)
    for (int f = 0; f < nf; ++f) {
      const Vec3 a = row3(V, F(f, 0)), b = row3(V, F(f, 1)), c = row3(V, F(f, 2));
      const Vec3 g = (a + b + c) / 3.0;
      const double rad = std::max({(a - g).norm(), (b - g).norm(), (c - g).norm()});
      const double rmin = std::min({rho[F(f, 0)], rho[F(f, 1)], rho[F(f, 2)]});
      face_far[f] = (*bdist)(g) - rad > o.boundary_clearance * spacing(n_int * rmin / rho_integral);
    }
  }
  const double margin = 1e-9;
  double scale = n_int / pix_sum;
  std::vector<long> picked;
  std::vector<Sample> samples;
  std::vector<char> keep;
  // A pixel's sample is always the same point, so its verdict is reused by later passes.
  std::vector<signed char> pix_keep(npix, -1);
  std::vector<double> err0(R + 2), err1(R + 2);
  // Rounds of diffusion + relaxation + minimum separation: where the sampling map is too coarse for
  // the target (pixels larger than the spacing on the surface), relaxed samples crowd and the
  // separation drops them, so the diffusion goal is raised by the shortfall and the rounds repeat
  // until the kept count is within 0.5% of the target (every mode hits the count).
  int n_goal = n_int;
  res.passes = 0;
  int kept = 0;  // interior samples kept by the last round
  for (int round = 0;; ++round) {
    res.n_separated = 0;
    for (int pass = 0; pass < 6; ++pass) {
      picked.clear();
      std::fill(err0.begin(), err0.end(), 0.0);
      for (int j = 0; j < R; ++j) {
        std::fill(err1.begin(), err1.end(), 0.0);
        const bool fwd = (j % 2) == 0;
        const int dir = fwd ? 1 : -1;
        for (int s = 0; s < R; ++s) {
          const int i = fwd ? s : R - 1 - s;
          const long idx = long(j) * R + i;
          if (pix_face[idx] < 0) continue;
          const double v = scale * pix_val[idx] + err0[i + 1];
          double e = v;
          if (v >= 0.5) {
            picked.push_back(idx);
            e = v - 1.0;
          }
          // Floyd-Steinberg weights 7, 3, 5, 1 (/16), over the neighbours inside the chart only so
          // that no density leaks out at the chart's border.
          const int in = i + dir, ib = i - dir;
          const bool ok_n = in >= 0 && in < R && pix_face[idx + dir] >= 0;
          const bool last = j + 1 >= R;
          const long below = idx + R;
          const bool ok_b = !last && pix_face[below] >= 0;
          const bool ok_bb = !last && ib >= 0 && ib < R && pix_face[below - dir] >= 0;
          const bool ok_bn = !last && in >= 0 && in < R && pix_face[below + dir] >= 0;
          const double wsum = 7.0 * ok_n + 3.0 * ok_bb + 5.0 * ok_b + 1.0 * ok_bn;
          if (wsum <= 0) continue;
          const double q = e / wsum;
          if (ok_n) err0[in + 1] += 7 * q;
          if (ok_bb) err1[ib + 1] += 3 * q;
          if (ok_b) err1[i + 1] += 5 * q;
          if (ok_bn) err1[in + 1] += 1 * q;
        }
        std::swap(err0, err1);
      }
      const int ns = int(picked.size());
      samples.assign(ns, Sample{});
      keep.assign(ns, 0);
  #pragma omp parallel for schedule(static) if (ns > kParallelMin)
      for (int s = 0; s < ns; ++s) {
        const long idx = picked[s];
        const int i = int(idx % R), j = int(idx / R);
        const uint32_t h = uint32_t(idx) * 2654435761U;
        const Vec2 p((i + 0.5 + 0.1 * jitter(h)) / R, (j + 0.5 + 0.1 * jitter(h ^ 0x9e3779b9U)) / R);
        const int f = pix_face[idx];
        const Vec2 a = uv_row(Us, F(f, 0)), b = uv_row(Us, F(f, 1)), c = uv_row(Us, F(f, 2));
        const double det = cross2(b - a, c - a);
        double w0 = std::max(0.0, cross2(b - p, c - p) / det), w1 = std::max(0.0, cross2(c - p, a - p) / det);
        double w2 = std::max(0.0, 1 - w0 - w1);
        const double ws = w0 + w1 + w2;
        w0 /= ws, w1 /= ws, w2 /= ws;
        samples[s] = Sample{f, w0, w1, w2};
        if (pix_keep[idx] >= 0) {
          keep[s] = pix_keep[idx];
          continue;
        }
        const Vec2 u = w0 * uv_row(Ut, F(f, 0)) + w1 * uv_row(Ut, F(f, 1)) + w2 * uv_row(Ut, F(f, 2));
        if (!inside_chart(f, u, margin)) {
          pix_keep[idx] = 0;
          continue;
        }
        if (face_far[f]) {
          keep[s] = pix_keep[idx] = 1;
          continue;
        }
        const Vec3 x = w0 * row3(V, F(f, 0)) + w1 * row3(V, F(f, 1)) + w2 * row3(V, F(f, 2));
        const double r = w0 * rho[F(f, 0)] + w1 * rho[F(f, 1)] + w2 * rho[F(f, 2)];
        const double hloc = spacing(n_int * r / rho_integral);
        keep[s] = (*bdist)(x) >= o.boundary_clearance * hloc;
        pix_keep[idx] = keep[s];
      }
      int accepted = 0;
      for (int s = 0; s < ns; ++s) accepted += keep[s];
      ++res.passes;
      res.n_rejected = ns - accepted;
      report(std::min(0.55 + 0.04 * (pass + 1), 0.79));
      const int tol = std::max(1, int(0.002 * n_goal));
      if (std::abs(accepted - n_goal) <= tol) break;
      scale *= accepted > 0 ? double(n_goal) / accepted : 2.0;  // none kept: every sample hit the clearance
    }
    res.seconds_sample = seconds_since(t_sample) - res.seconds_relax;

    // 4b. Density-weighted Lloyd relaxation of the interior samples (Lloyd 1982; the centroidal
    // Voronoi sampling of a parameter map in Alliez, de Verdiere, Devillers, Isenburg 2003,
    // "Isotropic surface remeshing"; beyond the thesis's list of steps). Error diffusion quantizes samples to pixel centres and puts
    // neighbours anywhere from 1 to several pixels apart; each Lloyd step moves every interior
    // sample to the mass centroid (mass = control map value, i.e. density times 3D area) of its
    // Voronoi cell over the points of the Lloyd grid (the sampling map rasterized at RL, a multiple of
    // the control map's resolution). The cells are measured in the surface metric (nearest generator
    // in 3D; the centroid is then taken in 3D and pulled onto the surface) or in the sampling map's
    // own metric; boundary samples are fixed generators. The same step for all three modes. Error
    // diffusion leaves a pattern that is isotropic in the sampling map, so stretched on the surface
    // as the map is, and Lloyd steps undo that only slowly (a stretched lattice is itself a fixed
    // point): with 4 steps sampling on U0 stayed more uniform than on Uopt where U0 is the less
    // anisotropic map (nefertiti: 1.24 vs 1.33); steps until the samples settle make the map's
    // signature small against the tie margins.
    if (relax) {
      const auto t_relax = Clock::now();
      std::vector<int> ids;  // interior samples taking part
      for (size_t q = 0; q < samples.size(); ++q)
        if (keep[q]) ids.push_back(int(q));
      const int ni = int(ids.size());
      const int ng = nb + ni;
      MatX3d G(ng, 3);  // generator coordinates for the nearest-neighbour search
      auto sample_s = [&](const Sample& q) {
        return Vec2(q.w0 * uv_row(Us, F(q.face, 0)) + q.w1 * uv_row(Us, F(q.face, 1)) + q.w2 * uv_row(Us, F(q.face, 2)));
      };
      auto sample_x = [&](const Sample& q) {
        return Vec3(q.w0 * row3(V, F(q.face, 0)) + q.w1 * row3(V, F(q.face, 1)) + q.w2 * row3(V, F(q.face, 2)));
      };
      auto set_gen = [&](int g, const Vec2& su, const Vec3& x) {
        if (relax_surface) G.row(g) = x.transpose();
        else G.row(g) << su.x(), su.y(), 0.0;
      };
      for (int k = 0; k < nb; ++k) set_gen(k, bnd_s[k], bnd_x[k]);
      const int nthreads = nlpix > kParallelMin * 4 ? std::max(1, num_threads()) : 1;
      constexpr int kAcc = 9;  // per generator: mass, mass x (map position, 3D position, face normal)
      const MatX3d Nf = relax_surface ? face_normals(V, F) : MatX3d();
      std::vector<double> acc(size_t(kAcc) * ng);
      auto locate = [&](const Vec2& p, int f, Sample& out) { return locate_in_map(Us, F, topo, p, f, out); };
      // Nearest generator of every pixel: a kd-tree the first time; afterwards a greedy walk from the
      // pixel's previous generator over the Voronoi-neighbour graph read off the previous labels
      // (pixels side by side with different labels). Greedy descent on the Delaunay graph finds the
      // nearest site (this graph is its pixel approximation), and samples move less than a cell per step, so the walk is a few distance
      // evaluations instead of a tree search (the relaxation's cost at 1024^2 pixels).
      std::vector<int> label(nlpix, -1);
      std::vector<double> move2(ni);
      constexpr int kMaxNbr = 24;  // Voronoi neighbours kept per generator (a cell has ~6)
      std::vector<int> nbr(size_t(ng) * kMaxNbr), nbr_n(ng);
      auto pix_point = [&](long idx) {
        if (relax_surface) return Vec3(lpix_x[3 * idx], lpix_x[3 * idx + 1], lpix_x[3 * idx + 2]);
        return Vec3((idx % RL + 0.5) / RL, (idx / RL + 0.5) / RL, 0.0);
      };
      // Row bands list their neighbour pairs apart (the build was the step's largest serial part at
      // 1024^2), then each generator's lists are merged and sorted: the walk's visiting order, and so
      // the labels, must not depend on the number of bands.
      const int nadj = std::clamp(nthreads, 1, 4);
      std::vector<int> band_nbr(size_t(nadj) * ng * kMaxNbr), band_n(size_t(nadj) * ng);
      auto build_adjacency = [&]() {
        std::fill(band_n.begin(), band_n.end(), 0);
  #pragma omp parallel for schedule(static, 1) num_threads(nadj) if (nadj > 1)
        for (int t = 0; t < nadj; ++t) {
          int* tl = band_nbr.data() + size_t(t) * ng * kMaxNbr;
          int* tn = band_n.data() + size_t(t) * ng;
          auto add1 = [&](int a, int b) {
            int* l = tl + size_t(a) * kMaxNbr;
            for (int k = 0; k < tn[a]; ++k)
              if (l[k] == b) return;
            if (tn[a] < kMaxNbr) l[tn[a]++] = b;
          };
          auto add = [&](int a, int b) {
            if (a == b || a < 0 || b < 0) return;
            add1(a, b);
            add1(b, a);
          };
          for (int j = RL * t / nadj; j < RL * (t + 1) / nadj; ++j)
            for (int i = 0; i < RL; ++i) {
              const long idx = long(j) * RL + i;
              const int l = label[idx];
              if (l < 0) continue;
              if (i + 1 < RL) add(l, label[idx + 1]);
              if (j + 1 < RL) add(l, label[idx + RL]);
              if (i + 1 < RL && j + 1 < RL) add(l, label[idx + RL + 1]);
              if (i > 0 && j + 1 < RL) add(l, label[idx + RL - 1]);
            }
        }
  #pragma omp parallel for schedule(static) if (ng > kParallelMin)
        for (int g = 0; g < ng; ++g) {
          int* l = nbr.data() + size_t(g) * kMaxNbr;
          int n = 0;
          for (int t = 0; t < nadj; ++t) {
            const int* tl = band_nbr.data() + (size_t(t) * ng + g) * kMaxNbr;
            for (int k = 0, m = band_n[size_t(t) * ng + g]; k < m; ++k)
              if (n < kMaxNbr && std::find(l, l + n, tl[k]) == l + n) l[n++] = tl[k];
          }
          std::sort(l, l + n);
          nbr_n[g] = n;
        }
      };
      for (int it = 0; it < o.lloyd_iterations; ++it) {
        for (int q = 0; q < ni; ++q) {
          const Sample& sm = samples[ids[q]];
          set_gen(nb + q, sample_s(sm), sample_x(sm));
        }
        std::unique_ptr<KdTree> tree;
        if (it == 0) tree = std::make_unique<KdTree>(G);
        else build_adjacency();
        // Labels in parallel; the mass sums then in raster order, so that the centroids do not
        // depend on the thread count or schedule (bit-identical results run to run).
  #pragma omp parallel for schedule(dynamic, 4) num_threads(nthreads) if (nthreads > 1)
        for (int j = 0; j < RL; ++j) {
          for (int i = 0; i < RL; ++i) {
            const long idx = long(j) * RL + i;
            if (lpix_face[idx] < 0) continue;
            const Vec3 qp = pix_point(idx);
            int g;
            if (tree) {
              g = tree->nearest(qp);
            } else {
              g = label[idx];
              double best = (row3(G, g) - qp).squaredNorm();
              for (bool improved = true; improved;) {
                improved = false;
                const int* l = nbr.data() + size_t(g) * kMaxNbr;
                const int n = nbr_n[g];
                for (int k = 0; k < n; ++k) {
                  const double d = (row3(G, l[k]) - qp).squaredNorm();
                  if (d < best) {
                    best = d;
                    g = l[k];
                    improved = true;
                    break;  // walk on from the closer generator
                  }
                }
              }
            }
            label[idx] = g;
          }
        }
        std::fill(acc.begin(), acc.end(), 0.0);
        for (int j = 0; j < RL; ++j) {
          const double y = (j + 0.5) / RL;
          for (int i = 0; i < RL; ++i) {
            const long idx = long(j) * RL + i;
            if (lpix_face[idx] < 0) continue;
            const double x = (i + 0.5) / RL;
            const double m = lpix_val[idx];
            double* ag = acc.data() + kAcc * label[idx];
            ag[0] += m;
            ag[1] += m * x;
            ag[2] += m * y;
            if (relax_surface) {
              ag[3] += m * lpix_x[3 * idx];
              ag[4] += m * lpix_x[3 * idx + 1];
              ag[5] += m * lpix_x[3 * idx + 2];
              const int f = lpix_face[idx];
              ag[6] += m * Nf(f, 0);
              ag[7] += m * Nf(f, 1);
              ag[8] += m * Nf(f, 2);
            }
          }
        }
        // Each sample moves to its cell's mass centroid. In the surface metric that is the centroid
        // in 3D pulled onto the surface (the constrained centroidal Voronoi tessellation of Du,
        // Gunzburger and Ju 2003), here the 3D centroid's offset from the sample within the cell's
        // mean tangent plane: Gauss-Newton steps from the sample towards the surface point nearest to
        // it, through each face's Jacobian. The map's own centroid is not it wherever the map's
        // Jacobian varies across the cell (a cell spans several input faces), and that bias depends
        // on the map: on lion-head's Uopt (anisotropy 4.8) it made more steps raise the area CV
        // instead of lowering it. The steps end at o.lloyd_iterations or when the samples' RMS move
        // falls under kLloydTolerance local spacings (12 steps at 100K vertices, 18-30 at 3000-5000).
        int moved = 0;
  #pragma omp parallel for schedule(static) reduction(+ : moved) if (ni > kParallelMin)
        for (int q = 0; q < ni; ++q) {
          const int g = nb + q;
          move2[q] = 0;
          const double* ag = acc.data() + kAcc * g;
          if (!(ag[0] > 0)) continue;  // no pixel: the sample stays (and is dropped below)
          Sample& sm = samples[ids[q]];
          Sample next;
          Vec2 c;
          if (relax_surface) {
            // Gauss-Newton from the sample itself: a cell can wrap a thin feature, its pixels then lie
            // in two far-apart parts of the map, and their map centroid in neither (from there ~60 of
            // 100K samples on mannequin-devil jumped by half a spacing or more at every step).
            next = sm;
            c = sample_s(sm);
          } else {
            c = Vec2(ag[1] / ag[0], ag[2] / ag[0]);  // the map's own centroid
            const int pi = std::clamp(int(c.x() * RL), 0, RL - 1), pj = std::clamp(int(c.y() * RL), 0, RL - 1);
            const int start = lpix_face[long(pj) * RL + pi] >= 0 ? lpix_face[long(pj) * RL + pi] : sm.face;
            if (!locate(c, start, next)) continue;
          }
          if (relax_surface) {
            // The 3D centroid's offset from the sample, within the cell's mean tangent plane: at a
            // peak or a ridge the 3D centroid lies inside the solid, and the surface point nearest to
            // it is on a flank, so the plain constrained centroid drives samples off sharp tips and
            // crests (three_peaks, targets 4800-5200: mean Hausdorff 0.0080 of the diagonal, 0.0056
            // with this). A cell whose normals cancel (it wraps a thin feature) uses the sample's own.
            const Vec3 x0 = sample_x(sm);
            Vec3 x3(ag[3] / ag[0], ag[4] / ag[0], ag[5] / ag[0]);
            const Vec3 nm(ag[6], ag[7], ag[8]);
            const Vec3 n = nm.norm() > 0.5 * ag[0] ? Vec3(nm.normalized()) : Vec3(row3(Nf, sm.face));
            x3 -= n * n.dot(x3 - x0);
            for (int step = 0; step < 5; ++step) {
              const int f = next.face;
              const Vec2 ua = uv_row(Us, F(f, 0)), ub = uv_row(Us, F(f, 1)), uc = uv_row(Us, F(f, 2));
              const Vec3 xa = row3(V, F(f, 0)), xb = row3(V, F(f, 1)), xc = row3(V, F(f, 2));
              Eigen::Matrix2d M;
              M << ub.x() - ua.x(), uc.x() - ua.x(), ub.y() - ua.y(), uc.y() - ua.y();
              if (!(std::abs(M.determinant()) > 0)) break;
              Eigen::Matrix<double, 3, 2> E;
              E.col(0) = xb - xa;
              E.col(1) = xc - xa;
              const Eigen::Matrix<double, 3, 2> J = E * M.inverse();  // d(3D) / d(map)
              const Eigen::Matrix2d JtJ = J.transpose() * J;
              if (!(std::abs(JtJ.determinant()) > 0)) break;
              const Vec3 x = next.w0 * xa + next.w1 * xb + next.w2 * xc;
              const Vec2 du = JtJ.ldlt().solve(J.transpose() * (x3 - x));
              const Vec2 c1 = c + du;
              Sample at;
              if (!locate(c1, next.face, at)) break;  // off the chart: keep the last point
              c = c1;
              next = at;
              if (du.norm() < 1e-3 / RL) break;
            }
          }
          const Vec2 u = next.w0 * uv_row(Ut, F(next.face, 0)) + next.w1 * uv_row(Ut, F(next.face, 1)) +
                         next.w2 * uv_row(Ut, F(next.face, 2));
          if (!inside_chart(next.face, u, margin)) continue;  // must stay strictly inside for the Delaunay step
          {
            const double r = next.w0 * rho[F(next.face, 0)] + next.w1 * rho[F(next.face, 1)] + next.w2 * rho[F(next.face, 2)];
            const double h = spacing(n_int * r / rho_integral);
            move2[q] = (sample_x(next) - sample_x(sm)).squaredNorm() / (h * h);
          }
          sm = next;
          ++moved;
        }
        res.lloyd_iterations = it + 1;
        report(std::min(0.79, 0.7 + 0.09 * (it + 1) / o.lloyd_iterations));
        if (moved == 0) break;
        // Converged: the samples' RMS move, in local target spacings, under kLloydTolerance.
        const double rms = std::sqrt(ordered_sums<1>(ni, ni > kParallelMin, [&](int q, std::array<double, 1>& a) { a[0] += move2[q]; })[0] / ni);
        if (rms < kLloydTolerance) break;
      }
      res.seconds_relax += seconds_since(t_relax);
    }

    // 4c. Minimum separation: an interior sample closer in 3D than min_separation x the local target
    // spacing to a boundary sample or to an earlier kept interior sample is dropped. Pixel-quantized
    // or stuck samples (a Lloyd cell with no pixel) otherwise make the near-degenerate triangles.
    if (o.min_separation > 0) {
      const auto t_sep = Clock::now();
      MatX3d G(nb + int(samples.size()), 3);
      for (int k = 0; k < nb; ++k) G.row(k) = bnd_x[k].transpose();
      for (size_t q = 0; q < samples.size(); ++q) {
        const Sample& sm = samples[q];
        G.row(nb + int(q)) = sm.w0 * V.row(F(sm.face, 0)) + sm.w1 * V.row(F(sm.face, 1)) + sm.w2 * V.row(F(sm.face, 2));
      }
      const KdTree tree(G);
      const int ns = int(samples.size());
      // Only a sample with some kept neighbour inside its radius can be dropped: find those in
      // parallel, then decide them in order (the verdict depends on earlier drops).
      std::vector<char> crowded(ns, 0);
      std::vector<double> radius(ns, 0.0);
  #pragma omp parallel if (ns > kParallelMin)
      {
        std::vector<std::pair<int, double>> near;
  #pragma omp for schedule(static)
        for (int q = 0; q < ns; ++q) {
          if (!keep[q]) continue;
          const Sample& sm = samples[q];
          const double r = sm.w0 * rho[F(sm.face, 0)] + sm.w1 * rho[F(sm.face, 1)] + sm.w2 * rho[F(sm.face, 2)];
          radius[q] = o.min_separation * spacing(n_int * r / rho_integral);
          tree.radius(row3(G, nb + q), radius[q], near);
          for (const auto& gd : near)
            if (gd.first != nb + q && (gd.first < nb || keep[gd.first - nb])) {
              crowded[q] = 1;
              break;
            }
        }
      }
      std::vector<std::pair<int, double>> near;
      for (int q = 0; q < ns; ++q) {
        if (!crowded[q]) continue;
        tree.radius(row3(G, nb + q), radius[q], near);
        for (const auto& gd : near) {
          const int g = gd.first, other = g - nb;
          if (other == q) continue;
          if (g < nb || (other < q && keep[other])) {
            keep[q] = 0;
            ++res.n_separated;
            break;
          }
        }
      }
      res.seconds_relax += seconds_since(t_sep);
    }
    kept = 0;
    for (char k : keep) kept += k;
    res.sampling_rounds = round + 1;
    if (kept == 0 || std::abs(kept - n_int) <= std::max(1, int(0.005 * n_int)) || round == 3) break;
    const double shortfall = double(n_int) / kept;
    n_goal = std::max(1, int(std::lround(n_goal * shortfall)));
    scale *= shortfall;
  }  // rounds
  if (kept == 0 && n_int > 0)
    throw MeshError("remesh: no inner vertex could be placed (every sample fell within the boundary clearance); "
                    "raise the target or lower the resolution");
  if (res.n_separated > std::max(1, n_int / 100))
    res.warnings.push_back(std::to_string(res.n_separated) + " of " + std::to_string(n_goal) +
                           " interior samples were closer than " + std::to_string(o.min_separation) +
                           " x the target spacing and were dropped (the diffusion oversampled to keep the count): "
                           "the sampling map is too coarse for this target somewhere; raise the resolution or "
                           "sample on the low-stretch map (mode double)");
  const auto t_tri = Clock::now();

  // 5. Delaunay in the triangulation map (Qhull), lift through the shared triangulation.
  int n_keep = 0;
  for (char k : keep) n_keep += k;
  int n_all = nb + n_keep;
  MatX2d P(n_all, 2);
  MatX3d X(n_all, 3);
  std::vector<Sample> PS(n_all, Sample{-1, 0, 0, 0});  // input face + barycentrics (interior only)
  for (int k = 0; k < nb; ++k) {
    P.row(k) = bnd_u[k].transpose();
    X.row(k) = bnd_x[k].transpose();
  }
  {
    // The boundary polygon is convex but for the tips of ears, which leave their neighbours reflex;
    // interior samples in the diametral disk of a polygon edge next to a reflex vertex are left out.
    // With a resampled boundary (no pieces: its samples lie on the ears' sides) this keeps the
    // boundary in the Delaunay triangulation: it keeps such an edge only when no sample lies in
    // that disk (a Gabriel edge), else it connects past the reflex vertex, which becomes an interior
    // vertex. A kept boundary is met anyway (the pieces below); there it keeps the samples away
    // from the ears' sides, which they would see at more than 90 degrees (obtuse triangles on them).
    std::vector<std::pair<Vec2, double>> disks;  // centre, squared radius
    double area2 = 0;
    for (int k = 0; k < nb; ++k) area2 += cross2(bnd_u[k], bnd_u[(k + 1) % nb]);
    for (int k = 0; k < nb; ++k) {
      const Vec2 &a = bnd_u[(k + nb - 1) % nb], &b = bnd_u[k], &c = bnd_u[(k + 1) % nb];
      if (cross2(b - a, c - b) * area2 >= 0) continue;  // convex (or straight) corner
      disks.emplace_back(0.5 * (a + b), 0.25 * (b - a).squaredNorm());
      disks.emplace_back(0.5 * (b + c), 0.25 * (c - b).squaredNorm());
    }
    int w = nb;
    for (size_t s = 0; s < samples.size(); ++s) {
      if (!keep[s]) continue;
      const Sample& q = samples[s];
      const int f = q.face;
      const Vec2 u = (q.w0 * Ut.row(F(f, 0)) + q.w1 * Ut.row(F(f, 1)) + q.w2 * Ut.row(F(f, 2))).transpose();
      if (std::any_of(disks.begin(), disks.end(), [&](const auto& d) { return (u - d.first).squaredNorm() < d.second; })) {
        keep[s] = 0;
        continue;
      }
      P.row(w) = u.transpose();
      X.row(w) = q.w0 * V.row(F(f, 0)) + q.w1 * V.row(F(f, 1)) + q.w2 * V.row(F(f, 2));
      PS[w] = q;
      ++w;
    }
    P.conservativeResize(w, 2);
    X.conservativeResize(w, 3);
    PS.resize(w);
    n_all = w;
  }
  report(0.8);
  // The pieces' points (indices into P): the core's boundary samples and the interior samples on
  // its faces; each ear's prev, tip and next and the interior samples on its face.
  std::vector<int> core_pts(core);
  std::vector<std::vector<int>> ear_pts(ears.size());
  for (size_t e = 0; e < ears.size(); ++e) ear_pts[e] = {ears[e].prev, ears[e].tip, ears[e].next};
  for (int i = nb; i < n_all; ++i) {
    const int e = ear_of_face[PS[i].face];
    (e < 0 ? core_pts : ear_pts[e]).push_back(i);
  }
  // Delaunay triangulation of a piece, counter-clockwise in the map, in P's indices.
  auto triangulate = [&](const std::vector<int>& pts) {
    MatX2d Q(int(pts.size()), 2);
    for (int i = 0; i < Q.rows(); ++i) Q.row(i) = P.row(pts[i]);
    MatX3i T = delaunay_2d(Q);
    for (int t = 0; t < T.rows(); ++t)
      for (int k = 0; k < 3; ++k) T(t, k) = pts[T(t, k)];
    return T;
  };
  const MatX3i T = triangulate(core_pts);
  report(0.92);
  // The output triangles in P's indices, oriented like the input. The core's: without flat
  // triangles (co-linear boundary points) and any outside the core polygon.
  const double area_eps = 1e-14;
  std::vector<std::array<int, 3>> tris;
  tris.reserve(T.rows() + ears.size());
  auto add_map_triangle = [&](int a, int b, int c, bool reverse) {  // (a, b, c) counter-clockwise in the map
    if (reverse) std::swap(b, c);
    tris.push_back({a, b, c});
  };
  for (int t = 0; t < T.rows(); ++t) {
    const Vec2 a = uv_row(P, T(t, 0)), b = uv_row(P, T(t, 1)), c = uv_row(P, T(t, 2));
    if (std::abs(cross2(b - a, c - a)) <= area_eps) continue;
    // Every interior sample of the core is strictly inside the convex core polygon, so the hull is
    // the polygon and only a triangle of three boundary samples can lie outside it (on a straight side).
    const bool all_boundary = T(t, 0) < nb && T(t, 1) < nb && T(t, 2) < nb;
    if (all_boundary && !polygon.inside((a + b + c) / 3.0, 0.0)) continue;
    add_map_triangle(T(t, 0), T(t, 1), T(t, 2), flip);
  }
  // The ears: the input face itself when no sample lies on it (whatever its shape in the map), else
  // the Delaunay triangulation of its corners and samples (strictly inside its triangle, so the
  // hull is the ear and the chord joins the core), oriented like the ear's face in the map.
  for (size_t e = 0; e < ears.size(); ++e) {
    const Ear& ear = ears[e];
    auto sample_of = [&](int v) { return v == loop[ear.tip] ? ear.tip : v == loop[ear.prev] ? ear.prev : ear.next; };
    const int f = ear.face;
    if (ear_pts[e].size() == 3) {
      tris.push_back({sample_of(F(f, 0)), sample_of(F(f, 1)), sample_of(F(f, 2))});
      continue;
    }
    const Vec2 u0 = uv_row(Ut, F(f, 0));
    const bool reverse = cross2(uv_row(Ut, F(f, 1)) - u0, uv_row(Ut, F(f, 2)) - u0) < 0;
    const MatX3i Te = triangulate(ear_pts[e]);
    for (int t = 0; t < Te.rows(); ++t) {
      const Vec2 a = uv_row(P, Te(t, 0)), b = uv_row(P, Te(t, 1)), c = uv_row(P, Te(t, 2));
      if (std::abs(cross2(b - a, c - a)) <= area_eps) continue;
      add_map_triangle(Te(t, 0), Te(t, 1), Te(t, 2), reverse);
    }
  }
  // The chords join the pieces but are no boundary: flips across them (and on from there) give the
  // Delaunay triangulation of the map constrained by the boundary's edges only, the triangulation
  // of all the points in one piece wherever that has the boundary's edges.
  if (!ears.empty()) {
    std::vector<std::pair<int, int>> chords;
    for (const Ear& ear : ears) chords.emplace_back(ear.prev, ear.next);
    delaunay_flips_map(P, tris, chords);
  }
  // Compact: boundary vertices keep their indices, unused interior samples go.
  std::vector<int> id(n_all, -1);
  for (int k = 0; k < nb; ++k) id[k] = k;
  int nout = nb;
  for (const auto& t : tris)
    for (int k = 0; k < 3; ++k)
      if (id[t[k]] < 0) id[t[k]] = nout++;
  res.V.resize(nout, 3);
  res.uv.resize(nout, 2);
  std::vector<Sample> out_s(nout, Sample{-1, 0, 0, 0});
  for (int i = 0; i < n_all; ++i)
    if (id[i] >= 0) {
      res.V.row(id[i]) = X.row(i);
      res.uv.row(id[i]) = P.row(i);
      out_s[id[i]] = PS[i];
    }
  res.F.resize(int(tris.size()), 3);
  for (size_t q = 0; q < tris.size(); ++q)
    for (int k = 0; k < 3; ++k) res.F(int(q), k) = id[tris[q][k]];
  if (o.flip_3d) res.n_flips = delaunay_flips_3d(res.V, res.uv, res.F, flip ? -1.0 : 1.0);
  if (o.smooth_iterations > 0) {
    smooth_remeshed(V, F, topo, Ut, rho, o, nb, flip ? -1.0 : 1.0, out_s, res);
    nout = int(res.V.rows());
  }
  // The result must be a disk whose boundary is exactly the boundary samples.
  try {
    const Topology out = build_topology(res.F, nout);
    bool ok = out.n_components == 1 && out.boundary_loops.size() == 1 && int(out.boundary_loops[0].size()) == nb;
    for (int v = 0; ok && v < nb; ++v) ok = out.on_boundary[v] && !out.is_loose(v);
    if (!ok) throw MeshError("the triangulation's boundary is not the chart's boundary");
  } catch (const MeshError& e) {
    throw Error(std::string("remesh: internal error, the new triangulation is invalid (") + e.what() +
                "); try another resolution or target");
  }
  res.seconds_triangulate = seconds_since(t_tri);
  res.source_face.resize(nout);
  res.source_bary.resize(nout, 3);
  for (int i = 0; i < nout; ++i) {
    const Sample& q = i < nb ? bnd_src[i] : out_s[i];
    // Every sample was located on the input (data is carried over through these), so -1 is a bug.
    if (q.face < 0)
      throw Error("remesh: internal error, output vertex " + std::to_string(i) + " lies on no input face");
    res.source_face[i] = q.face;
    res.source_bary.row(i) << q.w0, q.w1, q.w2;
  }
  report(1);
  return res;
}

}  // namespace dgmesh
