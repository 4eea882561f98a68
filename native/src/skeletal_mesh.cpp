// The skeletal mesh (thesis 6.1); see skeletal.h.
#include "dgmesh/skeletal.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dgmesh/delaunay.h"
#include "dgmesh/detail/skeletal_util.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {

// Tangential part of the uniform bi-umbrella flow (thesis 6.1 pre-smoothing [WDSB00]).
MatX3d bilaplacian_tangential(MatX3d V, const MatX3i& F, const Topology& topo, int iterations, double step) {
  const int n = static_cast<int>(V.rows());
  for (int it = 0; it < iterations; ++it) {
    const MatX3d U2 = bi_umbrella(V, topo, Umbrella::Uniform);
    const MatX3d N = vertex_normals(V, F, topo, NormalWeights::Area);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      if (topo.on_boundary[i] || topo.is_loose(i)) continue;
      const Vec3 u = row3(U2, i), nn = row3(N, i);
      V.row(i) -= step * (u - u.dot(nn) * nn).transpose();
    }
  }
  return V;
}

}  // namespace

namespace detail {

double signed_volume(const MatX3d& V, const MatX3i& F) {
  double vol = 0;
  for (int f = 0; f < F.rows(); ++f) vol += row3(V, F(f, 0)).dot(row3(V, F(f, 1)).cross(row3(V, F(f, 2))));
  return vol / 6;
}

}  // namespace detail

using detail::signed_volume;

SkeletalMesh skeletal_mesh(const Mesh& mesh, const SkeletonOptions& opt) {
  const int n = static_cast<int>(mesh.V.rows());
  const Topology& topo = mesh.topo;
  // Poles are taken on a regularised copy: sliver triangles give spiky Voronoi poles (fig. 6.6).
  const MatX3d Vs = bilaplacian_tangential(mesh.V, mesh.F, topo, opt.presmooth_iterations, opt.presmooth_step);
  MatX3d N = vertex_normals(Vs, mesh.F, topo, NormalWeights::Area);
  if (signed_volume(Vs, mesh.F) < 0) N = -N;  // inside-out faces: the inner side is along +N
  const Delaunay3 del = delaunay_3d(Vs);
  const double cos_max = std::cos(opt.max_pole_angle);

  SkeletalMesh out;
  out.S.resize(n, 3);
  std::vector<char> found(n, 0);
  // Inner Voronoi pole: the farthest vertex of the Voronoi cell on the inner side of the surface
  // (against the outward normal), i.e. the centre of the largest empty ball touching x_i inside.
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) {
    const Vec3 p = row3(Vs, i), inward = -row3(N, i);
    double best = -1;
    Vec3 pole = p;
    for (int k = del.point_offset[i]; k < del.point_offset[i + 1]; ++k) {
      const Vec3 c = row3(del.circumcenters, del.point_tets[k]);
      const Vec3 d = c - p;
      const double r = d.norm();
      if (!(r > 0) || !std::isfinite(r) || d.dot(inward) < cos_max * r) continue;
      if (r > best) best = r, pole = c;
    }
    if (best > 0) {
      out.S.row(i) = pole.transpose();
      found[i] = 1;
    }
  }
  // Vertices without a pole (duplicates Qhull dropped, isolated needles): their ring's mean depth.
  std::vector<double> depth(n, 0.0);
  for (int i = 0; i < n; ++i)
    if (found[i]) depth[i] = (row3(mesh.V, i) - row3(out.S, i)).norm();
  for (int pass = 0; pass < 20; ++pass) {
    bool missing = false;
    for (int i = 0; i < n; ++i) {
      if (found[i]) continue;
      double sum = 0;
      int c = 0;
      for (int k = topo.vv_offset[i]; k < topo.vv_offset[i + 1]; ++k)
        if (found[topo.vv_index[k]] == 1) sum += depth[topo.vv_index[k]], ++c;
      if (c == 0) {
        missing = true;
        continue;
      }
      depth[i] = sum / c;
      out.S.row(i) = (row3(mesh.V, i) - depth[i] * row3(N, i)).transpose();
      found[i] = 2;
      ++out.n_fallback;
    }
    for (int i = 0; i < n; ++i)
      if (found[i] == 2) found[i] = 1;
    if (!missing) break;
  }
  for (int i = 0; i < n; ++i)
    if (!found[i]) {  // a component without any pole: shrink to its vertex (radius 0 handled below)
      out.S.row(i) = mesh.V.row(i);
      ++out.n_fallback;
    }

  // Post-smoothing (thesis 6.1 end).
  std::vector<char> moved(n, 0);
  const SpMatR W = umbrella_matrix(out.S, topo, Umbrella::Uniform);  // uniform: depends on topology only
  std::vector<double> ring;
  for (int it = 0; it < opt.postsmooth_iterations; ++it) {
    const MatX3d U = W * out.S;
    const MatX3d U2 = W * U;
    VecXd rad(n);
    for (int i = 0; i < n; ++i) rad[i] = (row3(mesh.V, i) - row3(out.S, i)).norm();
    int changed = 0;
#pragma omp parallel for schedule(static) reduction(+ : changed)
    for (int i = 0; i < n; ++i) {
      if (topo.is_loose(i)) continue;
      const Vec3 v = -row3(U2, i);  // smoothing vector of the bilaplacian flow
      const Vec3 nn = row3(N, i);
      const bool inverted = (row3(mesh.V, i) - row3(out.S, i)).dot(nn) <= 0;
      double mx = 0, sum = 0;
      int c = 0;
      for (int k = topo.vv_offset[i]; k < topo.vv_offset[i + 1]; ++k) {
        sum += rad[topo.vv_index[k]];
        mx = std::max(mx, rad[topo.vv_index[k]]);
        ++c;
      }
      const bool spike = c > 0 && rad[i] > opt.spike_factor * (sum / c);
      if (v.dot(nn) < 0 || spike || inverted) {
        out.S.row(i) += opt.postsmooth_step * v.transpose();
        if (spike || inverted) {  // pull a spike fully to its ring (a single step is too weak)
          out.S.row(i) = out.S.row(i) * 0.5 + 0.5 * (out.S.row(i) + row3(U, i).transpose());
        }
        moved[i] = 1;
        ++changed;
      }
    }
    if (!changed) break;
  }
  for (char m : moved) out.n_postsmoothed += m;

  out.radii.resize(n);
  for (int i = 0; i < n; ++i) out.radii[i] = (row3(mesh.V, i) - row3(out.S, i)).norm();
  return out;
}

}  // namespace dgmesh
