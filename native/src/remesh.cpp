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
#include "dgmesh/detail/remesh_retry.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/parallel.h"
#include "dgmesh/remesh_flips.h"
#include "dgmesh/remesh_sampling.h"
#include "dgmesh/remesh_smoothing.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {

using detail::BoundarySamples;
using detail::chart_pieces;
using detail::ChartPieces;
using detail::Clock;
using detail::control_raster;
using detail::ControlRaster;
using detail::ConvexPolygon;
using detail::cross2;
using detail::delaunay_flips_3d;
using detail::delaunay_flips_map;
using detail::Ear;
using detail::Sample;
using detail::sample_boundary;
using detail::sample_interior;
using detail::SamplingChart;
using detail::seconds_since;
using detail::smooth_remeshed;
using detail::uv_row;
using detail::Vec2;

// Rejects non-disk input with a message that says what is wrong and what to do.
Topology check_disk(const MatX3d& V, const MatX3i& F) {
  Topology t = validate(V, F, kSurface | kNoLooseVertices);
  const std::string hint =
      " Remeshing needs one disk-shaped chart: select a disk-shaped region of faces or cut the mesh open.";
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

// 1. The two maps (thesis 5.2): U0 with Floater's weights on the convex domain, Uopt by stretch
// equalization (eq. 5.1, 5.3, 5.4) from it.
// (Us: the sampling map, Ut: the triangulation map, as the mode picks them.) Sets res.uopt_iterations and the
// unwrap's warnings.
struct ChartMaps {
  MatX2d U0, Uopt;
};

ChartMaps parameterize(const MatX3d& V, const MatX3i& F, const RemeshOptions& o, const ProgressFn& progress,
                       RemeshResult& res) {
  UnwrapOptions uo = unwrap_thesis_defaults();  // the boundary fixed, as the thesis
  uo.boundary = o.domain;
  uo.weights = UvWeights::Floater;
  uo.max_iterations = o.max_uopt_iterations;
  ChartMaps maps;
  MatX2d& U0 = maps.U0;
  MatX2d& Uopt = maps.Uopt;
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
  return maps;
}

// 2. Density per vertex: rho = (1 - a) + a * min(kappa / mean kappa, clip), kappa = sqrt(k1^2 + k2^2)
// = sqrt(4H^2 - 2K); its integral over the surface normalises the control map.
VecXd vertex_density(const MatX3d& V, const MatX3i& F, const Topology& topo, const RemeshOptions& o) {
  const int nv = topo.n_vertices;
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
      for (int v = 0; v < nv; ++v)
        rho[v] = (1 - o.adaptivity) + o.adaptivity * std::min(kappa[v] / mean, o.curvature_clip);
  }
  return rho;
}

// Delaunay triangulation of a piece, counter-clockwise in the map, in P's indices.
MatX3i triangulate_piece(const MatX2d& P, const std::vector<int>& pts) {
  MatX2d Q(int(pts.size()), 2);
  for (int i = 0; i < Q.rows(); ++i) Q.row(i) = P.row(pts[i]);
  MatX3i T = delaunay_2d(Q);
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 3; ++k) T(t, k) = pts[T(t, k)];
  return T;
}

// Adds (a, b, c), counter-clockwise in the map, oriented like the input (reversed when `reverse`).
void add_map_triangle(std::vector<std::array<int, 3>>& tris, int a, int b, int c, bool reverse) {
  if (reverse) std::swap(b, c);
  tris.push_back({a, b, c});
}

// 5. Delaunay in the triangulation map (Qhull), lift through the shared triangulation.
// samples, keep: the interior samples (keep: those kept; those next to a reflex boundary corner are
// dropped). flip: the chart is clockwise in the triangulation map. Sets res.V, res.uv and res.F (the
// boundary samples first) and returns the output vertices' input locations (interior ones).
std::vector<Sample> triangulate_chart(const SamplingChart& c, const std::vector<Sample>& samples,
                                      std::vector<char>& keep, bool flip, Progress& report, RemeshResult& res) {
  const MatX3d& V = c.V;
  const MatX3i& F = c.F;
  const MatX2d& Ut = c.Ut;
  const std::vector<int>& loop = c.topo.boundary_loops[0];
  const int nb = int(c.bnd.x.size());
  const std::vector<Vec3>& bnd_x = c.bnd.x;
  const std::vector<Vec2>& bnd_u = c.bnd.u;
  const std::vector<Ear>& ears = c.pieces.ears;
  const std::vector<int>& ear_of_face = c.pieces.ear_of_face;
  const std::vector<int>& core = c.pieces.core;
  const ConvexPolygon& polygon = c.pieces.polygon;
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
      if (std::any_of(disks.begin(), disks.end(),
                      [&](const auto& d) { return (u - d.first).squaredNorm() < d.second; })) {
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
  const MatX3i T = triangulate_piece(P, core_pts);
  report(0.92);
  // The output triangles in P's indices, oriented like the input. The core's: without flat
  // triangles (co-linear boundary points) and any outside the core polygon.
  const double area_eps = 1e-14;
  std::vector<std::array<int, 3>> tris;
  tris.reserve(T.rows() + ears.size());
  for (int t = 0; t < T.rows(); ++t) {
    const Vec2 a = uv_row(P, T(t, 0)), b = uv_row(P, T(t, 1)), c = uv_row(P, T(t, 2));
    if (std::abs(cross2(b - a, c - a)) <= area_eps) continue;
    // Every interior sample of the core is strictly inside the convex core polygon, so the hull is
    // the polygon and only a triangle of three boundary samples can lie outside it (on a straight side).
    const bool all_boundary = T(t, 0) < nb && T(t, 1) < nb && T(t, 2) < nb;
    if (all_boundary && !polygon.inside((a + b + c) / 3.0, 0.0)) continue;
    add_map_triangle(tris, T(t, 0), T(t, 1), T(t, 2), flip);
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
    const MatX3i Te = triangulate_piece(P, ear_pts[e]);
    for (int t = 0; t < Te.rows(); ++t) {
      const Vec2 a = uv_row(P, Te(t, 0)), b = uv_row(P, Te(t, 1)), c = uv_row(P, Te(t, 2));
      if (std::abs(cross2(b - a, c - a)) <= area_eps) continue;
      add_map_triangle(tris, Te(t, 0), Te(t, 1), Te(t, 2), reverse);
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
  return out_s;
}

}  // namespace

namespace {

RemeshResult remesh_once(const MatX3d& V, const MatX3i& F, const RemeshOptions& o, const ProgressFn& progress) {
  if (o.target_vertices < 4)
    throw MeshError("remesh: target_vertices must be at least 4, got " + std::to_string(o.target_vertices));
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
  const int nf = topo.n_faces;
  RemeshResult res;
  const auto t_param = Clock::now();

  // 1. The two maps: U0 and Uopt.
  const ChartMaps maps = parameterize(V, F, o, progress, res);
  const MatX2d& U0 = maps.U0;
  const MatX2d& Uopt = maps.Uopt;
  const MatX2d& Us = o.mode == RemeshMode::SingleU0 ? U0 : Uopt;    // sampling map
  const MatX2d& Ut = o.mode == RemeshMode::SingleUopt ? Uopt : U0;  // triangulation map
  res.seconds_parameterize = seconds_since(t_param);
  report(0.4);
  const auto t_sample = Clock::now();

  // 2. Density per vertex, and its integral over the surface (which normalises the control map).
  const VecXd rho = vertex_density(V, F, topo, o);
  const VecXd area3 = face_areas(V, F);
  double rho_integral = 0;  // int rho dA over the surface
  for (int f = 0; f < nf; ++f) rho_integral += area3[f] * (rho[F(f, 0)] + rho[F(f, 1)] + rho[F(f, 2)]) / 3.0;
  double surface_area = area3.sum();
  if (!(rho_integral > 0) || !(surface_area > 0)) throw MeshError("remesh: the mesh has zero area");

  // Boundary samples.
  const int N = o.target_vertices;
  const BoundarySamples bnd = sample_boundary(V, F, topo, Us, Ut, rho, rho_integral, o, res);
  const std::vector<Sample>& bnd_src = bnd.src;
  const int nb = int(bnd.x.size());
  const int n_int = N - nb;
  if (n_int < 1)
    throw MeshError(
        "remesh: target_vertices (" + std::to_string(N) + ") must exceed the number of boundary vertices (" +
        std::to_string(nb) + ")" +
        (o.boundary == RemeshBoundary::Keep ? ", which are kept; raise the target or resample the boundary" : ""));
  res.n_interior_target = n_int;
  res.n_boundary = nb;

  // Orientation of the chart in the triangulation map (the Delaunay triangles come out CCW).
  double signed_area = 0;
  for (int f = 0; f < nf; ++f)
    signed_area += cross2(uv_row(Ut, F(f, 1)) - uv_row(Ut, F(f, 0)), uv_row(Ut, F(f, 2)) - uv_row(Ut, F(f, 0)));
  const bool flip = signed_area < 0;
  // The pieces of the chart in the triangulation map: a convex core and the ears of a kept boundary.
  const ChartPieces pieces = chart_pieces(topo, bnd.u, o);
  const SamplingChart chart{V, F, topo, Us, Ut, rho, rho_integral, n_int, bnd, pieces};
  // 3. The control map over the sampling map.
  const ControlRaster raster = control_raster(chart, area3, o, res);
  report(0.55);

  // 4. Interior samples: error diffusion, Lloyd relaxation, minimum separation.
  std::vector<Sample> samples;
  std::vector<char> keep;
  sample_interior(chart, raster, o, report, t_sample, samples, keep, res);
  const auto t_tri = Clock::now();

  // 5. Delaunay in the triangulation map (Qhull), lift through the shared triangulation.
  std::vector<Sample> out_s = triangulate_chart(chart, samples, keep, flip, report, res);
  int nout = int(res.V.rows());
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
    throw detail::InvalidTriangulation(std::string("remesh: internal error, the new triangulation is invalid (") +
                                       e.what() + "); try another resolution or target");
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

}  // namespace

RemeshResult remesh(const MatX3d& V, const MatX3i& F, const RemeshOptions& o, const ProgressFn& progress) {
  return detail::remesh_with_retry(o, [&](const RemeshOptions& oo) { return remesh_once(V, F, oo, progress); });
}

}  // namespace dgmesh
