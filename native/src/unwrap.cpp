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
#include "dgmesh/detail/parallel_rows.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/multigrid.h"
#include "dgmesh/parallel.h"
#include "dgmesh/sparse_solver.h"
#include "dgmesh/uv_boundary.h"
#include "dgmesh/uv_metrics.h"
#include "dgmesh/uv_stretch_opt.h"
#include "dgmesh/validate.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace dgmesh {

namespace {

using detail::angle3;
using detail::arc_length;
using detail::BoundaryCurve;
using detail::Clock;
using detail::cross2;
using detail::diameter_pair;
using detail::face_data;
using detail::FaceData;
using detail::fit_unit_box;
using detail::kInf;
using detail::kParallelRows;
using detail::kPi;
using detail::lscm;
using detail::metrics_impl;
using detail::place_circle;
using detail::place_square;
using detail::profile_mark;
using detail::reflex_count;
using detail::seconds_since;
using detail::square_corners;
using detail::Vec2;
using detail::vertex_stretch_impl;

// ----- weights of eq. 5.2 ------------------------------------------------------------------------

struct RingScratch {
  std::vector<Vec3> e;
  std::vector<double> len, theta, lambda;
  std::vector<Vec2> q;
  void resize(size_t d) { e.resize(d), len.resize(d), theta.resize(d), lambda.resize(d), q.resize(d); }
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
      const double bk = cross2(s.q[l], s.q[l1]) / A, bl = cross2(s.q[l1], s.q[k]) / A, bl1 = cross2(s.q[k], s.q[l]) / A;
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
std::vector<double> base_weights(const MatX3d& V, const Topology& topo, const std::vector<char>& fixed, UvWeights kind,
                                 WeightStats& stats) {
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

// ----- linear solves of eq. 5.3 -------------------------------------------------------------------

// The two coordinates u and v share the matrix of eq. 5.3, so the multigrid solves them together
// (multigrid.h).
constexpr int kDirectRows = 1000;  // UvSolver::Auto solves charts up to this size by UMFPACK
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
// Charts above this many faces compute the free boundary's conformal map on one thread while the
// other builds the weights, the matrix and the multigrid hierarchy of eq. 5.3.
constexpr int kOverlapFaces = 4000;

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
      : kind_(kind != UvSolver::Auto ? kind
              : n > kDirectRows      ? UvSolver::Multigrid
                                     : UvSolver::Umfpack),
        tol_(tol) {}

  const char* name() const {
    switch (kind_) {
      case UvSolver::Umfpack:
        return "umfpack";
      case UvSolver::SparseLU:
        return "sparselu";
      case UvSolver::BiCGSTAB:
        return "bicgstab+ilut";
      case UvSolver::Multigrid:
        return "bicgstab+amg";
      default:
        return "?";
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
      Block2 Bb = B, Xb = X;
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
  AmgPreconditioner amg_;
};

// The system of eq. 5.3 over the free vertices, row-normalised (A_ii = 1, A_ij = -w_ij / sum_k w_ik),
// with the pattern built once and the values refilled in place for every step.
struct System {
  std::vector<int> row;                // free vertex -> row, -1 if fixed
  std::vector<int> free_v;             // row -> vertex
  std::vector<int> pos;                // per ring entry: index into A's values, -1 if the neighbour is fixed
  std::vector<int> diag_pos;           // per row
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
    res.warnings.push_back(std::to_string(ws.fallback) +
                           " vertices with rings Floater's construction cannot flatten used mean-value weights");
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
  // Every step carries every metric of thesis 5.3 (no NaN placeholders in a result).
  auto metrics_of = [&](const MatX2d& Ucur) {
    profile_mark("other");
    fd = face_data(Vf, Ff, Ucur, nff);
    fd_valid = true;
    auto m = metrics_impl(mesh.V, mesh.F, Ucur, nf, edges, opt.zero_area_eps, &angles3);
    profile_mark("metrics");
    return m;
  };
  // An iterative solve stops at a relative residual; the exact solution of eq. 5.3 has no flips
  // when the polygon is convex and the weights positive [Flo97], so flips in an inexact map are
  // solver error: re-solve from it with a 100 times tighter tolerance, twice at most (not below 1e-10).
  auto solve_checked = [&](MatX2d& Ucur, UnwrapStep& st) {
    st.solver_iterations = solve_step(Ucur);
    st.metrics = metrics_of(Ucur);
    const double tol = solver.tolerance();
    double t = tol;
    for (int k = 0; k < 2 && st.metrics.flipped && solver.iterative() && !fold_stops; ++k) {
      t = std::max(t * 1e-2, 1e-10);
      solver.set_tolerance(t);
      st.solver_iterations += solve_step(Ucur);
      st.metrics = metrics_of(Ucur);
    }
    solver.set_tolerance(tol);
  };
  const bool optimal = opt.iterations < 0;
  const int max_steps = optimal ? opt.max_iterations : opt.iterations;
  auto frac = [&](int h) {
    return optimal ? std::min(0.95, 0.1 + 0.85 * h / (h + 3.0)) : 0.1 + 0.9 * h / (max_steps + 1.0);
  };

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
    solve_checked(U, st);
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
    solve_checked(U, st);
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
      return fail_cur < fail_prev ||
             (fail_cur == fail_prev && cur.stretch_l2_finite < prev.stretch_l2_finite * (1 - 1e-12));
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
  res.uv = best.topRows(n);
  progress(1.0);
  return res;
}

}  // namespace

namespace {

UnwrapResult unwrap_equalized(const MatX3d& V, const MatX3i& F, const UnwrapOptions& opt, const ProgressFn& progress);

// The final stage (UnwrapOptions::stretch_iterations): minimise eq. 5.5 from the chosen map and
// keep the result only if it is better (lower L2, no flipped or zero-area triangle).
void minimize_final_stretch(const MatX3d& V, const MatX3i& F, const UnwrapOptions& opt, UnwrapResult& r,
                            const ProgressFn& progress) {
  const UvMetrics& m0 = r.steps[r.chosen].metrics;
  if (m0.flipped || m0.zero_area) {
    r.warnings.push_back("the stretch minimisation did not run: the map has " + std::to_string(m0.flipped) +
                         " flipped and " + std::to_string(m0.zero_area) + " zero-area triangles");
    return;
  }
  const auto t0 = Clock::now();
  detail::StretchOptOptions so;
  so.iterations = opt.stretch_iterations;
  so.tolerance = opt.stretch_tolerance;
  detail::StretchOptResult sr = detail::minimize_stretch(V, F, r.uv, so, progress);
  std::vector<int> rows(sr.uv.rows());
  std::iota(rows.begin(), rows.end(), 0);
  fit_unit_box(sr.uv, rows);
  UnwrapStep st;
  st.metrics = uv_metrics(V, F, sr.uv, opt.zero_area_eps);
  st.solver_iterations = sr.iterations;
  st.seconds = seconds_since(t0);
  if (st.metrics.flipped || st.metrics.zero_area || !(st.metrics.stretch_l2 < m0.stretch_l2)) {
    if (sr.iterations > 0)
      r.warnings.push_back("the stretch minimisation's map was not kept (L2 stretch " +
                           std::to_string(st.metrics.stretch_l2) + ", " + std::to_string(st.metrics.flipped) +
                           " flipped, " + std::to_string(st.metrics.zero_area) + " zero-area triangles)");
    return;
  }
  r.steps.push_back(st);
  r.chosen = r.stretch_step = static_cast<int>(r.steps.size()) - 1;
  r.uv = sr.uv;
}

}  // namespace

UnwrapResult unwrap(const MatX3d& V, const MatX3i& F, const UnwrapOptions& opt, const ProgressFn& progress) {
  if (!(opt.eta > 0 && opt.eta <= 1)) throw MeshError("unwrap: eta must be in (0, 1], got " + std::to_string(opt.eta));
  if (opt.iterations < -1) throw MeshError("unwrap: iterations must be -1 (optimal) or >= 0");
  if (opt.max_iterations < 0) throw MeshError("unwrap: max_iterations must be >= 0");
  if (opt.stretch_iterations < 0)
    throw MeshError("unwrap: stretch_iterations must be >= 0, got " + std::to_string(opt.stretch_iterations));
  if (!(opt.stretch_tolerance >= 0))
    throw MeshError("unwrap: stretch_tolerance must be >= 0, got " + std::to_string(opt.stretch_tolerance));
  if (opt.stretch_iterations == 0) return unwrap_equalized(V, F, opt, progress);
  // Progress: the equalization to 0.4, the minimisation (whose Newton steps cost more) after.
  auto part = [&](double lo, double hi) -> ProgressFn {
    if (!progress) return {};
    return [&progress, lo, hi](double f) { return progress(lo + (hi - lo) * f); };
  };
  UnwrapResult r = unwrap_equalized(V, F, opt, part(0.0, 0.4));
  minimize_final_stretch(V, F, opt, r, part(0.4, 1.0));
  return r;
}

namespace {

UnwrapResult unwrap_equalized(const MatX3d& V, const MatX3i& F, const UnwrapOptions& opt, const ProgressFn& progress) {
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
  fl.warnings.insert(fl.warnings.begin(),
                     "the cotangent weights' map folded (" + std::to_string(last.flipped) + " flipped, " +
                         std::to_string(last.zero_area) + " zero-area triangles) or its solve did not converge; used " +
                         (holes ? "mean-value weights (the chart has holes)" : "Floater's weights"));
  return fl;
}

}  // namespace

}  // namespace dgmesh
