// Discrete Willmore flow and its companions (thesis chapter 3). See fair.h for the interface.
//
// Conventions. Everything runs on a working submesh (the faces within reach of the movable
// vertices) in normalised coordinates: centred and divided by the mean edge length, so that
// the numerical thresholds are scale-free. The thesis's step rules tau = A_min^2/150 and
// eps = 12 A_min are dimensionally homogeneous (F ~ 1/L^3, T ~ 1/L), so normalising does not
// change the flow, only the numbers. H follows the thesis: H = N . Laplace_S(P) / 2 with the
// area-weighted normal (negative on a sphere with outward normals); with it F = -Lap(H) -
// 2H(H^2-K) is the stable (descending) direction.
//
// Convergence: the explicit step is tiny, so a per-iteration energy change says nothing. We
// compare the energy over windows of flow time t_w = r^4 / 52 (the relaxation time of the
// slowest mode of a clamped disk of the region's area, see relaxation_time) and stop when the
// relative change over a window drops below the tolerance. The semi-implicit scheme stops when
// long accepted steps no longer change it; when no step lowers the energy (F is the continuous
// gradient, not the exact gradient of the discrete sum H^2 A) it stops too, and that stall counts
// as converged only after the energy had also stopped changing over accepted steps. It also stops
// when 16 accepted steps found no energy lower (by the tolerance) than the lowest before them:
// capped steps or a step control cycling below long steps never pass the long-step test.
//
// Region mode starts the curvature flows from the linearised minimiser (see linear_start): on
// scanned holes the flat fill's rim crease costs little discrete energy at the mesh's resolution
// (often less than the removed original's noisy surface), so a descent flow started there
// stays near the flat fill; that was the "stall" on large holes, not a wrong step. Likewise each
// level after a subdivision first moves its new midpoints to the cotangent bi-Laplacian's
// minimiser with the old vertices held (see subdivision_start).
#include "dgmesh/fair.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "dgmesh/detail/fair_mesh.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/parallel.h"
#include "dgmesh/regularization.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/unwrap.h"  // connected_labels
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {

using Mat3Row = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

using detail::area_normals;
using detail::BoundaryCurves;
using detail::check_input;
using detail::extract;
using detail::kFairParallelMin;
using detail::kPi;
using detail::mean_edge_length;
using detail::prepare_level;
using detail::slide_boundary;
using detail::Stopwatch;
using detail::Submesh;
using detail::validated_topology;
using detail::Work;

inline int corner_of(const MatX3i& F, int f, int v) { return F(f, 0) == v ? 0 : (F(f, 1) == v ? 1 : 2); }

// Per-iteration geometry of the working mesh; buffers are reused across iterations.
struct Geo {
  Mat3Row cot, cmix, ang;  // per face corner: cotangent, mixed (Voronoi) area, angle
  MatX3d fcross;           // per face: (b-a) x (c-a) = 2 area n
  VecXd farea;
  VecXd A, H, K;  // per vertex: mixed area, mean curvature (thesis sign), Gaussian
  MatX3d N, LP;   // area-weighted unit normal (eq. 3.7), Laplace_S(P) (eq. 3.11)
};

void extend_to_boundary(VecXd& x, const Topology& t, const VecXd& interior) {
#pragma omp parallel for schedule(static) if (t.n_vertices > kFairParallelMin)
  for (int v = 0; v < t.n_vertices; ++v) {
    if (!t.on_boundary[v]) continue;
    double s = 0;
    int c = 0;
    for (int j = t.vv_offset[v]; j < t.vv_offset[v + 1]; ++j)
      if (!t.on_boundary[t.vv_index[j]]) s += interior[t.vv_index[j]], ++c;
    x[v] = c ? s / c : 0.0;
  }
}

void compute_geometry(const MatX3d& P, const MatX3i& F, const Topology& t, Geo& g) {
  const int m = static_cast<int>(F.rows()), n = t.n_vertices;
  g.cot.resize(m, 3);
  g.cmix.resize(m, 3);
  g.ang.resize(m, 3);
  g.fcross.resize(m, 3);
  g.farea.resize(m);
#pragma omp parallel for schedule(static) if (m > kFairParallelMin)
  for (int f = 0; f < m; ++f) {
    const Vec3 p[3] = {P.row(F(f, 0)), P.row(F(f, 1)), P.row(F(f, 2))};
    const Vec3 cr = (p[1] - p[0]).cross(p[2] - p[0]);
    const double twice = cr.norm();
    g.fcross.row(f) = cr;
    g.farea[f] = 0.5 * twice;
    const double inv = twice > 0 ? 1.0 / twice : 0.0;
    double dots[3], len2[3];
    bool obtuse = false;
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = p[(k + 1) % 3] - p[k], w = p[(k + 2) % 3] - p[k];
      dots[k] = u.dot(w);
      len2[k] = (p[(k + 1) % 3] - p[(k + 2) % 3]).squaredNorm();  // edge opposite corner k
      g.cot(f, k) = dots[k] * inv;
      g.ang(f, k) = std::atan2(twice, dots[k]);
      obtuse |= dots[k] < 0;
    }
    for (int k = 0; k < 3; ++k) {
      // Meyer et al.'s mixed area: Voronoi part of corner k, or area/2 (obtuse at k) / area/4.
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      if (!obtuse)
        g.cmix(f, k) = (len2[k2] * g.cot(f, k2) + len2[k1] * g.cot(f, k1)) / 8.0;
      else
        g.cmix(f, k) = dots[k] < 0 ? g.farea[f] / 2 : g.farea[f] / 4;
    }
  }
  g.A.resize(n);
  g.H.resize(n);
  g.K.resize(n);
  g.N.resize(n, 3);
  g.LP.resize(n, 3);
#pragma omp parallel for schedule(static) if (n > kFairParallelMin)
  for (int v = 0; v < n; ++v) {
    double a = 0, angle = 0;
    Vec3 nn = Vec3::Zero(), lap = Vec3::Zero();
    const Vec3 pv = P.row(v);
    for (int i = t.vf_offset[v]; i < t.vf_offset[v + 1]; ++i) {
      const int f = t.vf_index[i], k = corner_of(F, f, v), k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      a += g.cmix(f, k);
      angle += g.ang(f, k);
      nn += g.fcross.row(f).transpose();
      // Edge v-b is opposite corner k2, edge v-c opposite k1 (eq. 3.11, cotangent weights).
      lap += 0.5 * (g.cot(f, k2) * (Vec3(P.row(F(f, k1))) - pv) + g.cot(f, k1) * (Vec3(P.row(F(f, k2))) - pv));
    }
    const double len = nn.norm();
    const Vec3 N = len > 0 ? Vec3(nn / len) : Vec3::Zero();
    g.N.row(v) = N;
    g.A[v] = a;
    if (a > 0) lap /= a;
    g.LP.row(v) = lap;
    g.H[v] = 0.5 * N.dot(lap);
    g.K[v] = a > 0 ? (2.0 * kPi - angle) / a : 0.0;
  }
  // Boundary vertices have no angle deficit of their own: extrapolate from the interior.
  const VecXd H0 = g.H, K0 = g.K;
  extend_to_boundary(g.H, t, H0);
  extend_to_boundary(g.K, t, K0);
}

// Laplace_S of a scalar field with the cotangent weights of g, at vertex v.
inline double laplace_scalar(const MatX3i& F, const Topology& t, const Geo& g, const VecXd& x, int v) {
  double s = 0;
  for (int i = t.vf_offset[v]; i < t.vf_offset[v + 1]; ++i) {
    const int f = t.vf_index[i], k = corner_of(F, f, v), k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    s += 0.5 * (g.cot(f, k2) * (x[F(f, k1)] - x[v]) + g.cot(f, k1) * (x[F(f, k2)] - x[v]));
  }
  return g.A[v] > 0 ? s / g.A[v] : 0.0;
}

double energy_of(const Work& w, const Geo& g) {
  const int n = w.topo.n_vertices;
  return ordered_sums<1>(n, n > kFairParallelMin, [&](int v, std::array<double, 1>& e) {
    if (w.energy_set[v]) e[0] += g.H[v] * g.H[v] * g.A[v];
  })[0];
}

double min_area_near(const Work& w, const Geo& g) {
  double a = std::numeric_limits<double>::infinity();
  for (int f = 0; f < w.F.rows(); ++f)
    if (w.near[f]) a = std::min(a, g.farea[f]);
  return std::isfinite(a) ? a : 0.0;
}

// CHOLMOD's threads cost more than they save on small systems under load (a 120-vertex patch:
// 1.9 s, 0.2 s with one thread); the simplicial LDL^T has none.
SparseSolver::Kind spd_kind(int unknowns) {
  return unknowns < 3000 ? SparseSolver::Kind::Cholesky : SparseSolver::Kind::Supernodal;
}

// The uniform bi-umbrella U0^2 = W W of the thesis's section 3.2 (W = D^-1 G: G the graph Laplacian,
// G_kk = -d_k and G_kj = 1 on k's ring, with zero rows at boundary vertices where U0 = 0; D the
// valences) in symmetric form: S = G^T D^-1 G, returned with D. At an interior vertex i, S's row is
// D U0^2's (sum_k G_ik G_kj / d_k; a term through a boundary vertex k vanishes in both, G_kj = 0),
// so U0^2 P = 0 at the movable vertices (all interior) is S_mm x = -S_mf X_f, and the bilaplacian
// flow's backward Euler step (I + tau U0^2) is (D_m + tau S_mm) x = D_m p - tau S_mf X_f, both
// symmetric positive definite when every movable component meets a fixed vertex (the second for
// any tau > 0): Cholesky instead of the sparse LU of the unsymmetric U0^2, whose factorisations
// were 74% of the bilaplacian run and 41% of a 10-iteration Willmore run on a 6240-vertex region
// (callgrind, bench/notes/fair.md). Same solutions up to rounding. Only the rows and columns of
// the vertices with idx[v] >= 0 are complete (the terms of a vertex k whose closed ring has none
// are left out): the blocks S_mm and S_mf that the solves read.
SpMat symmetric_bi_umbrella(const Topology& t, const std::vector<int>& idx, VecXd& valence) {
  const int n = t.n_vertices;
  valence.setOnes(n);
  std::vector<Eigen::Triplet<double>> trip;
  for (int k = 0; k < n; ++k) {
    const int b = t.vv_offset[k], d = t.valence(k);
    if (d > 0) valence[k] = d;
    if (t.on_boundary[k] || d == 0) continue;
    bool any = idx[k] >= 0;
    for (int q = 0; q < d && !any; ++q) any = idx[t.vv_index[b + q]] >= 0;
    if (!any) continue;
    // G_k^T G_k / d_k: G_kk = -d_k, G_kj = 1 on the ring.
    trip.emplace_back(k, k, static_cast<double>(d));
    for (int qa = 0; qa < d; ++qa) {
      const int a = t.vv_index[b + qa];
      trip.emplace_back(k, a, -1.0);
      trip.emplace_back(a, k, -1.0);
      for (int qb = 0; qb < d; ++qb) trip.emplace_back(a, t.vv_index[b + qb], 1.0 / d);
    }
  }
  SpMat S(n, n);
  S.setFromTriplets(trip.begin(), trip.end());
  return S;
}

// Willmore / Laplacian-of-H speed F at movable vertices (eq. 3.5 / 3.12), with the thesis's
// rescaling of H where the discrete H^2 - K < 0 (applied in the nonlinear term, so that
// Laplace_S(H) stays a smooth function of the geometry). Returns lambda.
double normal_speed(const Work& w, const Geo& g, FairMethod method, VecXd& speed) {
  const int n = w.topo.n_vertices;
  double lambda = 1.0;
  if (method == FairMethod::Willmore)
    for (int v = 0; v < n; ++v) {
      const double h = g.H[v], k = g.K[v];
      if (w.movable[v] && h != 0 && h * h - k < 0) lambda = std::min(lambda, std::sqrt(h * h / k));
    }
  speed.setZero(n);
#pragma omp parallel for schedule(static) if (n > kFairParallelMin)
  for (int v = 0; v < n; ++v) {
    if (!w.movable[v] || w.sliding[v]) continue;
    double s = -laplace_scalar(w.F, w.topo, g, g.H, v);
    if (method == FairMethod::Willmore) {
      double h = g.H[v];
      const double k = g.K[v];
      if (h != 0 && h * h - k < 0) h /= lambda;
      s -= 2.0 * h * (h * h - k);
    }
    speed[v] = s;
  }
  return lambda;
}

// The semi-implicit system M + tau/2 L M^-1 L over the movable vertices: L the cotangent
// stiffness (eq. 3.11's weights, from the per-corner cotangents of g), M the mixed areas. Its
// pattern (the movable vertices' two rings) and the value slot each product term
// L_ak L_kb / M_k adds to are set up once per level, so a refactorisation only refills the
// values (the sparse product and triplet sorts it replaces took 38 ms of a 236 ms step on the
// 26K-vertex armadillo).
struct ImplicitSystem {
  SpMat A;
  std::vector<int> corner_slot;          // per face corner k: L's ring slots of edge (k+1, k+2), both ways
  std::vector<int> term_offset;          // per vertex k: start of its closed ring's pairs in term_slot
  std::vector<int> term_slot;            // per pair (a, b) of k's closed ring: A's value index, -1 if fixed
  std::vector<int> diag_slot;            // per movable vertex: A's diagonal value index
  std::vector<double> lring, ldiag, cv;  // L by ring slot (aligned with vv_index), its diagonal

  void setup(const Work& w, const std::vector<int>& idx, int nm) {
    const Topology& t = w.topo;
    const int n = t.n_vertices, m = static_cast<int>(w.F.rows());
    auto ring_slot = [&](int i, int j) {
      for (int q = t.vv_offset[i]; q < t.vv_offset[i + 1]; ++q)
        if (t.vv_index[q] == j) return q;
      throw Error("fair: internal error (edge missing from a vertex ring)");
    };
    corner_slot.resize(6 * static_cast<size_t>(m));
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) {
        const int i = w.F(f, (k + 1) % 3), j = w.F(f, (k + 2) % 3);
        corner_slot[6 * f + 2 * k] = ring_slot(i, j);
        corner_slot[6 * f + 2 * k + 1] = ring_slot(j, i);
      }
    // Pattern: every movable pair in some closed ring, and the diagonal.
    std::vector<Eigen::Triplet<double>> trip;
    term_offset.assign(n + 1, 0);
    for (int k = 0; k < n; ++k) {
      const int b = t.vv_offset[k], d = t.vv_offset[k + 1] - b;
      bool any = idx[k] >= 0;
      for (int q = 0; q < d && !any; ++q) any = idx[t.vv_index[b + q]] >= 0;
      term_offset[k + 1] = term_offset[k] + (any ? (d + 1) * (d + 1) : 0);
      if (!any) continue;
      for (int qa = -1; qa < d; ++qa)
        for (int qb = -1; qb < d; ++qb) {
          const int ia = idx[qa < 0 ? k : t.vv_index[b + qa]], ib = idx[qb < 0 ? k : t.vv_index[b + qb]];
          if (ia >= 0 && ib >= 0) trip.emplace_back(ia, ib, 0.0);
        }
    }
    A.resize(nm, nm);
    A.setFromTriplets(trip.begin(), trip.end());
    A.makeCompressed();
    auto slot = [&](int r, int c) {
      const int* first = A.innerIndexPtr() + A.outerIndexPtr()[c];
      const int* last = A.innerIndexPtr() + A.outerIndexPtr()[c + 1];
      return static_cast<int>(std::lower_bound(first, last, r) - A.innerIndexPtr());
    };
    term_slot.resize(term_offset[n]);
    for (int k = 0; k < n; ++k) {
      if (term_offset[k + 1] == term_offset[k]) continue;
      const int b = t.vv_offset[k], d = t.vv_offset[k + 1] - b;
      int o = term_offset[k];
      for (int qa = -1; qa < d; ++qa)
        for (int qb = -1; qb < d; ++qb, ++o) {
          const int ia = idx[qa < 0 ? k : t.vv_index[b + qa]], ib = idx[qb < 0 ? k : t.vv_index[b + qb]];
          term_slot[o] = ia >= 0 && ib >= 0 ? slot(ia, ib) : -1;
        }
    }
    diag_slot.assign(n, -1);
    for (int v = 0; v < n; ++v)
      if (idx[v] >= 0) diag_slot[v] = slot(idx[v], idx[v]);
  }

  void fill(const Work& w, const Geo& g, double tau) {
    const Topology& t = w.topo;
    const int n = t.n_vertices, m = static_cast<int>(w.F.rows());
    lring.assign(t.vv_index.size(), 0.0);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) {
        const double c = 0.5 * g.cot(f, k);
        lring[corner_slot[6 * f + 2 * k]] += c;
        lring[corner_slot[6 * f + 2 * k + 1]] += c;
      }
    ldiag.assign(n, 0.0);
    for (int v = 0; v < n; ++v)
      for (int q = t.vv_offset[v]; q < t.vv_offset[v + 1]; ++q) ldiag[v] -= lring[q];
    double* val = A.valuePtr();
    std::fill(val, val + A.nonZeros(), 0.0);
    for (int k = 0; k < n; ++k) {
      if (term_offset[k + 1] == term_offset[k]) continue;
      const int b = t.vv_offset[k], d = t.vv_offset[k + 1] - b;
      cv.resize(d + 1);
      cv[0] = ldiag[k];
      for (int q = 0; q < d; ++q) cv[q + 1] = lring[b + q];
      const double c = 0.5 * tau / g.A[k];
      const int* ts = term_slot.data() + term_offset[k];
      for (int qa = 0; qa <= d; ++qa)
        for (int qb = 0; qb <= d; ++qb, ++ts)
          if (*ts >= 0) val[*ts] += c * (cv[qa] * cv[qb]);
    }
    for (int v = 0; v < n; ++v)
      if (diag_slot[v] >= 0) val[diag_slot[v]] += g.A[v];
  }
};

// FairMethod::Hinge: the edge-based discrete Willmore energy (Grinspun et al., "Discrete shells",
// SCA 2003; Bobenko, "A conformal energy for simplicial surfaces", 2005, as the bending energy of
// the hinges) sum_e 3 theta_e^2 |e|^2 / A_e, theta_e the angle between the normals of the two faces
// of edge e, A_e their summed areas. A crease of angle theta along a rim of length L costs
// about 3 theta^2 L / h, growing as the mesh gets finer (h the edge length), where sum H^2 A (one
// rim vertex sees a quarter of it, theta^2/4) does not: a flattened region's rim crease is charged
// at its cost. Its hinges: the interior edges of the working mesh with a face near a movable vertex
// (so the rim's edges, with the fixed faces outside, carry the tangent-plane (G1) boundary data).
struct Hinge {
  int v[4];  // v0 -> v1 the edge in face (v0, v1, v2); v3 opposite it in the other face (v1, v0, v3)
};

std::vector<Hinge> hinges_near(const Work& w) {
  const int m = static_cast<int>(w.F.rows());
  struct Half {
    long long key;
    int f, k;
  };
  std::vector<Half> half;
  half.reserve(3 * static_cast<size_t>(m));
  const long long n = w.topo.n_vertices;
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const long long a = w.F(f, k), b = w.F(f, (k + 1) % 3);
      half.push_back({std::min(a, b) * n + std::max(a, b), f, k});
    }
  std::sort(half.begin(), half.end(), [](const Half& x, const Half& y) { return x.key < y.key; });
  std::vector<Hinge> out;
  for (size_t i = 0; i + 1 < half.size(); ++i) {
    if (half[i].key != half[i + 1].key || (i + 2 < half.size() && half[i + 2].key == half[i].key)) continue;
    const Half &h1 = half[i], &h2 = half[i + 1];
    if (!w.near[h1.f] && !w.near[h2.f]) continue;
    // A degenerate face outside (fixed: it stays degenerate) would make the energy infinite.
    auto flat_fixed = [&](int f) {
      const Vec3 p0 = w.P.row(w.F(f, 0)), p1 = w.P.row(w.F(f, 1)), p2 = w.P.row(w.F(f, 2));
      return !w.near[f] && !((p1 - p0).cross(p2 - p0).norm() > 0);
    };
    if (flat_fixed(h1.f) || flat_fixed(h2.f)) continue;
    Hinge h;
    h.v[0] = w.F(h1.f, h1.k);
    h.v[1] = w.F(h1.f, (h1.k + 1) % 3);
    h.v[2] = w.F(h1.f, (h1.k + 2) % 3);
    h.v[3] = w.F(h2.f, (h2.k + 2) % 3);
    out.push_back(h);
  }
  return out;
}

// theta (signed), the weight c = 3 |e|^2 / A_e and, when g is given, d theta / d x_k (k = 0..3; the
// gradient of Bridson et al., "Simulation of clothing with folds and wrinkles", SCA 2003). False
// for a degenerate hinge.
bool hinge_terms(const MatX3d& P, const Hinge& h, double& theta, double& c, Vec3* g) {
  const Vec3 x0 = P.row(h.v[0]), x1 = P.row(h.v[1]), x2 = P.row(h.v[2]), x3 = P.row(h.v[3]);
  const Vec3 e = x1 - x0;
  const double le = e.norm();
  const Vec3 n1 = e.cross(x2 - x0), n2 = (x0 - x1).cross(x3 - x1);
  const double a1 = n1.norm(), a2 = n2.norm();
  if (!(le > 0 && a1 > 0 && a2 > 0)) return false;
  const Vec3 eh = e / le, u1 = n1 / a1, u2 = n2 / a2;
  theta = std::atan2(u1.cross(u2).dot(eh), u1.dot(u2));
  c = 3.0 * le * le / (0.5 * (a1 + a2));
  if (g) {
    const Vec3 m1 = n1 / (a1 * a1), m2 = n2 / (a2 * a2);
    g[0] = -((x2 - x1).dot(eh) * m1 + (x3 - x1).dot(eh) * m2);
    g[1] = (x2 - x0).dot(eh) * m1 + (x3 - x0).dot(eh) * m2;
    g[2] = -le * m1;
    g[3] = -le * m2;
  }
  return true;
}

double hinge_energy(const MatX3d& P, const std::vector<Hinge>& hs) {
  double e = 0, theta, c;
  for (const Hinge& h : hs) {
    if (!hinge_terms(P, h, theta, c, nullptr)) return std::numeric_limits<double>::infinity();
    e += c * theta * theta;
  }
  return e;
}

struct LevelReport {
  int iterations = 0;
  bool converged = false;
  double lambda = 1.0;
  bool linear_start = false;
  bool energy_rose = false;
  bool restarted = false;
  double e_start = 0, e_end = 0;  // the level's energy before anything moved and at its end
  double max_move = 0;            // largest move of a vertex over the level (mean edge lengths)
};

class Driver {
 public:
  Driver(const FairOptions& o, Progress& p, Stopwatch& c, std::vector<double>& e)
      : opt_(o), progress_(p), clock_(c), energy_(e) {}

  bool start_fallback() const { return start_fallback_; }

  // first_new: the level's first vertex made by its subdivision (0 on the first level).
  LevelReport run(Work& w, int level, int levels, int first_new) {
    level_ = level;
    levels_ = levels;
    curves_.build(w);
    curves_.hint.assign(w.topo.n_vertices, {-1, -1});
    movable_idx_.assign(w.topo.n_vertices, -1);
    nm_ = 0;
    for (int v = 0; v < w.topo.n_vertices; ++v)
      if (w.movable[v] && !w.sliding[v]) movable_idx_[v] = nm_++;
    h_ = mean_edge_length(w.P, w.topo);
    free_comp_.assign(w.topo.n_components, 1);
    for (int v = 0; v < w.topo.n_vertices; ++v)
      if (movable_idx_[v] < 0) free_comp_[w.topo.component[v]] = 0;
    any_free_ = std::find(free_comp_.begin(), free_comp_.end(), 1) != free_comp_.end();
    keep_size_ = opt_.keep_size && opt_.method != FairMethod::Bilaplacian && any_free_;
    if (keep_size_) place_and_size(w.P, w.F, w.topo, comp_center_, comp_area_);
    const MatX3d P_in = w.P;
    compute_geometry(w.P, w.F, w.topo, g_);
    const double e_in = energy_of(w, g_);
    e_level_in_ = e_in;
    declined_.resize(0, 3);
    if (opt_.method == FairMethod::Bilaplacian) return finish_level(run_bilaplacian(w), w, P_in, e_in);
    if (opt_.method == FairMethod::Hinge) return run_hinge(w, P_in);
    // The linear start is tried on the first level with movable vertices (a fill without inner
    // vertices only gets them by subdivision) and counts as that level's first iteration.
    const bool try_lin = opt_.linear_start && !tried_linear_ && nm_ > 0 && opt_.max_iterations > 0;
    tried_linear_ = tried_linear_ || try_lin;
    const bool lin = try_lin && linear_start(w);
    const bool sub = !lin && first_new > 0 && !out_of_budget(0) && subdivision_start(w, first_new);
    // The slow-progress stop is for regions (every part has fixed vertices): a closed object faired
    // whole creeps to its round shape with an energy excess quadratic in the deviation (Blender's
    // mirrored 1:2:1 ellipsoid stopped at a radius spread of 1.2% against < 1% after the full flow).
    // The restart below judges how far the flow from the input got, so that flow runs without it
    // too (bench fair_repair's bull tip 12% dent: stopped at 126 iterations it had not moved a
    // quarter of the way, and the restart from the linear start, 2.7e6, ended at 0.0253 of the
    // diagonal from the original against 0.0124 after the full 300).
    slow_stop_ = !any_free_ && !(try_lin && !lin && declined_.rows() == w.P.rows() && max_move(P_in, declined_) > 1.0);
    LevelReport r = finish_level(run_curvature_flow(w, lin || sub ? 1 : 0, sub), w, P_in, e_in);
    slow_stop_ = true;
    r.linear_start = lin;
    // Restart from the declined linear start when the flow from the input stalled at a discrete
    // minimum near it (FairResult::restarted): a flattened region of a scan whose crease along the
    // fixed rim is cheap at the mesh's resolution (issue 30: elephant, bull, camel tips stayed put;
    // the hand's tip moved 2 edges of the linear start's 9.6).
    const double lin_away = declined_.rows() == w.P.rows() ? max_move(P_in, declined_) : 0.0;
    if (try_lin && !lin && lin_away > 1.0 && r.max_move < 0.25 * lin_away && !out_of_budget(r.iterations)) {
      w.P = declined_;
      compute_geometry(w.P, w.F, w.topo, g_);
      energy_.push_back(energy_of(w, g_));
      LevelReport r2 = finish_level(run_curvature_flow(w, r.iterations + 1, false), w, P_in, e_in);
      r2.linear_start = r2.restarted = true;
      return r2;
    }
    return r;
  }

 private:
  double max_move(const MatX3d& A, const MatX3d& B) const {
    double m = 0;
    for (int v = 0; v < w_rows(A, B); ++v) m = std::max(m, (A.row(v) - B.row(v)).squaredNorm());
    return std::sqrt(m);
  }
  static int w_rows(const MatX3d& A, const MatX3d& B) { return static_cast<int>(std::min(A.rows(), B.rows())); }
  LevelReport finish_level(LevelReport r, Work& w, const MatX3d& P_in, double e_in) {
    compute_geometry(w.P, w.F, w.topo, g_);
    r.e_start = e_in;
    r.e_end = energy_of(w, g_);
    r.max_move = max_move(P_in, w.P);
    return r;
  }
  bool out_of_budget(int it) const {
    return it >= opt_.max_iterations || (opt_.max_seconds > 0 && clock_.seconds() > opt_.max_seconds);
  }
  void report(int it) {
    const double frac = (level_ + std::min(1.0, double(it) / std::max(1, opt_.max_iterations))) / (levels_ + 1);
    progress_(std::min(frac, 0.999));
  }
  // Tracks flow time; returns true when a window ended with a relative change below tolerance.
  bool window_converged(double dt, double e, double t_window) {
    t_acc_ += dt;
    if (t_acc_ < t_window) return false;
    const double rel = std::abs(e_mark_ - e) / std::max(std::abs(e_mark_), 1e-300);
    t_acc_ = 0;
    e_mark_ = e;
    return rel < opt_.tolerance;
  }
  // Relative change over the last two accepted steps (rejected steps do not count).
  bool semi_converged(double e) {
    accepted_.push_back(e);
    const size_t k = accepted_.size();
    if (k < 3) return false;
    const double e2 = accepted_[k - 3];
    return std::abs(e2 - e) / std::max(std::abs(e2), 1e-300) < opt_.tolerance;
  }
  // Semi-implicit: the lowest energy of the last kProgressWindow accepted steps is within the
  // tolerance of the lowest before them. Ends the levels the long-step test cannot: steps that
  // stay capped or an accept/accept/reject cycle below s = 1e3 (torus levels ran their whole
  // budget at a relative change of 2e-6 per step, or with the energy creeping up).
  static constexpr size_t kProgressWindow = 16;
  bool no_progress() const {
    const size_t k = accepted_.size();
    if (k <= kProgressWindow) return false;
    const auto split = accepted_.end() - kProgressWindow;
    const double before = *std::min_element(accepted_.begin(), split);
    const double now = *std::min_element(split, accepted_.end());
    return before - now < opt_.tolerance * std::abs(before);
  }
  // Semi-implicit: the energy fell over the last kSlowWindow accepted steps by less than
  // opt_.min_progress times the smaller of its fall since the level began (from the level's input
  // energy, or from the flow's start when that is higher: a restart) and the energy left (sum H^2 A
  // >= 0 bounds what more steps can gain). A flow creeping at that pace has made its drop (issue
  // 30's 104K-vertex case: 90% of the drop by iteration 3, then 0.1-0.3% per step over the
  // 300-iteration budget; bench/notes/fair.md); one still halving a small energy (a flattened
  // catenoid disk going back to H = 0) goes on.
  static constexpr size_t kSlowWindow = 8;
  bool slow_progress(double e) const {
    const size_t k = accepted_.size();
    if (!slow_stop_ || opt_.min_progress <= 0 || k <= kSlowWindow) return false;
    const double fall = std::max(e_level_in_, accepted_.front()) - e;
    return fall > 0 && accepted_[k - 1 - kSlowWindow] - e < opt_.min_progress * std::min(fall, e);
  }
  void tangential_step(Work& w, const MatX3d& N, double eps) {
    tan_.field(w.P, N, w.topo);
    const int n = w.topo.n_vertices;
#pragma omp parallel for schedule(static) if (n > kFairParallelMin)
    for (int v = 0; v < n; ++v)
      if (movable_idx_[v] >= 0) w.P.row(v) += eps * tan_.U2.row(v);
  }

  // Centroid (area-weighted over faces) and area of each component.
  static void place_and_size(const MatX3d& P, const MatX3i& F, const Topology& t, MatX3d& center, VecXd& area) {
    center = MatX3d::Zero(t.n_components, 3);
    area = VecXd::Zero(t.n_components);
    for (int f = 0; f < F.rows(); ++f) {
      const Vec3 a = P.row(F(f, 0)), b = P.row(F(f, 1)), c = P.row(F(f, 2));
      const double af = 0.5 * (b - a).cross(c - a).norm();
      const int k = t.component[F(f, 0)];
      area[k] += af;
      center.row(k) += (af / 3.0) * (a + b + c).transpose();
    }
    for (int k = 0; k < t.n_components; ++k)
      if (area[k] > 0) center.row(k) /= area[k];
  }
  // keep_size: a component without fixed vertices goes back to its centroid and area after each
  // step. The discrete Willmore energy is invariant under similarities (cotangent weights and
  // angle deficits are scale-free, H^2 A is too), and the Willmore and Laplacian-of-H flows are
  // scale-equivariant (F ~ 1/L^3), so this changes neither the energy nor the shapes the flow goes
  // through, only the size and place they are seen at: eight.off had shrunk to 0.59 of its area,
  // elephant.off grown to 1.6. (Not for the bilaplacian flow: rescaled, its collapse towards a
  // point would instead converge to its slowest mode, a needle or a disk.)
  void restore_place_and_size(Work& w) {
    if (!keep_size_) return;
    place_and_size(w.P, w.F, w.topo, cur_center_, cur_area_);
    for (int v = 0; v < w.topo.n_vertices; ++v) {
      const int k = w.topo.component[v];
      if (!free_comp_[k] || !(cur_area_[k] > 0) || !(comp_area_[k] > 0)) continue;
      const double scale = std::sqrt(comp_area_[k] / cur_area_[k]);
      w.P.row(v) = comp_center_.row(k) + scale * (w.P.row(v) - cur_center_.row(k));
    }
  }

  // Willmore energy of each component (over the energy set).
  void component_energy(const Work& w, VecXd& e) const {
    e = VecXd::Zero(w.topo.n_components);
    for (int v = 0; v < w.topo.n_vertices; ++v)
      if (w.energy_set[v]) e[w.topo.component[v]] += g_.H[v] * g_.H[v] * g_.A[v];
  }

  // A component without fixed vertices may not drift: its energy is translation invariant, so
  // the exact gradient has no net translation, but the discrete speed F N sums to a small net
  // force, and the preconditioner leaves the translation mode (in L's null space) undamped, so the
  // long semi-implicit steps turned it into a steady drift (eight.off moved 6 bbox diagonals in
  // 200 steps). Removes the mass-weighted mean of u over each such component.
  void remove_translation(const Work& w, Eigen::MatrixXd& u) {
    const int nc = w.topo.n_components;
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(nc, 3);
    VecXd mass = VecXd::Zero(nc);
    for (int v = 0; v < w.topo.n_vertices; ++v) {
      const int c = w.topo.component[v];
      if (!free_comp_[c]) continue;
      sum.row(c) += g_.A[v] * u.row(movable_idx_[v]);
      mass[c] += g_.A[v];
    }
    for (int v = 0; v < w.topo.n_vertices; ++v) {
      const int c = w.topo.component[v];
      if (free_comp_[c] && mass[c] > 0) u.row(movable_idx_[v]) -= sum.row(c) / mass[c];
    }
  }

  // Flow time over which the slowest shape mode of the movable region relaxes under the leading
  // (bi-Laplacian) part of the flow: a clamped disk of the region's area a (r^2 = a/pi) has
  // first plate eigenvalue ~104/r^4, and u_t = -Lap^2 u / 2 relaxes it in 2/lambda = r^4/52.
  // The explicit scheme compares energies over windows of this flow time.
  double relaxation_time(const Work& w, const Geo& g) const {
    double a = 0;
    for (int v = 0; v < w.topo.n_vertices; ++v)
      if (movable_idx_[v] >= 0) a += g.A[v];
    const double r2 = a / kPi;
    return std::max(r2 * r2 / 52.0, std::pow(h_, 4) / 8.0);
  }

  // B's rows of the solved vertices (idx[v] >= 0, ns of them) split into solved columns (Bmm) and
  // the others (Bmf), and the other vertices' positions Xf in Bmf's column order: B P = 0 becomes
  // Bmm x = -Bmf Xf.
  static void split_fixed(const SpMat& B, const MatX3d& P, const std::vector<int>& idx, int ns, SpMat& Bmm, SpMat& Bmf,
                          MatX3d& Xf) {
    const int n = static_cast<int>(P.rows());
    std::vector<int> fixed_idx(n, -1);
    int nf = 0;
    for (int v = 0; v < n; ++v)
      if (idx[v] < 0) fixed_idx[v] = nf++;
    std::vector<Eigen::Triplet<double>> tm, tf;
    for (int c = 0; c < B.outerSize(); ++c)
      for (SpMat::InnerIterator it(B, c); it; ++it) {
        const int r = idx[it.row()];
        if (r < 0) continue;
        if (idx[c] >= 0)
          tm.emplace_back(r, idx[c], it.value());
        else
          tf.emplace_back(r, fixed_idx[c], it.value());
      }
    Bmm.resize(ns, ns);
    Bmm.setFromTriplets(tm.begin(), tm.end());
    Bmf.resize(ns, nf);
    Bmf.setFromTriplets(tf.begin(), tf.end());
    Xf.resize(nf, 3);
    for (int v = 0; v < n; ++v)
      if (fixed_idx[v] >= 0) Xf.row(fixed_idx[v]) = P.row(v);
  }

  // Region mode: start from the minimiser of the linearised energy with the fixed vertices as
  // boundary data, i.e. the steady state of the thesis's bilaplacian flow: U0^2 P = 0 at the
  // movable vertices (uniform bi-umbrella, section 3.2), one sparse solve. The two fixed rings
  // enter through U0^2, so this start meets the surrounding surface with position and tangent
  // continuity; the Willmore flow then continues from it. A flat fill has a crease along the
  // rim whose discrete energy is small on a coarse mesh (about theta^2/4 per rim vertex), so a
  // flow started there stays near it. The start is taken only when it lowers the discrete
  // energy, so the recorded energy stays monotone. (Cotangent weights on the flat fill's own
  // metric gave a nearly flat start on scanned holes; the uniform weights do not depend on it.
  // FairStartWeights::Cotangent uses the input's metric: better on some dented regions, worse on
  // flattened ones, bench fair_repair.)
  bool linear_start(Work& w) {
    if (nm_ == 0 || nm_ == w.topo.n_vertices) return false;
    // A failed solve (e.g. a movable component without fixed neighbours) starts from the input.
    Eigen::MatrixXd x;
    if (!linear_minimiser(w, x)) return false;
    return take_if_lower(w, movable_idx_, x);
  }

  // x: the movable vertices' rows of U0^2 P = 0 with the others held (see symmetric_bi_umbrella), or
  // with FairStartWeights::Cotangent of L M^-1 L P = 0 (cotangent_held_minimiser; U0^2 when that
  // fails); false when the solve fails. A component without fixed vertices makes S_mm singular: the
  // unsymmetric LU of U0^2 then, as before.
  // Sets start_fallback_ when the cotangent start was asked for and the uniform one is used.
  bool linear_minimiser(const Work& w, Eigen::MatrixXd& x) {
    if (opt_.start_weights == FairStartWeights::Cotangent) {
      if (!any_free_ && cotangent_held_minimiser(w, x)) return true;
      start_fallback_ = true;
    }
    if (any_free_) {
      const SpMatR W = umbrella_matrix(w.P, w.topo, Umbrella::Uniform);
      return held_solve(SpMat(W * W), w.P, movable_idx_, nm_, SparseSolver::Kind::LU, x);
    }
    VecXd d;
    return held_solve(symmetric_bi_umbrella(w.topo, movable_idx_, d), w.P, movable_idx_, nm_, spd_kind(nm_), x);
  }

  // FairStartWeights::Cotangent: x solves L M^-1 L P = 0 at the movable vertices, L (eq. 3.11's
  // cotangent weights) and M (mixed areas) of the current (input) geometry, the others held: the
  // system CGAL's PMP::fair solves. Symmetric positive semi-definite (M > 0); false when a mixed
  // area is not positive or the solve fails (the caller then takes the uniform start).
  bool cotangent_held_minimiser(const Work& w, Eigen::MatrixXd& x) const {
    const Topology& t = w.topo;
    const VecXd M = mixed_areas(w.P, w.F, t);
    // 1 / M_k enters the rows of k's closed ring only: a degenerate vertex away from the movable
    // vertices' rings (a sliver of the scan two rings out) does not matter.
    VecXd Minv = VecXd::Zero(t.n_vertices);
    for (int k = 0; k < t.n_vertices; ++k) {
      if (M[k] > 0) {
        Minv[k] = 1.0 / M[k];
        continue;
      }
      if (movable_idx_[k] >= 0) return false;
      for (int q = t.vv_offset[k]; q < t.vv_offset[k] + t.valence(k); ++q)
        if (movable_idx_[t.vv_index[q]] >= 0) return false;
    }
    const SpMat L = cotan_laplacian(w.P, w.F);
    return held_solve(SpMat(SpMat(L.transpose()) * Minv.asDiagonal() * L), w.P, movable_idx_, nm_, spd_kind(nm_), x);
  }

  // x: the rows idx[v] of B P = 0 solved for the vertices with idx[v] >= 0 (ns of them), the others
  // held at P (split_fixed); false when the factorisation or the solve fails or x is not finite.
  static bool held_solve(const SpMat& B, const MatX3d& P, const std::vector<int>& idx, int ns, SparseSolver::Kind kind,
                         Eigen::MatrixXd& x) {
    SpMat Bmm, Bmf;
    MatX3d Xf;
    split_fixed(B, P, idx, ns, Bmm, Bmf, Xf);
    try {
      SparseSolver solver;
      solver.factor(Bmm, kind);
      x = solver.solve(-(Bmf * Xf));
    } catch (const SolverError&) {
      return false;
    }
    return x.allFinite();
  }

  // Solves B P = 0 as held_solve and takes the solution when it lowers the energy (take_if_lower);
  // false when the solve fails.
  bool take_held_minimiser(Work& w, const SpMat& B, const std::vector<int>& idx, int ns, SparseSolver::Kind kind) {
    Eigen::MatrixXd x;
    return held_solve(B, w.P, idx, ns, kind, x) && take_if_lower(w, idx, x);
  }

  // A level after a subdivision. The linear 1-to-4 split leaves the coarse facets flat, and at the
  // new midpoints the discrete energy measures the creases between them. On a Blender torus faired
  // whole (48 x 12 quads, Subdivisions 4; the flow makes it a Willmore torus, whose inner side
  // needs thin triangles) it rose from 19.7 to 384 and 570 at the third and fourth splits, and
  // those levels spent 126 and all 300 iterations of capped steps bringing it down (the fourth
  // stalled at 206, its inner side crumpled). So the new movable vertices first go to the
  // minimiser of the linearised energy (the cotangent bi-Laplacian, X^T L M^-1 L X) with every
  // other vertex held, when that lowers the energy. There it took each split's 38.5-39.7 to within
  // 0.7% of where the level ends (19.74 on the fourth), the levels took 8, 5, 2 and 2 flow
  // iterations, and the smallest angle stayed 4.8 degrees (it had fallen to 1.5). The faceted
  // mesh's metric is right and L reproduces linear functions on it, so flat facets give no
  // tangential pull; the uniform bi-umbrella of linear_start pulls midpoints along thin triangles
  // (on that torus it raised the energy at the first two splits, and the finer levels kept
  // 2.8-degree corners). The flow's fixed points do not change.
  bool subdivision_start(Work& w, int first_new) {
    const int n = w.topo.n_vertices;
    std::vector<int> idx(n, -1);
    int ns = 0;
    for (int v = first_new; v < n; ++v)
      if (movable_idx_[v] >= 0) idx[v] = ns++;
    if (ns == 0) return false;
    const VecXd M = mixed_areas(w.P, w.F, w.topo);
    if (!(M.minCoeff() > 0)) return false;
    const SpMat L = cotan_laplacian(w.P, w.F);
    return take_held_minimiser(w, SpMat(SpMat(L.transpose()) * M.cwiseInverse().asDiagonal() * L), idx, ns,
                               SparseSolver::Kind::Supernodal);
  }

  // Moves the vertices with idx[v] >= 0 to the rows idx[v] of x when that lowers the discrete
  // energy, recorded then as an iteration (so the recorded energy stays monotone); else w is left
  // as it was.
  bool take_if_lower(Work& w, const std::vector<int>& idx, const Eigen::MatrixXd& x) {
    if (!x.allFinite()) return false;
    compute_geometry(w.P, w.F, w.topo, g_);
    const double e0 = energy_of(w, g_);
    const MatX3d P0 = w.P;
    for (int v = 0; v < w.topo.n_vertices; ++v)
      if (idx[v] >= 0) w.P.row(v) = x.row(idx[v]);
    compute_geometry(w.P, w.F, w.topo, g_);
    const double e1 = energy_of(w, g_);
    if (!(e1 < e0) || g_.farea.minCoeff() <= 1e-12) {
      if (g_.farea.minCoeff() > 1e-12 && std::isfinite(e1)) declined_ = w.P;  // a regular mesh: see run()
      w.P = P0;
      compute_geometry(w.P, w.F, w.topo, g_);
      return false;
    }
    energy_.push_back(e1);
    return true;
  }

  // The lowest-energy state of a level, returned if the level ends above where it started: on
  // meshes a flow cannot improve (a cylinder whose caps are triangle fans, slivers) the unjudged
  // tangential sub-steps or the explicit scheme's instability can raise the energy step after step
  // and inflate the mesh, and the bi-umbrella flow shrinks a closed mesh without fixed vertices
  // towards a point (the only case where it applies to that flow, see run_bilaplacian). (Only then: a level that ends
  // below its start keeps its last state, whose slow energy creep goes with real progress of the mesh; see the report.)
  struct Lowest {
    double start, best;
    MatX3d P;
    void track(double e, const MatX3d& Pc) {
      if (e < best) best = e, P = Pc;
    }
  };
  void keep_lowest(Work& w, double e, const Lowest& lowest, LevelReport& rep) {
    if (e <= lowest.start * (1 + 10 * opt_.tolerance) + 1e-12) return;
    w.P = lowest.P;
    compute_geometry(w.P, w.F, w.topo, g_);
    energy_.push_back(lowest.best);
    rep.energy_rose = true;
    rep.converged = false;
  }

  // near_steady: the level starts from subdivision_start's minimiser (see s below).
  LevelReport run_curvature_flow(Work& w, int it0, bool near_steady) {
    LevelReport rep;
    compute_geometry(w.P, w.F, w.topo, g_);
    double e = energy_of(w, g_);
    if (!std::isfinite(e)) throw Error("fair: the curvature of the input is not finite");
    e_mark_ = e;
    t_acc_ = 0;
    accepted_.assign(1, e);
    Lowest lowest{e, e, w.P};
    const double t_window = relaxation_time(w, g_);
    const bool semi = opt_.scheme == FairScheme::SemiImplicit;
    // Semi-implicit: tau = s h^4. Start large (the step is stable for any tau; the energy test
    // shortens it when needed) and grow until the slowest modes of the region relax in one step.
    // A level started from subdivision_start's minimiser is near its steady state, so its first
    // step is already long enough (s >= 1e3) to count for the convergence test below: otherwise a
    // well-shaped mesh (an ellipsoid, Subdivisions 3) still spent the 3 steps the test needs on
    // each refined level and the minimiser only added its solve.
    double s = near_steady ? 1024.0 : 64.0;
    constexpr double s_max = 1e6;
    double s_used = 0;
    double cap = 0.5;  // longest step, in mean edge lengths
    SparseSolver solver;
    bool have_pattern = false;
    double factored_tau = -1;
    int since_factor = 0;
    MatX3d P_prev;
    int it = it0;
    while (!out_of_budget(it)) {
      report(it);
      rep.lambda = normal_speed(w, g_, opt_.method, speed_);
      const double amin = min_area_near(w, g_);
      const double eps = opt_.tangential ? 12.0 * amin : 0.0;
      double dt;
      if (!semi) {
        // Eq. 3.8: P += tau F N + eps T, tau = A_min^2 / 150.
        const double tau = opt_.step_scale * amin * amin / 150.0;
        if (opt_.tangential) tan_.field(w.P, g_.N, w.topo);
        const int n = w.topo.n_vertices;
#pragma omp parallel for schedule(static) if (n > kFairParallelMin)
        for (int v = 0; v < n; ++v) {
          if (movable_idx_[v] < 0) continue;
          Vec3 d = tau * speed_[v] * Vec3(g_.N.row(v));
          if (opt_.tangential) d += eps * Vec3(tan_.U2.row(v));
          w.P.row(v) += d;
        }
        if (opt_.boundary == FairBoundary::Sliding) slide_boundary(w, curves_, 0.25);
        restore_place_and_size(w);
        compute_geometry(w.P, w.F, w.topo, g_);
        e = energy_of(w, g_);
        if (!std::isfinite(e)) throw Error("fair: the explicit flow diverged (try a smaller step_scale)");
        dt = tau;
      } else {
        if (nm_ == 0) break;
        const double tau = s * std::pow(h_, 4);
        // u = tau (M + tau/2 L M^-1 L)^-1 M F N over the movable vertices. The matrix is only a
        // preconditioner (the fixed points are F = 0 whatever it is), so it is rebuilt when tau
        // changes or every few iterations, not at every step. (The step control changes tau at
        // almost every step, so this is mostly a refill of the values and a numeric refactorisation
        // over the level's pattern and symbolic analysis: 80-90% of a step on large meshes.)
        if (tau != factored_tau || since_factor >= 4) {
          if (!have_pattern) system_.setup(w, movable_idx_, nm_);
          system_.fill(w, g_, tau);
          const SpMat& A = system_.A;
          if (!have_pattern) {
            solver.factor(A, SparseSolver::Kind::Supernodal);
            have_pattern = true;
          } else {
            solver.refactor(A);
          }
          factored_tau = tau;
          since_factor = 0;
        }
        ++since_factor;
        Eigen::MatrixXd rhs(nm_, 3);
        for (int v = 0; v < w.topo.n_vertices; ++v) {
          const int i = movable_idx_[v];
          if (i >= 0) rhs.row(i) = tau * g_.A[v] * speed_[v] * g_.N.row(v);
        }
        Eigen::MatrixXd u = solver.solve(rhs);
        remove_translation(w, u);
        // Keep each vertex's step below `cap` edges (half an edge at most): scale the whole
        // step so that its 98th percentile length meets the cap (a uniform scaling keeps the
        // preconditioned descent direction), then clamp the few outliers on their own. Scaling
        // by the maximum instead let a single spike (a tiny-area vertex with a huge speed,
        // e.g. where the thesis's H rescaling divides by a small lambda) shrink everyone's step
        // to nothing. The cap also shrinks on rejection, because a capped step does not
        // shorten with tau: shrinking tau alone rejected every step and stopped the flow at
        // the linear start on refined fan fills (the fan-plus-refine stall).
        ulen_.resize(nm_);
        for (int i = 0; i < nm_; ++i) ulen_[i] = u.row(i).norm();
        const double umax = ulen_.maxCoeff();
        const bool capped = umax > cap * h_;
        if (capped) {
          const int k = nm_ - 1 - nm_ / 50;
          ulen_sorted_.assign(ulen_.data(), ulen_.data() + nm_);
          std::nth_element(ulen_sorted_.begin(), ulen_sorted_.begin() + k, ulen_sorted_.end());
          const double q = ulen_sorted_[k];
          const double f = q > cap * h_ ? cap * h_ / q : 1.0;
          for (int i = 0; i < nm_; ++i) {
            const double l = f * ulen_[i];
            u.row(i) *= l > cap * h_ ? cap * h_ / ulen_[i] : f;
          }
        }
        P_prev = w.P;
        for (int v = 0; v < w.topo.n_vertices; ++v)
          if (movable_idx_[v] >= 0) w.P.row(v) += u.row(movable_idx_[v]);
        // The trial state's geometry goes to g_try_: a rejected step keeps g_ as it was.
        compute_geometry(w.P, w.F, w.topo, g_try_);
        const double e_new = energy_of(w, g_try_);
        // Energy rose by more than the tolerance allows: reject and shorten the step. When even
        // short steps cannot lower it, the flow direction no longer decreases the discrete
        // energy: a stall, which counts as converged only if the energy had also stopped changing
        // over the last accepted steps. (The tangential sub-steps below are not judged: undoing
        // them when they raise the energy left fan-filled holes stuck; see the report.)
        if (!(e_new <= e * (1 + 0.1 * opt_.tolerance))) {
          w.P = P_prev;
          s /= 16;
          if (capped) cap /= 16;
          ++it;
          energy_.push_back(e);
          if (capped ? cap < 1e-5 : s < 1e-2) {
            const size_t k = accepted_.size();
            const double e_ref = accepted_[k >= 4 ? k - 4 : 0];
            // A stall before any accepted step is not convergence (F is not a descent
            // direction of the discrete energy there).
            rep.converged = k >= 4 && std::abs(e_ref - e) <= 10 * opt_.tolerance * std::abs(e_ref);
            break;
          }
          continue;
        }
        std::swap(g_, g_try_);
        s_used = capped ? 0.0 : s;  // a capped step says nothing about a steady state
        s = std::min(s * 4, s_max);
        cap = std::min(cap * 4, 0.5);
        if (opt_.tangential) {
          // A few explicit drift sub-steps per (large) normal step keep the mesh regular.
          const double eps_t = 12.0 * min_area_near(w, g_);
          for (int k = 0; k < 4; ++k) {
            // The drift reads the normals only (the full geometry follows the sub-steps).
            if (k > 0) area_normals(w.P, w.F, w.topo, g_.N, g_.farea, g_.fcross);
            tangential_step(w, g_.N, eps_t);
          }
        }
        if (opt_.boundary == FairBoundary::Sliding) slide_boundary(w, curves_, 0.25);
        restore_place_and_size(w);
        compute_geometry(w.P, w.F, w.topo, g_);
        e = energy_of(w, g_);
        dt = tau;
      }
      lowest.track(e, w.P);
      energy_.push_back(e);
      ++it;
      // Semi-implicit: every step is long (s >= 64 h^4 is ~5e4 explicit steps), so the window
      // is three iterations (an accept/accept/reject cycle of the step control).
      // Semi-implicit: only a long step (s >= 1e3) that barely changes the energy shows a
      // steady state; a step shortened by the energy test says nothing.
      if (semi ? semi_converged(e) && s_used >= 1e3 : window_converged(dt, e, t_window)) {
        rep.converged = true;
        break;
      }
      if (semi && slow_progress(e)) {
        rep.converged = true;
        break;
      }
      if (semi && no_progress()) {
        // Converged when the energy also settled over the window (not when it crept up).
        const double e_ref = accepted_[accepted_.size() - 1 - kProgressWindow];
        rep.converged = std::abs(e_ref - e) <= opt_.tolerance * std::abs(e_ref);
        break;
      }
    }
    keep_lowest(w, e, lowest, rep);
    rep.iterations = it;
    return rep;
  }

  // FairMethod::Hinge: Levenberg-Marquardt on the hinge energy (residuals sqrt(c_e) theta_e, their
  // weights held over a step) over the movable vertices, started (first level with movable vertices)
  // from the linearised minimiser U0^2 P = 0 (linear_start: always taken; the Willmore flow takes it
  // only when it lowers sum H^2 A). A step is kept when it lowers the energy; the damping grows x4
  // on a rejected step and shrinks /3 on an accepted one, in units of JtJ's mean diagonal. (Scaling
  // each row by its own diagonal, Marquardt's choice, took 96 instead of 15 iterations on a 6240-vertex
  // region, at a relative change per step just above the tolerance.) Stops when a step changes
  // the energy by less than tolerance / 10 (relative) or no damping up to 1e6 x the mean diagonal lowers it.
  LevelReport run_hinge(Work& w, const MatX3d& P_in) {
    LevelReport rep;
    const std::vector<Hinge> hs = hinges_near(w);
    double e = hinge_energy(w.P, hs);
    rep.e_start = e;
    int it = 0;
    if (opt_.linear_start && !tried_linear_ && nm_ > 0 && nm_ < w.topo.n_vertices && opt_.max_iterations > 0) {
      tried_linear_ = true;
      Eigen::MatrixXd x;
      if (linear_minimiser(w, x)) {
        MatX3d P = w.P;
        for (int v = 0; v < w.topo.n_vertices; ++v)
          if (movable_idx_[v] >= 0) P.row(v) = x.row(movable_idx_[v]);
        const double e1 = hinge_energy(P, hs);
        if (std::isfinite(e1)) {
          w.P = P;
          e = e1;
          rep.linear_start = true;
          energy_.push_back(e);
          ++it;
        }
      }
    }
    const int nm = nm_, n3 = 3 * nm;
    double mu = 1e-3;
    SparseSolver solver;  // JtJ keeps its pattern: one symbolic analysis per level
    bool analysed = false;
    const SparseSolver::Kind kind = spd_kind(n3);
    // JtJ's pattern and, per term (in the hinges' order), the value it adds to are set up on the
    // first iteration; later ones refill the values in the same order (the same sums as
    // setFromTriplets', which took 4% of a step).
    std::vector<Eigen::Triplet<double>> trip;
    std::vector<int> term_slot, diag_slot;
    SpMat JtJ(n3, n3);
    Eigen::VectorXd grad(n3);
    while (!out_of_budget(it) && nm > 0) {
      report(it);
      const bool first = term_slot.empty();
      trip.clear();
      grad.setZero();
      double* val = JtJ.valuePtr();
      if (!first) std::fill(val, val + JtJ.nonZeros(), 0.0);
      size_t term = 0;
      for (const Hinge& h : hs) {
        double theta, c;
        Vec3 g[4];
        if (!hinge_terms(w.P, h, theta, c, g)) {  // degenerate: no term, the same pattern (refactor)
          theta = c = 0;
          for (Vec3& x : g) x.setZero();
        }
        const double sc = std::sqrt(c), r = sc * theta;
        int id[4];
        for (int k = 0; k < 4; ++k) id[k] = movable_idx_[h.v[k]];
        for (int a = 0; a < 4; ++a) {
          if (id[a] < 0) continue;
          for (int d = 0; d < 3; ++d) grad[3 * id[a] + d] += sc * g[a][d] * r;
          for (int b = 0; b < 4; ++b) {
            if (id[b] < 0) continue;
            for (int da = 0; da < 3; ++da)
              for (int db = 0; db < 3; ++db) {
                const double x = c * g[a][da] * g[b][db];
                if (first)
                  trip.emplace_back(3 * id[a] + da, 3 * id[b] + db, x);
                else
                  val[term_slot[term++]] += x;
              }
          }
        }
      }
      if (first) {
        for (int i = 0; i < n3; ++i) trip.emplace_back(i, i, 0.0);
        JtJ.setFromTriplets(trip.begin(), trip.end());
        auto slot = [&](int r, int col) {
          const int* lo = JtJ.innerIndexPtr() + JtJ.outerIndexPtr()[col];
          const int* hi = JtJ.innerIndexPtr() + JtJ.outerIndexPtr()[col + 1];
          return static_cast<int>(std::lower_bound(lo, hi, r) - JtJ.innerIndexPtr());
        };
        term_slot.resize(trip.size() - n3);
        for (size_t q = 0; q < term_slot.size(); ++q) term_slot[q] = slot(trip[q].row(), trip[q].col());
        diag_slot.resize(n3);
        for (int i = 0; i < n3; ++i) diag_slot[i] = slot(i, i);
      }
      const double dmean = std::max(JtJ.diagonal().mean(), 1e-12);
      bool accepted = false;
      double e_new = e;
      while (mu <= 1e6) {
        SpMat A = JtJ;
        for (int i = 0; i < n3; ++i) A.valuePtr()[diag_slot[i]] += mu * dmean;
        Eigen::MatrixXd step;
        try {
          if (analysed)
            solver.refactor(A);
          else
            solver.factor(A, kind);
          analysed = true;
          step = solver.solve(-grad);
        } catch (const SolverError&) {
          mu *= 4;
          analysed = false;
          continue;
        }
        MatX3d P = w.P;
        for (int v = 0; v < w.topo.n_vertices; ++v)
          if (movable_idx_[v] >= 0)
            for (int d = 0; d < 3; ++d) P(v, d) += step(3 * movable_idx_[v] + d, 0);
        e_new = hinge_energy(P, hs);
        if (std::isfinite(e_new) && e_new < e) {
          w.P = P;
          accepted = true;
          mu = std::max(mu / 3, 1e-7);
          break;
        }
        mu *= 4;
      }
      if (!accepted) {
        rep.converged = true;  // no damping lowers it: a (local) minimum at this resolution
        break;
      }
      ++it;
      energy_.push_back(e_new);
      const double rel = (e - e_new) / std::max(e, 1e-300);
      e = e_new;
      if (rel < 0.1 * opt_.tolerance) {
        rep.converged = true;
        break;
      }
    }
    rep.iterations = it;
    rep.e_end = e;
    rep.max_move = max_move(P_in, w.P);
    return rep;
  }

  // P <- P - tau U0^2(P) (thesis section 3.2), explicit or backward Euler.
  LevelReport run_bilaplacian(Work& w) {
    LevelReport rep;
    const int n = w.topo.n_vertices;
    const bool semi = opt_.scheme == FairScheme::SemiImplicit;
    SpMat B;  // explicit: U0^2; semi-implicit: its symmetric form S (symmetric_bi_umbrella)
    VecXd valence;
    if (semi) {
      B = symmetric_bi_umbrella(w.topo, movable_idx_, valence);
    } else {
      const SpMatR W = umbrella_matrix(w.P, w.topo, Umbrella::Uniform);
      B = SpMat(W * W);
    }
    compute_geometry(w.P, w.F, w.topo, g_);
    double e = energy_of(w, g_);
    e_mark_ = e;
    t_acc_ = 0;
    // The flow shrinks a component without fixed vertices towards a point: each such component's
    // lowest-energy state is tracked on its own (an object may hold a closed part and an open one,
    // whose falling energy hid the closed part's collapse in the total).
    VecXd ec, e_start, e_best;
    MatX3d P_best;
    if (any_free_) {
      component_energy(w, e_start);
      e_best = e_start;
      P_best = w.P;
    }
    double tau = semi ? 1.0 : 0.2 * opt_.step_scale;  // explicit: stable below 0.5
    SparseSolver solver;
    SpMat Bmm, Bmf;
    if (semi) {
      split_fixed(B, w.P, movable_idx_, nm_, Bmm, Bmf, fixed_pos_);
    }
    double tau_factored = -1;  // the step the factorisation holds (refactored only when it changes)
    int it = 0;
    MatX3d BP;
    while (!out_of_budget(it) && nm_ > 0) {
      report(it);
      const MatX3d P_prev = w.P;
      if (!semi) {
        BP = B * w.P;
#pragma omp parallel for schedule(static) if (n > kFairParallelMin)
        for (int v = 0; v < n; ++v)
          if (movable_idx_[v] >= 0) w.P.row(v) -= tau * BP.row(v);
      } else {
        // (I + tau U0^2) x = p, times the valences: (D_m + tau S_mm) x = D_m p - tau S_mf X_f. S is
        // fixed (uniform weights), so the matrix changes only with tau, which stops growing at its
        // cap; refactoring it every step cost ~175 ms a step on an 8K-vertex scan. Its pattern
        // (S_mm's, with the diagonal) stays: one symbolic analysis per level.
        if (tau != tau_factored) {
          SpMat A = Bmm * tau;
          for (int v = 0; v < n; ++v)
            if (movable_idx_[v] >= 0) A.coeffRef(movable_idx_[v], movable_idx_[v]) += valence[v];
          A.makeCompressed();
          if (tau_factored < 0)
            solver.factor(A, spd_kind(nm_));
          else
            solver.refactor(A);
          tau_factored = tau;
        }
        Eigen::MatrixXd rhs(nm_, 3);
        for (int v = 0; v < n; ++v)
          if (movable_idx_[v] >= 0) rhs.row(movable_idx_[v]) = valence[v] * w.P.row(v);
        if (Bmf.cols() > 0) rhs -= tau * (Bmf * Eigen::MatrixXd(fixed_pos_));
        const Eigen::MatrixXd x = solver.solve(rhs);
        for (int v = 0; v < n; ++v)
          if (movable_idx_[v] >= 0) w.P.row(v) = x.row(movable_idx_[v]);
      }
      if (opt_.boundary == FairBoundary::Sliding) slide_boundary(w, curves_, 0.25);
      compute_geometry(w.P, w.F, w.topo, g_);
      const double e_new = energy_of(w, g_);
      if (!std::isfinite(e_new) || g_.farea.minCoeff() <= 1e-14 * h_ * h_) {
        // The flow collapses closed or unconstrained meshes; stop at the last regular state.
        w.P = P_prev;
        compute_geometry(w.P, w.F, w.topo, g_);
        break;
      }
      e = e_new;
      if (any_free_) {
        component_energy(w, ec);
        for (int v = 0; v < n; ++v) {
          const int c = w.topo.component[v];
          if (free_comp_[c] && ec[c] < e_best[c]) P_best.row(v) = w.P.row(v);
        }
        for (int c = 0; c < ec.size(); ++c)
          if (free_comp_[c]) e_best[c] = std::min(e_best[c], ec[c]);
      }
      energy_.push_back(e);
      ++it;
      const double dt = tau;
      if (semi) tau = std::min(tau * 4, 1e6);
      if (window_converged(dt, e, semi ? 0.0 : 1.0)) {
        rep.converged = true;
        break;
      }
    }
    // Only a component without fixed vertices collapses. With fixed vertices the flow converges to
    // its own steady state (U0^2 P = 0), whose Willmore energy may well exceed the start's: a tube's
    // band narrows into a neck, a removed protrusion's fill bulges back (closer to it than the fill).
    if (any_free_) {
      component_energy(w, ec);
      bool restored = false;
      for (int v = 0; v < n; ++v) {
        const int c = w.topo.component[v];
        if (free_comp_[c] && ec[c] > e_start[c] * (1 + 10 * opt_.tolerance) + 1e-12) {
          w.P.row(v) = P_best.row(v);
          restored = true;
        }
      }
      if (restored) {
        compute_geometry(w.P, w.F, w.topo, g_);
        energy_.push_back(energy_of(w, g_));
        rep.energy_rose = true;
        rep.converged = false;
      }
    }
    rep.iterations = it;
    return rep;
  }

  const FairOptions& opt_;
  Progress& progress_;
  Stopwatch& clock_;
  std::vector<double>& energy_;
  int level_ = 0, levels_ = 0, nm_ = 0;
  std::vector<double> accepted_;
  bool tried_linear_ = false;
  bool start_fallback_ = false;  // see FairResult::start_fallback
  double e_level_in_ = 0;        // the current level's input energy (slow_progress)
  bool slow_stop_ = true;        // slow_progress may stop the flow
  MatX3d declined_;              // a minimiser take_if_lower declined (higher energy, regular mesh), else empty
  double h_ = 1, t_acc_ = 0, e_mark_ = 0;
  std::vector<int> movable_idx_;
  std::vector<char> free_comp_;  // components whose every vertex moves (see remove_translation)
  bool any_free_ = false;        // some component has no fixed vertex
  bool keep_size_ = false;
  MatX3d comp_center_, cur_center_;  // per component (restore_place_and_size)
  VecXd comp_area_, cur_area_;
  Geo g_, g_try_;  // g_try_: a semi-implicit trial step's geometry (swapped in when accepted)
  VecXd speed_;
  TangentialDrift tan_;
  ImplicitSystem system_;  // semi-implicit matrix (pattern per level)
  VecXd ulen_;             // step lengths (semi-implicit scratch)
  std::vector<double> ulen_sorted_;
  BoundaryCurves curves_;
  MatX3d fixed_pos_;
};

}  // namespace

double willmore_energy(const MatX3d& V, const MatX3i& F) {
  Work w;
  w.P = V;
  w.F = F;
  w.topo = validate(V, F, kSurface);
  w.energy_set.assign(w.topo.n_vertices, 1);
  Geo g;
  compute_geometry(w.P, w.F, w.topo, g);
  return energy_of(w, g);
}

namespace {
FairResult fair_rows(const MatX3d& V, const MatX3i& F, const FairOptions& opt, const ProgressFn& progress_fn) {
  if (opt.subdivisions < 0 || opt.subdivisions > 6) throw MeshError("subdivisions must be between 0 and 6");
  if (!(opt.tolerance >= 0 && std::isfinite(opt.tolerance))) throw MeshError("tolerance must be finite and >= 0");
  if (!(opt.min_progress >= 0 && std::isfinite(opt.min_progress)))
    throw MeshError("min_progress must be finite and >= 0");
  if (!(opt.max_seconds >= 0 && std::isfinite(opt.max_seconds)))
    throw MeshError("max_seconds must be finite and >= 0 (0: no limit)");
  if (opt.max_iterations < 0) throw MeshError("max_iterations must be >= 0");
  if (!(opt.step_scale > 0)) throw MeshError("step_scale must be > 0");
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  const bool whole = opt.vertex_mask.empty() && opt.face_mask.empty();
  // The hinge energy needs fixed vertices (boundary data); a mesh faired whole gets the Willmore flow.
  FairOptions eff = opt;
  if (eff.method == FairMethod::Hinge && whole) eff.method = FairMethod::Willmore;
  std::vector<char> movable_full(n, 1), region_full(m, 1);
  if (!opt.vertex_mask.empty())
    for (int v = 0; v < n; ++v) movable_full[v] = opt.vertex_mask[v] != 0;
  if (!opt.face_mask.empty()) {
    for (int f = 0; f < m; ++f) region_full[f] = opt.face_mask[f] != 0;
  } else if (!opt.vertex_mask.empty()) {
    for (int f = 0; f < m; ++f)
      region_full[f] = movable_full[F(f, 0)] || movable_full[F(f, 1)] || movable_full[F(f, 2)];
  }
  if (!whole && std::none_of(movable_full.begin(), movable_full.end(), [](char c) { return c; }) &&
      ((opt.subdivisions == 0 && !opt.refine) ||
       std::none_of(region_full.begin(), region_full.end(), [](char c) { return c; })))
    throw MeshError("nothing to fair: the mask selects no vertex (and no face to subdivide)");

  Submesh sub = extract(V, F, movable_full, region_full, whole);
  Work& w = sub.work;
  w.topo = validated_topology(w, whole);
  const int ns0 = w.topo.n_vertices, ms0 = static_cast<int>(w.F.rows());

  // Normalise: centred, unit mean edge length.
  const Vec3 centre = w.P.colwise().mean();
  const double scale = mean_edge_length(w.P, w.topo);
  w.P = ((w.P.rowwise() - centre.transpose()) / scale).eval();

  Progress progress(progress_fn);
  progress(0.0);
  Stopwatch clock;
  FairResult res;
  VecXi origin = VecXi::LinSpaced(ms0, 0, ms0 - 1);  // working face -> level-0 working face
  Driver driver(eff, progress, clock, res.energy);
  bool first_energy = true;
  bool any_flow = false, any_moved = false, any_lowered = false;  // over the levels (FairStall)
  if (opt.refine && !whole) {
    // Liepa refinement of the region before the flow; its new vertices move.
    RegionSubdivision rs = refine_region(w.P, w.F, w.region);
    w.P = std::move(rs.V);
    w.F = std::move(rs.F);
    origin = rs.face_origin;
    w.region = std::move(rs.face_mask);
    w.topo = validated_topology(w, whole);
    w.movable.resize(w.topo.n_vertices, 1);
  }
  // A fill already as fine as the mesh around it (a small hole closed by one n-gon) gets no vertex
  // from the refinement: one 1-to-4 subdivision gives it some to move.
  int levels = opt.subdivisions;
  if (opt.refine && !whole && levels == 0 && std::none_of(w.movable.begin(), w.movable.end(), [](char c) { return c; }))
    levels = 1;
  for (int level = 0; level <= levels; ++level) {
    int first_new = 0;
    if (level > 0) {
      RegionSubdivision rs = subdivide_region(w.P, w.F, w.region);
      first_new = w.topo.n_vertices;
      w.P = std::move(rs.V);
      w.F = std::move(rs.F);
      VecXi o(rs.face_origin.size());
      for (int i = 0; i < o.size(); ++i) o[i] = origin[rs.face_origin[i]];
      origin = std::move(o);
      w.region = std::move(rs.face_mask);
      w.topo = validated_topology(w, whole);
      w.movable.resize(w.topo.n_vertices, 1);  // midpoints of interior region edges move
    }
    prepare_level(w, opt.boundary);
    if (std::none_of(w.movable.begin(), w.movable.end(), [](char c) { return c; })) {
      res.level_iterations.push_back(0);
      continue;
    }
    // energy[0]: the first level with vertices to move (a fill without inner vertices has none
    // before its subdivision, and an empty energy set would report 0 as the input's energy).
    if (first_energy) {
      Geo g;
      compute_geometry(w.P, w.F, w.topo, g);
      res.energy.push_back(eff.method == FairMethod::Hinge ? hinge_energy(w.P, hinges_near(w)) : energy_of(w, g));
      first_energy = false;
    }
    const LevelReport rep = driver.run(w, level, levels, first_new);
    res.level_iterations.push_back(rep.iterations);
    res.iterations += rep.iterations;
    res.converged = rep.converged;
    res.lambda = rep.lambda;
    res.linear_start = res.linear_start || rep.linear_start;
    res.energy_rose = res.energy_rose || rep.energy_rose;
    res.restarted = res.restarted || rep.restarted;
    any_flow = true;
    any_moved = any_moved || rep.max_move > 1e-6;
    const bool lowered = opt.method == FairMethod::Bilaplacian
                             ? rep.max_move > 1e-6
                             : rep.e_end < rep.e_start - 10 * opt.tolerance * std::abs(rep.e_start);
    any_lowered = any_lowered || lowered || rep.restarted;
    if (opt.max_seconds > 0 && clock.seconds() > opt.max_seconds && level < levels) {
      // Out of time: still refine (so the output has the requested resolution), without flow.
      continue;
    }
  }
  if (std::none_of(w.movable.begin(), w.movable.end(), [](char c) { return c; }) && !whole)
    throw MeshError(
        "nothing to fair: every selected vertex is on the border of the selection or the mesh boundary; "
        "select the region's interior or add subdivisions");
  if (any_flow && !any_lowered) res.stall = any_moved ? FairStall::NoChange : FairStall::NoDescent;
  res.start_fallback = driver.start_fallback();
  if (res.energy.empty()) {  // a whole mesh with nothing to move (every vertex on a fixed boundary)
    Geo g;
    compute_geometry(w.P, w.F, w.topo, g);
    res.energy.push_back(energy_of(w, g));
  }

  // Back to the caller's coordinates and indices.
  const int ns = w.topo.n_vertices, ms = static_cast<int>(w.F.rows());
  const int n_new = ns - ns0;
  res.V.resize(n + n_new, 3);
  res.V.topRows(n) = V;
  res.vertex_mask.assign(n + n_new, 0);
  auto full_index = [&](int i) { return i < ns0 ? sub.verts[i] : n + (i - ns0); };
  for (int i = 0; i < ns; ++i) {
    if (i < ns0 && !w.movable[i] && !w.sliding[i]) continue;  // fixed: exactly the input
    const int fi = full_index(i);
    res.V.row(fi) = w.P.row(i) * scale + centre.transpose();
    res.vertex_mask[fi] = w.movable[i] || w.sliding[i];
  }
  res.F = F;
  res.face_origin = VecXi::LinSpaced(m, 0, m - 1);
  const int extra = ms - ms0;
  res.F.conservativeResize(m + extra, 3);
  res.face_origin.conservativeResize(m + extra);
  for (int r = 0; r < ms; ++r) {
    const int row = r < ms0 ? sub.faces[r] : m + (r - ms0);
    for (int k = 0; k < 3; ++k) res.F(row, k) = full_index(w.F(r, k));
    res.face_origin[row] = sub.faces[origin[r]];
  }
  progress(1.0);
  return res;
}

// One region (or the whole mesh), independent of the order of the faces' rows.
FairResult fair_region(const MatX3d& V, const MatX3i& F, const FairOptions& opt, const ProgressFn& progress_fn) {
  check_input(V, F, opt.vertex_mask, &opt.face_mask);
  if (!opt.refine && opt.subdivisions == 0) return fair_rows(V, F, opt, progress_fn);
  // Refinement and subdivision make, flip and split faces in the order they meet them, so the
  // result depended on the order of the input's rows, which Blender does not keep from one run of
  // an Edit-mode fill to the next (same triangles, other rows: 578, 598 or 610 vertices after
  // refining one sphere-cap fill). They run on the faces sorted by their vertices (each rotated to
  // start at its smallest), and the rows are put back.
  const int m = static_cast<int>(F.rows());
  std::vector<std::array<int, 3>> key(m);
  for (int f = 0; f < m; ++f) {
    int k = 0;
    for (int j = 1; j < 3; ++j)
      if (F(f, j) < F(f, k)) k = j;
    key[f] = {F(f, k), F(f, (k + 1) % 3), F(f, (k + 2) % 3)};
  }
  std::vector<int> perm(m);
  std::iota(perm.begin(), perm.end(), 0);
  std::stable_sort(perm.begin(), perm.end(), [&](int a, int b) { return key[a] < key[b]; });
  MatX3i Fs(m, 3);
  FairOptions o = opt;
  for (int i = 0; i < m; ++i) {
    Fs.row(i) = F.row(perm[i]);
    if (!opt.face_mask.empty()) o.face_mask[i] = opt.face_mask[perm[i]];
  }
  FairResult r = fair_rows(V, Fs, o, progress_fn);
  MatX3i Fo = r.F;
  VecXi origin = r.face_origin;
  for (int i = 0; i < static_cast<int>(Fo.rows()); ++i) {
    const int row = i < m ? perm[i] : i;  // the first m rows are the input's faces, in place
    r.F.row(row) = Fo.row(i);
    r.face_origin[row] = perm[origin[i]];
  }
  return r;
}

// Vertex masks of the parts of a region that do not interact: the movable vertices and the
// region's faces, grouped by the connected components of their two-ring neighbourhoods (the flows
// read two rings around a vertex: H on its ring, the Laplacian of H on the next), in the order
// of their smallest vertex. One part or none: empty.
std::vector<std::vector<char>> independent_parts(const MatX3i& F, const std::vector<char>& vertex_mask,
                                                 const std::vector<char>& face_mask) {
  const int n = static_cast<int>(vertex_mask.size()), m = static_cast<int>(F.rows());
  std::vector<char> region(vertex_mask);
  for (int f = 0; f < m && !face_mask.empty(); ++f)
    if (face_mask[f])
      for (int k = 0; k < 3; ++k) region[F(f, k)] = 1;
  if (std::none_of(region.begin(), region.end(), [](char c) { return c; })) return {};
  std::vector<char> zone(region);
  for (int ring = 0; ring < 2; ++ring) {
    std::vector<char> grown(zone);
    for (int f = 0; f < m; ++f)
      if (zone[F(f, 0)] || zone[F(f, 1)] || zone[F(f, 2)])
        for (int k = 0; k < 3; ++k) grown[F(f, k)] = 1;
    zone = std::move(grown);
  }
  std::vector<std::array<int, 2>> pairs;
  for (int f = 0; f < m; ++f)
    if (zone[F(f, 0)] && zone[F(f, 1)] && zone[F(f, 2)])
      for (int k = 0; k < 3; ++k) pairs.push_back({F(f, k), F(f, (k + 1) % 3)});
  MatX2i P(static_cast<Eigen::Index>(pairs.size()), 2);
  for (size_t i = 0; i < pairs.size(); ++i) P.row(static_cast<Eigen::Index>(i)) << pairs[i][0], pairs[i][1];
  const VecXi label = connected_labels(n, P);
  std::vector<int> ids;
  for (int v = 0; v < n; ++v)
    if (region[v]) ids.push_back(label[v]);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  if (ids.size() < 2) return {};
  std::vector<std::vector<char>> parts;
  for (const int id : ids) {
    std::vector<char> part(n, 0);
    for (int v = 0; v < n; ++v) part[v] = region[v] && label[v] == id;
    parts.push_back(std::move(part));
  }
  return parts;
}

// Fairs independent parts one after the other on the same mesh, so each flow keeps its own step
// size and stopping test (a shared step control let one part's energy drop carry another part's
// rise). The input's vertices keep their indices and the rows of faces outside a part are
// untouched, so each part's masks carry over to the mesh the previous parts left.
FairResult fair_parts(const MatX3d& V, const MatX3i& F, const FairOptions& opt,
                      const std::vector<std::vector<char>>& parts, const ProgressFn& progress_fn) {
  const int n0 = static_cast<int>(V.rows()), m0 = static_cast<int>(F.rows());
  const int np = static_cast<int>(parts.size());
  MatX3d Vc = V;
  MatX3i Fc = F;
  VecXi origin = VecXi::LinSpaced(m0, 0, m0 - 1);
  std::vector<FairResult> results;
  for (int k = 0; k < np; ++k) {
    FairOptions o = opt;
    o.vertex_mask.assign(Vc.rows(), 0);
    for (int v = 0; v < n0; ++v) o.vertex_mask[v] = opt.vertex_mask[v] && parts[k][v];
    if (!opt.face_mask.empty()) {
      o.face_mask.assign(Fc.rows(), 0);
      for (int f = 0; f < m0; ++f)
        o.face_mask[f] = opt.face_mask[f] && (parts[k][F(f, 0)] || parts[k][F(f, 1)] || parts[k][F(f, 2)]);
    }
    ProgressFn sub;
    if (progress_fn) sub = [&progress_fn, k, np](double f) { return progress_fn((k + f) / np); };
    FairResult r = fair_region(Vc, Fc, o, sub);
    Vc = r.V;
    Fc = r.F;
    VecXi o2(r.face_origin.size());
    for (Eigen::Index i = 0; i < o2.size(); ++i) o2[i] = origin[r.face_origin[i]];
    origin = std::move(o2);
    results.push_back(std::move(r));
  }
  FairResult out;
  out.V = std::move(Vc);
  out.F = std::move(Fc);
  out.face_origin = std::move(origin);
  size_t length = 0, levels = 0;
  for (const FairResult& r : results) {
    length = std::max(length, r.energy.size());
    levels = std::max(levels, r.level_iterations.size());
  }
  out.energy.assign(length, 0.0);  // the parts' energies, each held at its last value once done
  for (const FairResult& r : results)
    for (size_t i = 0; i < length; ++i) out.energy[i] += r.energy[std::min(i, r.energy.size() - 1)];
  out.vertex_mask.assign(out.V.rows(), 0);
  out.level_iterations.assign(levels, 0);
  out.converged = true;
  out.lambda = results.front().lambda;
  for (const FairResult& r : results) {
    for (size_t v = 0; v < r.vertex_mask.size(); ++v) out.vertex_mask[v] |= r.vertex_mask[v];
    for (size_t i = 0; i < r.level_iterations.size(); ++i)
      out.level_iterations[i] = std::max(out.level_iterations[i], r.level_iterations[i]);
    out.iterations = std::max(out.iterations, r.iterations);
    out.converged = out.converged && r.converged;
    out.lambda = std::min(out.lambda, r.lambda);
    out.linear_start = out.linear_start || r.linear_start;
    out.energy_rose = out.energy_rose || r.energy_rose;
    out.restarted = out.restarted || r.restarted;
    out.start_fallback = out.start_fallback || r.start_fallback;
    if (r.stall == FairStall::NoDescent || (r.stall == FairStall::NoChange && out.stall == FairStall::None))
      out.stall = r.stall;
  }
  return out;
}

}  // namespace

FairOptions fair_defaults(FairScheme scheme) {
  FairOptions o;
  if (scheme == FairScheme::Explicit) {
    o.scheme = FairScheme::Explicit;
    o.max_iterations = 5000;
  }
  return o;
}

FairResult fair(const MatX3d& V, const MatX3i& F, const FairOptions& opt, const ProgressFn& progress_fn) {
  check_input(V, F, opt.vertex_mask, &opt.face_mask);
  FairOptions o = opt;
  if (o.vertex_mask.empty() && !o.face_mask.empty()) {
    // A face mask alone: the vertices of the region's faces move, except its border with the rest.
    const int n = static_cast<int>(V.rows());
    std::vector<char> inner(n, 0), border(n, 0);
    for (int f = 0; f < F.rows(); ++f)
      for (int k = 0; k < 3; ++k) (o.face_mask[f] ? inner : border)[F(f, k)] = 1;
    o.vertex_mask.assign(n, 0);
    for (int v = 0; v < n; ++v) o.vertex_mask[v] = inner[v] && !border[v];
  }
  if (o.vertex_mask.empty()) return fair_region(V, F, o, progress_fn);
  const std::vector<std::vector<char>> parts = independent_parts(F, o.vertex_mask, o.face_mask);
  if (parts.size() < 2) return fair_region(V, F, o, progress_fn);
  return fair_parts(V, F, o, parts, progress_fn);
}

}  // namespace dgmesh
