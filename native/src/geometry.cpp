#include "dgmesh/geometry.h"

#include <cmath>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/parallel.h"

namespace dgmesh {

namespace {

// Quantities of one face seen from one of its corners a, with b, c the next corners (CCW).
struct CornerGeometry {
  Vec3 ab, ac;          // edges leaving a
  Vec3 cross;           // ab x ac = 2 * area * unit normal
  double area;          // triangle area
  double angle;         // interior angle at a
  double cot_b, cot_c;  // cotangents of the angles at b and c
  bool obtuse_a, obtuse_any;
};

inline CornerGeometry corner(const MatX3d& V, const MatX3i& F, int f, int k) {
  CornerGeometry g;
  const Vec3 a = V.row(F(f, k)), b = V.row(F(f, (k + 1) % 3)), c = V.row(F(f, (k + 2) % 3));
  g.ab = b - a;
  g.ac = c - a;
  const Vec3 bc = c - b;
  g.cross = g.ab.cross(g.ac);
  const double twice_area = g.cross.norm();
  g.area = 0.5 * twice_area;
  const double da = g.ab.dot(g.ac), db = -g.ab.dot(bc), dc = g.ac.dot(bc);
  g.angle = std::atan2(twice_area, da);
  // Validation rejects zero-area faces; the guard only keeps a sliver from producing inf.
  const double inv = twice_area > 0 ? 1.0 / twice_area : 0.0;
  g.cot_b = db * inv;
  g.cot_c = dc * inv;
  g.obtuse_a = da < 0;
  g.obtuse_any = da < 0 || db < 0 || dc < 0;
  return g;
}

// Mixed Voronoi area of the corner (Meyer et al. 2003, fig. 4).
inline double corner_mixed_area(const CornerGeometry& g) {
  if (!g.obtuse_any) return (g.ab.squaredNorm() * g.cot_c + g.ac.squaredNorm() * g.cot_b) / 8.0;
  return g.obtuse_a ? g.area / 2.0 : g.area / 4.0;
}

template <class Fn>
void for_each_corner(const MatX3i& F, const Topology& t, int v, Fn&& fn) {
  for (int i = t.vf_offset[v]; i < t.vf_offset[v + 1]; ++i) {
    const int f = t.vf_index[i];
    const int k = F(f, 0) == v ? 0 : (F(f, 1) == v ? 1 : 2);
    fn(f, k);
  }
}

// Boundary vertices take the mean of their interior neighbours' values.
void extend_to_boundary(VecXd& x, const Topology& t) {
  const VecXd interior = x;
#pragma omp parallel for schedule(static) if (t.n_vertices >= kParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    if (!t.on_boundary[v]) continue;
    double sum = 0.0;
    int n = 0;
    for (int j = t.vv_offset[v]; j < t.vv_offset[v + 1]; ++j) {
      const int w = t.vv_index[j];
      if (!t.on_boundary[w]) sum += interior[w], ++n;
    }
    x[v] = n ? sum / n : 0.0;
  }
}

}  // namespace

MatX3d face_normals(const MatX3d& V, const MatX3i& F) {
  MatX3d N(F.rows(), 3);
#pragma omp parallel for schedule(static) if (F.rows() >= kParallelMin)
  for (int f = 0; f < F.rows(); ++f) {
    const Vec3 n = (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0)));
    const double len = n.norm();
    N.row(f) = len > 0 ? Vec3(n / len) : Vec3::Zero();
  }
  return N;
}

VecXd face_areas(const MatX3d& V, const MatX3i& F) {
  VecXd A(F.rows());
#pragma omp parallel for schedule(static) if (F.rows() >= kParallelMin)
  for (int f = 0; f < F.rows(); ++f)
    A[f] = 0.5 * (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0))).norm();
  return A;
}

MatX3d vertex_normals(const MatX3d& V, const MatX3i& F, const Topology& t, NormalWeights w) {
  MatX3d N(t.n_vertices, 3);
#pragma omp parallel for schedule(static) if (t.n_vertices >= kParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    Vec3 n = Vec3::Zero();
    for_each_corner(F, t, v, [&](int f, int k) {
      const Vec3 a = V.row(F(f, k));
      const Vec3 ab = Vec3(V.row(F(f, (k + 1) % 3))) - a, ac = Vec3(V.row(F(f, (k + 2) % 3))) - a;
      const Vec3 c = ab.cross(ac);
      switch (w) {
        case NormalWeights::Max: {
          const double d = ab.squaredNorm() * ac.squaredNorm();
          if (d > 0) n += c / d;
          break;
        }
        case NormalWeights::Area:
          n += c;
          break;
        case NormalWeights::Angle: {
          const double len = c.norm();
          if (len > 0) n += std::atan2(len, ab.dot(ac)) * c / len;
          break;
        }
      }
    });
    const double len = n.norm();
    N.row(v) = len > 0 ? Vec3(n / len) : Vec3::Zero();
  }
  return N;
}

VecXd mixed_areas(const MatX3d& V, const MatX3i& F, const Topology& t) {
  VecXd A = VecXd::Zero(t.n_vertices);
#pragma omp parallel for schedule(static) if (t.n_vertices >= kParallelMin)
  for (int v = 0; v < t.n_vertices; ++v)
    for_each_corner(F, t, v, [&](int f, int k) { A[v] += corner_mixed_area(corner(V, F, f, k)); });
  return A;
}

SpMat cotan_laplacian(const MatX3d& V, const MatX3i& F) {
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(12 * F.rows());
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      // The edge opposite corner k gets half the cotangent of the angle at k.
      const CornerGeometry g = corner(V, F, f, k);
      const int i = F(f, (k + 1) % 3), j = F(f, (k + 2) % 3);
      const double cot_k = g.ab.dot(g.ac) / std::max(2.0 * g.area, 1e-300);
      const double w = 0.5 * cot_k;
      trip.emplace_back(i, j, w);
      trip.emplace_back(j, i, w);
      trip.emplace_back(i, i, -w);
      trip.emplace_back(j, j, -w);
    }
  SpMat L(V.rows(), V.rows());
  L.setFromTriplets(trip.begin(), trip.end());
  return L;
}

Curvature curvature(const MatX3d& V, const MatX3i& F, const Topology& t) {
  const int n = t.n_vertices;
  Curvature c;
  c.mean.setZero(n);
  c.gaussian.setZero(n);
  c.normals.setZero(n, 3);
  c.area.setZero(n);
  c.laplace.setZero(n, 3);
  // One pass per vertex over its corners: no scatter, so no atomics and no per-thread buffers.
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int v = 0; v < n; ++v) {
    Vec3 lap = Vec3::Zero(), nmax = Vec3::Zero();
    double area = 0.0, angle_sum = 0.0;
    for_each_corner(F, t, v, [&](int f, int k) {
      const CornerGeometry g = corner(V, F, f, k);
      lap += 0.5 * (g.cot_c * g.ab + g.cot_b * g.ac);  // edge ab is opposite c, ac opposite b
      area += corner_mixed_area(g);
      angle_sum += g.angle;
      const double d = g.ab.squaredNorm() * g.ac.squaredNorm();
      if (d > 0) nmax += g.cross / d;
    });
    if (area <= 0) continue;  // loose vertex
    lap /= area;
    const double len = nmax.norm();
    const Vec3 N = len > 0 ? Vec3(nmax / len) : Vec3::Zero();
    c.laplace.row(v) = lap;
    c.normals.row(v) = N;
    c.area[v] = area;
    c.mean[v] = -0.5 * N.dot(lap);
    c.gaussian[v] = (2.0 * detail::kPi - angle_sum) / area;
  }
  extend_to_boundary(c.mean, t);
  extend_to_boundary(c.gaussian, t);
  return c;
}

SpMatR umbrella_matrix(const MatX3d& V, const Topology& t, Umbrella kind) {
  const int n = t.n_vertices;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(t.vv_index.size() + n);
  std::vector<double> w;
  for (int v = 0; v < n; ++v) {
    const int begin = t.vv_offset[v], d = t.vv_offset[v + 1] - begin;
    if (t.on_boundary[v] || d == 0) continue;  // U(P) = 0 on the boundary (thesis 3.1)
    w.assign(d, 1.0 / d);
    if (kind == Umbrella::Area) {
      // U_area(P) = 1/(2An) sum_i a_i (PQ_i/|PQ_i| + PQ_i+1/|PQ_i+1|): neighbour j collects the
      // areas of its two triangles, divided by its edge length.
      const Vec3 P = V.row(v);
      double A = 0.0;
      std::fill(w.begin(), w.end(), 0.0);
      for (int i = 0; i < d; ++i) {
        const int j = (i + 1) % d;
        const Vec3 qi = V.row(t.vv_index[begin + i]), qj = V.row(t.vv_index[begin + j]);
        const double a = 0.5 * (qi - P).cross(qj - P).norm();
        A += a;
        w[i] += a;
        w[j] += a;
      }
      for (int i = 0; i < d; ++i) {
        const double len = (Vec3(V.row(t.vv_index[begin + i])) - P).norm();
        w[i] = (A > 0 && len > 0) ? w[i] / (2.0 * A * d * len) : 0.0;
      }
    }
    double diag = 0.0;
    for (int i = 0; i < d; ++i) {
      trip.emplace_back(v, t.vv_index[begin + i], w[i]);
      diag -= w[i];
    }
    trip.emplace_back(v, v, diag);
  }
  SpMatR W(n, n);
  W.setFromTriplets(trip.begin(), trip.end());
  return W;
}

MatX3d umbrella(const MatX3d& V, const Topology& t, Umbrella kind) { return umbrella_matrix(V, t, kind) * V; }

MatX3d bi_umbrella(const MatX3d& V, const Topology& t, Umbrella kind) {
  const SpMatR W = umbrella_matrix(V, t, kind);
  const MatX3d U = W * V;
  return W * U;
}

}  // namespace dgmesh
