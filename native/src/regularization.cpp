// Tangential regularisation (thesis eq. 3.8 with tau = 0, eq. 3.10); see regularization.h.
#include "dgmesh/regularization.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dgmesh/detail/fair_mesh.h"
#include "dgmesh/errors.h"
#include "dgmesh/progress.h"
#include "dgmesh/surface_projection.h"

namespace dgmesh {

using detail::area_normals;
using detail::BoundaryCurves;
using detail::check_input;
using detail::extract;
using detail::mean_edge_length;
using detail::prepare_level;
using detail::slide_boundary;
using detail::Submesh;
using detail::validated_topology;
using detail::Work;

void TangentialDrift::weights(const MatX3d& P, const Topology& t) {
  wts.assign(t.vv_index.size(), 0.0);
#pragma omp parallel for schedule(static) if (t.n_vertices > detail::kFairParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    const int b = t.vv_offset[v], d = t.vv_offset[v + 1] - b;
    if (t.on_boundary[v] || d == 0) continue;  // U_area = 0 on the boundary (thesis)
    const Vec3 p = P.row(v);
    double A = 0;
    for (int i = 0; i < d; ++i) {
      const int j = (i + 1) % d;
      const double a = 0.5 * (Vec3(P.row(t.vv_index[b + i])) - p).cross(Vec3(P.row(t.vv_index[b + j])) - p).norm();
      A += a;
      wts[b + i] += a;
      wts[b + j] += a;
    }
    for (int i = 0; i < d; ++i) {
      const double len = (Vec3(P.row(t.vv_index[b + i])) - p).norm();
      wts[b + i] = (A > 0 && len > 0) ? wts[b + i] / (2.0 * A * d * len) : 0.0;
    }
  }
}

void TangentialDrift::apply(const MatX3d& X, MatX3d& out, const Topology& t) const {
  out.resize(X.rows(), 3);
#pragma omp parallel for schedule(static) if (t.n_vertices > detail::kFairParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    Vec3 s = Vec3::Zero();
    const Vec3 x = X.row(v);
    for (int j = t.vv_offset[v]; j < t.vv_offset[v + 1]; ++j) s += wts[j] * (Vec3(X.row(t.vv_index[j])) - x);
    out.row(v) = s;
  }
}

void TangentialDrift::field(const MatX3d& P, const MatX3d& N, const Topology& t) {
  weights(P, t);
  apply(P, U, t);
  apply(U, U2, t);
#pragma omp parallel for schedule(static) if (t.n_vertices > detail::kFairParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    const Vec3 u = U2.row(v), nv = N.row(v);
    U2.row(v) = -(u - u.dot(nv) * nv);
  }
}

MatX3d regularize(const MatX3d& V, const MatX3i& F, const RegularizeOptions& opt, const ProgressFn& progress_fn) {
  check_input(V, F, opt.vertex_mask, nullptr);
  if (opt.iterations < 0) throw MeshError("iterations must be >= 0");
  if (!(opt.step_scale > 0)) throw MeshError("step_scale must be > 0");
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  const bool whole = opt.vertex_mask.empty();
  std::vector<char> movable_full(n, 1), region_full(m, 0);
  if (!whole)
    for (int v = 0; v < n; ++v) movable_full[v] = opt.vertex_mask[v] != 0;
  Submesh sub = extract(V, F, movable_full, region_full, whole);
  Work& w = sub.work;
  w.topo = validated_topology(w, whole);
  prepare_level(w, opt.boundary);
  const Vec3 centre = w.P.colwise().mean();
  const double scale = mean_edge_length(w.P, w.topo);
  w.P = ((w.P.rowwise() - centre.transpose()) / scale).eval();

  Progress progress(progress_fn);
  progress(0.0);
  TangentialDrift tan;
  BoundaryCurves curves;
  if (opt.boundary == FairBoundary::Sliding) curves.build(w);
  std::vector<char> moves(w.topo.n_vertices, 0);
  for (int v = 0; v < w.topo.n_vertices; ++v) moves[v] = w.movable[v] && !w.sliding[v];
  VecXd areas;
  MatX3d N, fcross;
  std::vector<double> ring_min, ring2_min;
  const SurfaceProjector projector(w.P, w.F, w.topo);
  for (int it = 0; it < opt.iterations; ++it) {
    progress(double(it) / std::max(1, opt.iterations));
    area_normals(w.P, w.F, w.topo, N, areas, fcross);
    // Eq. 3.8 with tau = 0: P += eps T, eps = 12 A_min, with A_min the smallest triangle within
    // two rings of the vertex (the bi-umbrella's reach) rather than of the whole mesh: a scan's few
    // slivers (camel: smallest triangle 6e-5 of the mean) otherwise freeze every other vertex.
    const int nv = w.topo.n_vertices;
    ring_min.assign(nv, std::numeric_limits<double>::infinity());
    for (int v = 0; v < nv; ++v)
      for (int q = w.topo.vf_offset[v]; q < w.topo.vf_offset[v + 1]; ++q)
        ring_min[v] = std::min(ring_min[v], areas[w.topo.vf_index[q]]);
    ring2_min = ring_min;
    for (int v = 0; v < nv; ++v)
      for (int q = w.topo.vv_offset[v]; q < w.topo.vv_offset[v + 1]; ++q)
        ring2_min[v] = std::min(ring2_min[v], ring_min[w.topo.vv_index[q]]);
    tan.field(w.P, N, w.topo);
#pragma omp parallel for schedule(static) if (nv > detail::kFairParallelMin)
    for (int v = 0; v < nv; ++v) {
      if (!moves[v] || !std::isfinite(ring2_min[v])) continue;
      const double eps = opt.step_scale * 12.0 * ring2_min[v];
      const Vec3 p = Vec3(w.P.row(v)) + eps * Vec3(tan.U2.row(v));
      if (opt.project) {
        thread_local std::vector<int> idx;
        thread_local std::vector<double> d2;
        w.P.row(v) = projector.project(p, idx, d2);
      } else {
        w.P.row(v) = p;
      }
    }
    if (opt.boundary == FairBoundary::Sliding) slide_boundary(w, curves, 0.25);
  }
  MatX3d out = V;
  for (int i = 0; i < w.topo.n_vertices; ++i)
    if (w.movable[i] || w.sliding[i]) out.row(sub.verts[i]) = w.P.row(i) * scale + centre.transpose();
  if (!out.allFinite()) throw Error("regularize: the drift diverged (try a smaller step_scale)");
  progress(1.0);
  return out;
}

}  // namespace dgmesh
