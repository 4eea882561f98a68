// Similarity-based (NL-means) and bilateral denoising, thesis chapter 2.
//
// Layout of one iteration (both methods):
//   1. normals (Nelson Max's weights) and area elements of the current positions; e = mean edge
//      length (point clouds: from the local density);
//   2. a kd-tree over the surface points and, per point, its neighbours sorted by distance, so that
//      the 2*sigma3 ball (RBF patch / compared neighbourhood) and the 2*sigma2 ball (averaging
//      domain) are both prefixes of one list;
//   3. every movable point moves along its normal by k(x) (eq. 2.3), computed from the old positions.
// Everything works in units of e, so the dimensionless sigmas are the etas.
#include "dgmesh/denoise.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <string>

#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"
#include "dgmesh/spatial_index.h"

namespace dgmesh {

namespace {

constexpr int kMaxPatch = 64;  // hard limit of DenoiseOptions::max_patch (stack-sized RBF systems)
constexpr int kMaxSys = kMaxPatch + 3;
constexpr int kMinPatch = 6;  // fewest points of an RBF patch when the neighbourhood has them
constexpr int kDensityK = 6;  // neighbours for the point-cloud spacing and area element
// The automatic rule (auto_options); the factors k are measured on the training set of
// bench/notes/denoise.md.
constexpr double kAutoKernelSimilarity = 1.0;
constexpr double kAutoKernelBilateral = 1.414;
constexpr int kAutoIterationsSimilarity = 3;
constexpr int kAutoIterationsBilateral = 3;
constexpr double kMinEffective = 12;  // quadratic_fit: effective samples needed (2 per coefficient)
// Taubin smoothing (DenoiseOptions::smoothing_steps) and its automatic rule: with d = max(detail,
// kAutoSmoothMinDetail), the shape's own reading f = min(kAutoSmoothFloor d, kAutoSmoothFloorCap) and
// the noise above it n = sqrt(max(0, sigma^2 - f^2)),
//   steps = kAutoSmoothScale n^kAutoSmoothPower / d^kAutoSmoothDetailPower.
// The floor: noise-free CGAL scans read sigma of 0.4-0.85 d and at most 0.104 e (femur, knot2 and
// two rough scans excepted), their shape at the sampling scale; added noise raises sigma far more
// than detail. The constants were fitted (grid search minimising the mean log ratio of the error to
// the best step count's) on the best counts of 14 CGAL models at 0.05-0.3 e with noise-free scans
// held to 0 steps (bench/notes/denoise.md, session 23: floor, uniform umbrella); scale and powers
// refitted in session 25 for the half-cotangent operator of taubin_smooth (session 24), the floor
// kept. The feature test of the automatic choice.
constexpr double kTaubinLambda = 0.6;
constexpr double kTaubinMu = -0.62;
constexpr double kTaubinCotangentShare = 0.5;  // measured: bench/notes/denoise.md, session 24
constexpr double kAutoSmoothScale = 9.5;
constexpr double kAutoSmoothPower = 1.8;
constexpr double kAutoSmoothDetailPower = 1.5;
constexpr double kAutoSmoothMinDetail = 0.03;
constexpr double kAutoSmoothFloor = 0.9;
constexpr double kAutoSmoothFloorCap = 0.1;
constexpr double kAutoSmoothMinCurvature = 0.05;  // the feature test's floor
constexpr int kAutoSmoothMaxSteps = 60;
constexpr double kAutoFeatureRatio = 1.0;
using detail::kPi;

inline Vec3 prow(const MatX3d& P, int i) { return Vec3(P(i, 0), P(i, 1), P(i, 2)); }

double bbox_diagonal(const MatX3d& V) {
  if (V.rows() == 0) return 0;
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

void check_finite(const MatX3d& A, const char* what) {
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(A(i, k)))
        throw MeshError(std::string(what) + " has a non-finite coordinate (NaN or inf) at row " + std::to_string(i));
}

// The etas are in units of the average edge length: below kMinEta a kernel is narrower than any
// sampling of the mesh, and 1 / (2 eta^2) leaves float's range (the weights became NaN).
constexpr double kMinEta = 1e-3;

void check_options(const DenoiseOptions& opt, Eigen::Index n) {
  auto positive = [](double v, const char* name) {
    if (!(std::isfinite(v) && v >= kMinEta))
      throw MeshError(std::string(name) + " must be a number of at least 0.001 (edge lengths), got " +
                      std::to_string(v));
  };
  positive(opt.eta1, "eta1");
  positive(opt.eta2, "eta2");
  positive(opt.eta3, "eta3");
  if (opt.eta2 > 20 || opt.eta3 > 20)
    throw MeshError("eta2 and eta3 must be at most 20 (neighbourhoods of 40 edge lengths)");
  if (opt.iterations < 0 || opt.iterations > 1000) throw MeshError("iterations must be in [0, 1000]");
  if (opt.smoothing_steps < 0 || opt.smoothing_steps > 1000) throw MeshError("smoothing_steps must be in [0, 1000]");
  if (opt.max_patch != 0 && (opt.max_patch < 3 || opt.max_patch > kMaxPatch))
    throw MeshError("max_patch must be 0 (automatic) or in [3, " + std::to_string(kMaxPatch) + "]");
  if (opt.max_window != 0 && (opt.max_window < 1 || opt.max_window > 4096))
    throw MeshError("max_window must be 0 (automatic) or in [1, 4096]");
  if (!(opt.weld_tolerance >= 0 && opt.weld_tolerance < 1e-2)) throw MeshError("weld_tolerance must be in [0, 0.01)");
  if (!opt.movable.empty() && static_cast<Eigen::Index>(opt.movable.size()) != n)
    throw MeshError("the mask has " + std::to_string(opt.movable.size()) + " entries but there are " +
                    std::to_string(n) + " vertices");
}

// ---- welding ------------------------------------------------------------------------------------

struct Welded {
  std::vector<int> rep;  // input vertex -> welded point
  MatX3d P;              // welded positions (the first copy's)
  int merged = 0;
};

// Points within tol of each other become one (transitively, through the lowest index).
Welded weld(const MatX3d& V, double tol) {
  const int n = static_cast<int>(V.rows());
  Welded w;
  w.rep.resize(n);
  std::vector<int> first(n);
  std::iota(first.begin(), first.end(), 0);
  if (tol > 0 && n > 1) {
    const KdTree tree(V);
#pragma omp parallel
    {
      std::vector<std::pair<int, double>> hits;
#pragma omp for schedule(static)
      for (int i = 0; i < n; ++i) {
        tree.radius(prow(V, i), tol, hits);
        int lo = i;
        for (const auto& h : hits) lo = std::min(lo, h.first);
        first[i] = lo;
      }
    }
  }
  // first[i] <= i, so resolving in increasing order follows chains to their root.
  std::vector<int> root(n);
  int count = 0;
  std::vector<int> index_of_root(n, -1);
  for (int i = 0; i < n; ++i) {
    root[i] = first[i] == i ? i : root[first[i]];
    if (index_of_root[root[i]] < 0) index_of_root[root[i]] = count++;
    w.rep[i] = index_of_root[root[i]];
  }
  MatX3d P(count, 3);
  for (int i = 0; i < n; ++i)
    if (root[i] == i) P.row(w.rep[i]) = V.row(i);
  w.merged = n - count;
  // Number the welded points along a Morton (Z-order) curve: neighbours in space become neighbours
  // in memory, which keeps the many small gathers of the filter in cache.
  std::vector<uint64_t> code(count);
  if (count > 0) {
    const Eigen::RowVector3d lo = P.colwise().minCoeff(), hi = P.colwise().maxCoeff();
    const double ext = std::max((hi - lo).maxCoeff(), 1e-300);
    auto spread = [](uint64_t x) {  // 21 bits -> every third of 63
      x &= 0x1fffff;
      x = (x | x << 32) & 0x1f00000000ffffULL;
      x = (x | x << 16) & 0x1f0000ff0000ffULL;
      x = (x | x << 8) & 0x100f00f00f00f00fULL;
      x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
      x = (x | x << 2) & 0x1249249249249249ULL;
      return x;
    };
    for (int i = 0; i < count; ++i) {
      uint64_t c = 0;
      for (int k = 0; k < 3; ++k) c |= spread(static_cast<uint64_t>((P(i, k) - lo(k)) / ext * 2097151.0)) << k;
      code[i] = c;
    }
  }
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return code[a] < code[b] || (code[a] == code[b] && a < b); });
  std::vector<int> position(count);
  w.P.resize(count, 3);
  for (int k = 0; k < count; ++k) {
    position[order[k]] = k;
    w.P.row(k) = P.row(order[k]);
  }
  for (int i = 0; i < n; ++i) w.rep[i] = position[w.rep[i]];
  return w;
}

// ---- per-iteration geometry ------------------------------------------------------------------------

// Max-weighted normals (unnormalised sums), area elements (a third of each incident face) and the
// mean edge length over non-degenerate faces. No topology needed: works on soups and non-manifold
// meshes alike.
double surface_geometry(const MatX3d& P, const MatX3i& F, MatX3d& N, VecXd& A) {
  const int n = static_cast<int>(P.rows());
  N.setZero(n, 3);
  A.setZero(n);
  double edge_sum = 0;
  long long edge_count = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int v[3] = {F(f, 0), F(f, 1), F(f, 2)};
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
    const Vec3 p[3] = {prow(P, v[0]), prow(P, v[1]), prow(P, v[2])};
    const Vec3 cr = (p[1] - p[0]).cross(p[2] - p[0]);
    const double area = 0.5 * cr.norm();
    if (!(area > 0)) continue;
    for (int k = 0; k < 3; ++k) {
      const Vec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
      const double l1 = e1.squaredNorm(), l2 = e2.squaredNorm();
      N.row(v[k]) += (e1.cross(e2) / (l1 * l2)).transpose();  // Max 1999
      A(v[k]) += area / 3;
      edge_sum += std::sqrt(l1);
      ++edge_count;
    }
  }
  return edge_count ? edge_sum / static_cast<double>(edge_count) : 0.0;
}

// Sorted neighbour lists: for point x, lists[off[x] .. off[x] + len[x]) nearest first, where the
// first n3[x] lie in the 2*sigma3 ball (capped) and the first n2[x] in the 2*sigma2 ball (capped).
struct Neighbourhoods {
  std::vector<long long> off;
  std::vector<int> len, n2, n3;
  std::vector<int> list;
};

// `act` maps kd-tree indices to point indices; points not in the tree get empty lists.
void build_neighbourhoods(const KdTree& tree, const std::vector<int>& act, int n_points, double r2ball, double r3ball,
                          int cap2, int cap3, Neighbourhoods& nb) {
  const int na = static_cast<int>(act.size());
  const double R = std::max(r2ball, r3ball);
  nb.len.assign(n_points, 0);
  nb.n2.assign(n_points, 0);
  nb.n3.assign(n_points, 0);
  nb.off.assign(n_points + 1, 0);
  const int nt = num_threads();
  std::vector<std::vector<int>> parts(nt);
  const MatX3d& Q = tree.points();
#pragma omp parallel num_threads(nt)
  {
    std::vector<std::pair<int, double>> hits;
    std::vector<int>& out = parts[thread_index()];
    out.clear();
    // static schedule: each thread takes one contiguous range, in thread order.
#pragma omp for schedule(static)
    for (int a = 0; a < na; ++a) {
      tree.radius(prow(Q, a), R, hits);
      int c2 = 0, c3 = 0;
      const double R2 = r2ball * r2ball, R3 = r3ball * r3ball;
      for (const auto& h : hits) {
        if (h.second <= R2) ++c2;
        if (h.second <= R3) ++c3;
      }
      c2 = std::min(c2, cap2);
      // Sparse spots of irregular meshes: a patch needs a few points for the RBF fit (eq. 2.8), so
      // the 2*sigma3 ball is widened to the nearest kMinPatch points within the query radius.
      c3 = std::min(std::max(c3, std::min<int>(kMinPatch, static_cast<int>(hits.size()))), cap3);
      const int keep = std::max(c2, c3);
      // Only the nearest `keep` are used: with large radii a ball holds thousands of points beyond
      // the caps, and sorting them all dominated the run (ties by index, so the order is total).
      const auto closer = [](const auto& p, const auto& q) {
        return p.second < q.second || (p.second == q.second && p.first < q.first);
      };
      if (keep < static_cast<int>(hits.size())) std::nth_element(hits.begin(), hits.begin() + keep, hits.end(), closer);
      std::sort(hits.begin(), hits.begin() + keep, closer);
      for (int k = 0; k < keep; ++k) out.push_back(act[hits[k].first]);
      const int x = act[a];
      nb.len[x] = keep;
      nb.n2[x] = c2;
      nb.n3[x] = c3;
    }
  }
  // Offsets follow point order; parts are in tree order, which is increasing point order.
  for (int x = 0; x < n_points; ++x) nb.off[x + 1] = nb.off[x] + nb.len[x];
  nb.list.clear();
  nb.list.reserve(static_cast<size_t>(nb.off[n_points]));
  for (const auto& p : parts) nb.list.insert(nb.list.end(), p.begin(), p.end());
}

// ---- RBF patch (eq. 2.8) ---------------------------------------------------------------------------

// Thin-plate spline in x's tangent frame, with phi(r^2) = r^2 log r^2 (= 2 Phi(r), the factor is
// absorbed by lambda): F(u, v) = c0 + c1 u + c2 v + sum_w lambda_w phi(|(u,v) - (u_w,v_w)|^2).
struct Patch {
  int m = 0;
  double c[3] = {0, 0, 0};
  double pu[kMaxPatch], pv[kMaxPatch], lambda[kMaxPatch];
};

// log for positive normal floats, |error| < 3e-6: exponent from the bits, mantissa m in [1, 2) by
// the series of log m = 2 atanh((m - 1) / (m + 1)). Branch-free, so the loop below vectorises.
inline float fast_log(float x) {
  uint32_t b;
  std::memcpy(&b, &x, 4);
  const float ex = static_cast<float>(static_cast<int>((b >> 23) & 0xff) - 127);
  b = (b & 0x007fffffu) | 0x3f800000u;
  float m;
  std::memcpy(&m, &b, 4);
  const float t = (m - 1.0f) / (m + 1.0f), t2 = t * t;
  return ex * 0.693147181f + 2.0f * t * (1.0f + t2 * (1.0f / 3 + t2 * (1.0f / 5 + t2 * (1.0f / 7 + t2 * (1.0f / 9)))));
}

// The kernel of the fit uses the same logarithm as the evaluation, so the patch interpolates its
// data exactly under the kernel it is evaluated with.
inline double phi(double r2) { return r2 > 0 ? r2 * static_cast<double>(fast_log(static_cast<float>(r2))) : 0.0; }

// Dense (m+3)^2 system of eq. 2.8, solved in place by Gaussian elimination with partial pivoting:
// small, allocation-free and cheaper than a general LU with a condition estimate.
struct Solver {
  double M[kMaxSys][kMaxSys + 1];  // augmented with the right-hand side
};

// Returns false when a pivot falls below 1e-11 of the largest entry (numerically singular).
bool solve_in_place(Solver& s, int N, double* x) {
  double scale = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) scale = std::max(scale, std::abs(s.M[i][j]));
  const double tiny = 1e-11 * scale;
  for (int c = 0; c < N; ++c) {
    int piv = c;
    for (int r = c + 1; r < N; ++r)
      if (std::abs(s.M[r][c]) > std::abs(s.M[piv][c])) piv = r;
    if (!(std::abs(s.M[piv][c]) > tiny)) return false;
    if (piv != c)
      for (int j = c; j <= N; ++j) std::swap(s.M[c][j], s.M[piv][j]);
    const double inv = 1.0 / s.M[c][c];
    for (int r = c + 1; r < N; ++r) {
      const double f = s.M[r][c] * inv;
      if (f == 0) continue;
      for (int j = c + 1; j <= N; ++j) s.M[r][j] -= f * s.M[c][j];
    }
  }
  for (int r = N - 1; r >= 0; --r) {
    double v = s.M[r][N];
    for (int j = r + 1; j < N; ++j) v -= s.M[r][j] * x[j];
    x[r] = v / s.M[r][r];
  }
  return true;
}

// Interpolates heights h at (pu, pv); an ill-conditioned or degenerate system (few, coincident or
// collinear points) falls back to a least-squares plane, which is always finite. Returns false on
// fallback.
bool fit_patch(Patch& p, const double* h, Solver& s) {
  const int m = p.m;
  if (m >= 3) {
    const int N = m + 3;
    for (int a = 0; a < m; ++a) {
      s.M[a][a] = 0;
      for (int b = a + 1; b < m; ++b) {
        const double du = p.pu[a] - p.pu[b], dv = p.pv[a] - p.pv[b];
        s.M[a][b] = s.M[b][a] = phi(du * du + dv * dv);
      }
      s.M[a][m] = s.M[m][a] = 1;
      s.M[a][m + 1] = s.M[m + 1][a] = p.pu[a];
      s.M[a][m + 2] = s.M[m + 2][a] = p.pv[a];
      s.M[a][N] = h[a];
    }
    for (int i = m; i < N; ++i) {
      for (int j = m; j < N; ++j) s.M[i][j] = 0;
      s.M[i][N] = 0;
    }
    double x[kMaxSys];
    if (solve_in_place(s, N, x)) {
      bool ok = true;
      // Coefficients this large mean a near-singular system the pivots did not reveal.
      for (int i = 0; i < N && ok; ++i) ok = std::isfinite(x[i]) && (i >= m || std::abs(x[i]) < 1e5);
      if (ok) {
        for (int a = 0; a < m; ++a) p.lambda[a] = x[a];
        for (int k = 0; k < 3; ++k) p.c[k] = x[m + k];
        return true;
      }
    }
  }
  // Lower-order fit: least-squares plane with a small ridge on the slopes (finite for any input).
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (int a = 0; a < m; ++a) {
    const Eigen::Vector3d row(1.0, p.pu[a], p.pv[a]);
    AtA += row * row.transpose();
    Atb += row * h[a];
  }
  AtA(0, 0) += 1e-9;
  AtA(1, 1) += 1e-6;
  AtA(2, 2) += 1e-6;
  const Eigen::Vector3d c = AtA.ldlt().solve(Atb);
  for (int k = 0; k < 3; ++k) p.c[k] = std::isfinite(c(k)) ? c(k) : 0.0;
  for (int a = 0; a < m; ++a) p.lambda[a] = 0;
  return false;
}

// Per-thread scratch, sized once for the largest possible sample set. Samples are single
// precision: they only feed the similarity weights, where 1e-6 relative error is far below noise.
struct Scratch {
  Solver solver;
  Patch patch;
  double h[kMaxPatch];
  Eigen::ArrayXf su, sv, tg, g, F;
  std::vector<int> seg;
  explicit Scratch(int max_samples) {
    for (auto* a : {&su, &sv, &tg, &g, &F}) a->resize(max_samples);
    seg.reserve(4097);
  }
};

// The hot loop of the filter: F[k] += sum_a lambda_a phi(|s_k - p_a|^2) over all samples. Built
// for AVX2 as well as the baseline, picked at load time (the add-on must run on any x86-64).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void rbf_accumulate(const float* su, const float* sv, float* F, int S, const float* pu, const float* pv,
                    const float* lambda, int m) {
  for (int a = 0; a < m; ++a) {
    const float qu = pu[a], qv = pv[a], la = lambda[a];
    if (la == 0.0f) continue;
    for (int k = 0; k < S; ++k) {
      const float du = su[k] - qu, dv = sv[k] - qv;
      // The offset keeps log finite at r2 = 0, where the product is then ~0.
      const float r2 = du * du + dv * dv + 1e-30f;
      F[k] += la * r2 * fast_log(r2);
    }
  }
}

// Evaluates the patch at samples [0, S) into s.F.
void eval_patch(Scratch& s, int S) {
  const Patch& p = s.patch;
  float pu[kMaxPatch], pv[kMaxPatch], la[kMaxPatch];
  for (int a = 0; a < p.m; ++a) {
    pu[a] = static_cast<float>(p.pu[a]);
    pv[a] = static_cast<float>(p.pv[a]);
    la[a] = static_cast<float>(p.lambda[a]);
  }
  s.F.head(S) = static_cast<float>(p.c[0]) + static_cast<float>(p.c[1]) * s.su.head(S) +
                static_cast<float>(p.c[2]) * s.sv.head(S);
  rbf_accumulate(s.su.data(), s.sv.data(), s.F.data(), S, pu, pv, la, p.m);
}

struct Frame {
  Vec3 n, t1, t2;
  explicit Frame(const Vec3& normal) : n(normal) {
    t1 = n.unitOrthogonal();
    t2 = n.cross(t1);
  }
  // Frame at another point whose first tangent follows `ref`'s (projected onto this tangent plane).
  Frame(const Vec3& normal, const Frame& ref) : n(normal) {
    Vec3 t = ref.t1 - ref.t1.dot(n) * n;
    if (t.squaredNorm() < 1e-6) t = ref.t2 - ref.t2.dot(n) * n;
    t1 = t.squaredNorm() > 1e-12 ? Vec3(t.normalized()) : n.unitOrthogonal();
    t2 = n.cross(t1);
  }
};

// Builds x's RBF patch from the first m points of its list. Returns false on fallback.
bool build_patch(const MatX3d& P, const int* L, int m, int x, const Frame& fr, double inv_e, Scratch& s) {
  const Vec3 px = prow(P, x);
  s.patch.m = m;
  for (int k = 0; k < m; ++k) {
    const Vec3 d = (prow(P, L[k]) - px) * inv_e;
    s.patch.pu[k] = fr.t1.dot(d);
    s.patch.pv[k] = fr.t2.dot(d);
    s.h[k] = fr.n.dot(d);
  }
  return fit_patch(s.patch, s.h, s.solver);
}

// Appends y's compared neighbourhood (eq. 2.9) as samples in x's frame: tangent offsets of z from
// y, the target height <n_x, z - base> and the area element of z. Returns the new sample count.
int add_samples(const MatX3d& P, const VecXd& A, double inv_mean_area, const Neighbourhoods& nb, int y,
                const Vec3& base, const Frame& fr, double inv_e, Scratch& s, int S) {
  const int* Ly = nb.list.data() + nb.off[y];
  const Vec3 py = prow(P, y);
  const double hy = fr.n.dot(py - base) * inv_e;
  for (int k = 0; k < nb.n3[y]; ++k) {
    const int z = Ly[k];
    const Vec3 d = (prow(P, z) - py) * inv_e;
    s.su[S] = static_cast<float>(fr.t1.dot(d));
    s.sv[S] = static_cast<float>(fr.t2.dot(d));
    s.tg[S] = static_cast<float>(hy + fr.n.dot(d));
    s.g[S] = static_cast<float>(A(z) * inv_mean_area);
    ++S;
  }
  return S;
}

// D of eq. 2.9 for each segment, turned into weights (2.7). The integral over the translations t
// is discretised over the vertices z with their area elements, measured in units of the mean area
// element (dt = A_z / mean A): on a regular mesh this is the image filter's sum over the pixels of
// the window, with an unnormalised Gaussian G(t) = exp(-t^2 / (2 sigma3^2)). The samples carry
// A_z / mean A already.
void segment_weights(Scratch& s, int S, double eta1, double eta3, std::vector<double>& wout) {
  auto su = s.su.head(S), sv = s.sv.head(S), g = s.g.head(S);
  g *= (-(su.square() + sv.square()) * static_cast<float>(0.5 / (eta3 * eta3))).exp();
  g *= (s.F.head(S) - s.tg.head(S)).square();
  const int ny = static_cast<int>(s.seg.size()) - 1;
  wout.resize(ny);
  const double inv = 0.5 / (eta1 * eta1);
  for (int j = 0; j < ny; ++j) {
    double D = 0;
    for (int k = s.seg[j]; k < s.seg[j + 1]; ++k) D += s.g[k];
    wout[j] = std::exp(-D * inv);
  }
}

// ---- the filters ---------------------------------------------------------------------------------

struct State {
  MatX3d P;  // current welded positions
  MatX3d N;  // unit normals (zero: the point does not move)
  VecXd A;   // area elements (zero: not part of the surface)
  double e = 0;
  double mean_area = 1;  // mean area element over the surface points
  std::vector<int> act;  // points in the kd-tree (A > 0)
  Neighbourhoods nb;
};

// k(x) of eq. 2.4-2.9 for one point, in units of e.
double similarity_step(const State& st, int x, const DenoiseOptions& o, Scratch& s, std::vector<double>& w,
                       long long& fallbacks) {
  const Frame fr(prow(st.N, x));
  const double inv_e = 1.0 / st.e;
  const int* L = st.nb.list.data() + st.nb.off[x];
  if (!build_patch(st.P, L, st.nb.n3[x], x, fr, inv_e, s)) ++fallbacks;
  const Vec3 px = prow(st.P, x);
  int S = 0;
  s.seg.clear();
  for (int j = 0; j < st.nb.n2[x]; ++j) {
    s.seg.push_back(S);
    S = add_samples(st.P, st.A, 1.0 / st.mean_area, st.nb, L[j], px, fr, inv_e, s, S);
  }
  s.seg.push_back(S);
  eval_patch(s, S);
  segment_weights(s, S, o.eta1, o.eta3, w);
  double K = 0, C = 0, C2 = 0;
  for (int j = 0; j < st.nb.n2[x]; ++j) {
    const int y = L[j];
    const double wy = w[j] * st.A(y);
    K += wy * fr.n.dot(prow(st.P, y) - px) * inv_e;  // I(y), eq. 2.6
    C += wy;
    C2 += wy * wy;
  }
  if (!(C > 0)) return 0.0;
  const double mean = K / C;
  if (!o.quadratic_fit || C * C < kMinEffective * C2) return mean;
  // Weighted least-squares quadratic over x's tangent plane; k(x) is its value at x.
  Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (int j = 0; j < st.nb.n2[x]; ++j) {
    const int y = L[j];
    const double wy = w[j] * st.A(y) / C;
    if (wy == 0) continue;
    const Vec3 d = (prow(st.P, y) - px) * inv_e;
    const double u = fr.t1.dot(d), v = fr.t2.dot(d);
    Eigen::Matrix<double, 6, 1> q;
    q << 1.0, u, v, u * u, u * v, v * v;
    M.noalias() += wy * q * q.transpose();
    b.noalias() += (wy * fr.n.dot(d)) * q;
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(M);
  if (lu.rank() < 6) return mean;
  const double c0 = lu.solve(b)(0);
  return std::isfinite(c0) ? c0 : mean;
}

// Fleishman et al. 2003: heights over the tangent plane averaged with a spatial Gaussian (sigma3)
// times a height Gaussian (sigma1) over the 2*sigma2 ball; units of e.
double bilateral_step(const State& st, int x, const DenoiseOptions& o) {
  const Vec3 n = prow(st.N, x), px = prow(st.P, x);
  const double inv_e = 1.0 / st.e;
  const double ic = 0.5 / (o.eta3 * o.eta3), is = 0.5 / (o.eta1 * o.eta1);
  const int* L = st.nb.list.data() + st.nb.off[x];
  double sum = 0, norm = 0;
  for (int j = 0; j < st.nb.n2[x]; ++j) {
    if (L[j] == x) continue;
    const Vec3 d = (prow(st.P, L[j]) - px) * inv_e;
    const double h = n.dot(d);
    const double wgt = std::exp(-d.squaredNorm() * ic - h * h * is);
    sum += wgt * h;
    norm += wgt;
  }
  return norm > 0 ? sum / norm : 0.0;
}

// Point clouds: local spacing s = mean distance to the k nearest neighbours (the edge length on a
// regular triangulation, where the 6 nearest are the one-ring), area element sqrt(3)/2 s^2 (the
// area per vertex of that triangulation).
void density_areas(const KdTree& tree, const std::vector<int>& act, VecXd& A, VecXd& spacing) {
  const int na = static_cast<int>(act.size());
  const int k = std::min(kDensityK, na - 1);
  const MatX3d& Q = tree.points();
#pragma omp parallel
  {
    std::vector<int> idx;
    std::vector<double> d2;
#pragma omp for schedule(static)
    for (int a = 0; a < na; ++a) {
      double s = 0;
      const int got = k > 0 ? tree.knn(prow(Q, a), k + 1, idx, d2) : 0;
      for (int j = 1; j < got; ++j) s += std::sqrt(d2[j]);  // j = 0 is the point itself
      s = got > 1 ? s / (got - 1) : 0.0;
      spacing(act[a]) = s;
      A(act[a]) = 0.5 * std::sqrt(3.0) * s * s;
    }
  }
}

// PCA normals over the 2*sigma2 ball, oriented like the current ones.
void pca_normals(State& st) {
  const int na = static_cast<int>(st.act.size());
#pragma omp parallel for schedule(static)
  for (int a = 0; a < na; ++a) {
    const int x = st.act[a];
    const int* L = st.nb.list.data() + st.nb.off[x];
    const int c = st.nb.n2[x];
    if (c < 4 || st.N.row(x).squaredNorm() == 0) continue;
    Vec3 mean = Vec3::Zero();
    for (int j = 0; j < c; ++j) mean += prow(st.P, L[j]);
    mean /= c;
    Eigen::Matrix3d Cv = Eigen::Matrix3d::Zero();
    for (int j = 0; j < c; ++j) {
      const Vec3 d = prow(st.P, L[j]) - mean;
      Cv += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(Cv);
    Vec3 nn = es.eigenvectors().col(0);
    if (!nn.allFinite() || nn.squaredNorm() == 0) continue;
    nn.normalize();
    if (nn.dot(prow(st.N, x)) < 0) nn = -nn;
    st.N.row(x) = nn.transpose();
  }
}

void normalize_rows(MatX3d& N) {
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    const double l = N.row(i).norm();
    if (l > 0 && std::isfinite(l))
      N.row(i) /= l;
    else
      N.row(i).setZero();
  }
}

// A regular mesh holds about 14.5 eta^2 points in a ball of radius 2 eta e (area sqrt(3)/2 e^2 per
// vertex); the caps allow 2.5 times that, so only much denser spots are truncated (nearest first).
int patch_cap(const DenoiseOptions& o) {
  if (o.max_patch > 0) return o.max_patch;
  return std::clamp(static_cast<int>(std::ceil(36.0 * o.eta3 * o.eta3)), 12, kMaxPatch);
}
int window_cap(const DenoiseOptions& o) {
  if (o.max_window > 0) return o.max_window;
  return std::clamp(static_cast<int>(std::ceil(36.0 * o.eta2 * o.eta2)), 24, 4096);
}

// Prepares the state for one iteration: geometry, kd-tree, neighbourhoods.
void prepare(State& st, const MatX3i* F, const DenoiseOptions& o, bool cloud, bool first) {
  const int n = static_cast<int>(st.P.rows());
  if (!cloud) {
    st.e = surface_geometry(st.P, *F, st.N, st.A);
    normalize_rows(st.N);
  }
  st.act.clear();
  for (int i = 0; i < n; ++i)
    if (cloud || st.A(i) > 0) st.act.push_back(i);
  MatX3d Q(st.act.size(), 3);
  for (size_t a = 0; a < st.act.size(); ++a) Q.row(a) = st.P.row(st.act[a]);
  const KdTree tree(Q);
  if (cloud) {
    st.A.setZero(n);
    VecXd spacing = VecXd::Zero(n);
    density_areas(tree, st.act, st.A, spacing);
    st.e = spacing.sum() / std::max<double>(1.0, static_cast<double>(st.act.size()));
  }
  double asum = 0;
  for (int x : st.act) asum += st.A(x);
  st.mean_area = st.act.empty() ? 1.0 : asum / static_cast<double>(st.act.size());
  if (!(st.e > 0) || !std::isfinite(st.e) || !(st.mean_area > 0))
    throw MeshError(cloud ? "the points are all coincident: no sampling density" : "no face has a positive area");
  const double r2 = 2 * o.eta2 * st.e, r3 = 2 * o.eta3 * st.e;
  build_neighbourhoods(tree, st.act, n, r2, r3, window_cap(o), patch_cap(o), st.nb);
  if (cloud && !first && o.reestimate_normals) pca_normals(st);
}

// Taubin's lambda|mu smoothing over the edges of F (each edge once, however many faces share it)
// with the umbrella operator L x_i = sum_j W_ij x_j - x_i, W_ij = (1 - c) / deg_i + c w_ij / sum_k w_ik:
// half uniform (its tangential part evens out the tangential component of isotropic noise) and
// half cotangent, w_ij = max(0, (cot alpha + cot beta) / 2) of the input positions (no tangential
// drift on an irregular triangulation, which counts as error of the face normals), c =
// kTaubinCotangentShare; a vertex without a positive cotangent weight uses the uniform part alone.
// The weights are convex, so every step is a stable average. Fixed points keep their place but
// inform their neighbours.
void taubin_smooth(MatX3d& P, const MatX3i& F, const std::vector<char>& movable, int steps) {
  const int n = static_cast<int>(P.rows());
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      if (a != b) edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const size_t ne = edges.size();
  std::vector<double> cot(ne, 0.0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3), o = F(f, (k + 2) % 3);
      if (a == b) continue;
      const Vec3 u = prow(P, a) - prow(P, o), v = prow(P, b) - prow(P, o);
      const double area2 = u.cross(v).norm();
      const double c = 0.5 * u.dot(v) / area2;
      if (!(area2 > 0) || !std::isfinite(c)) continue;  // a degenerate corner adds nothing
      const auto it = std::lower_bound(edges.begin(), edges.end(), std::make_pair(std::min(a, b), std::max(a, b)));
      cot[static_cast<size_t>(it - edges.begin())] += c;
    }
  VecXd degree = VecXd::Zero(n), cot_sum = VecXd::Zero(n);
  for (size_t e = 0; e < ne; ++e) {
    const auto [a, b] = edges[e];
    cot[e] = std::max(0.0, cot[e]);
    degree(a) += 1;
    degree(b) += 1;
    cot_sum(a) += cot[e];
    cot_sum(b) += cot[e];
  }
  const auto weight = [&](int i, double w) {
    return cot_sum(i) > 0 && std::isfinite(cot_sum(i))
               ? (1 - kTaubinCotangentShare) / degree(i) + kTaubinCotangentShare * w / cot_sum(i)
               : 1 / degree(i);
  };
  std::vector<std::array<double, 2>> W(ne);
  for (size_t e = 0; e < ne; ++e) W[e] = {weight(edges[e].first, cot[e]), weight(edges[e].second, cot[e])};
  MatX3d L(n, 3);
  for (int s = 0; s < 2 * steps; ++s) {
    const double factor = s % 2 == 0 ? kTaubinLambda : kTaubinMu;
    L.setZero();
    for (size_t e = 0; e < ne; ++e) {
      const auto [a, b] = edges[e];
      L.row(a) += W[e][0] * P.row(b);
      L.row(b) += W[e][1] * P.row(a);
    }
    for (int i = 0; i < n; ++i)
      if (movable[i] && degree(i) > 0) P.row(i) += factor * (L.row(i) - P.row(i));
  }
}

DenoiseResult run(const MatX3d& V, const MatX3i* F, const MatX3d* Nin, const DenoiseOptions& o,
                  const ProgressFn& progress_fn) {
  const bool cloud = F == nullptr;
  const int n = static_cast<int>(V.rows());
  Welded wd = weld(V, o.weld_tolerance * bbox_diagonal(V));
  const int nw = static_cast<int>(wd.P.rows());

  MatX3i Fw;
  if (!cloud) {
    Fw.resize(F->rows(), 3);
    for (Eigen::Index f = 0; f < F->rows(); ++f)
      for (int k = 0; k < 3; ++k) Fw(f, k) = wd.rep[(*F)(f, k)];
  }
  // A welded point moves only if every copy may move.
  std::vector<char> movable(nw, 1);
  if (!o.movable.empty())
    for (int i = 0; i < n; ++i)
      if (!o.movable[i]) movable[wd.rep[i]] = 0;

  State st;
  st.P = wd.P;
  if (cloud) {
    st.N.setZero(nw, 3);
    for (int i = 0; i < n; ++i) st.N.row(wd.rep[i]) += Nin->row(i).normalized();
    normalize_rows(st.N);
  }
  const MatX3d P0 = st.P;
  if (!cloud && o.smoothing_steps > 0) taubin_smooth(st.P, Fw, movable, o.smoothing_steps);

  Progress progress(progress_fn);
  progress(0.0);
  DenoiseResult res;
  long long fallbacks = 0;
  const int nt = num_threads();
  const int max_samples = window_cap(o) * patch_cap(o);
  std::vector<Scratch> scratch;
  std::vector<std::vector<double>> wbuf(nt);
  std::vector<long long> fb(nt, 0);
  if (o.method == DenoiseMethod::Similarity) {
    scratch.reserve(nt);
    for (int t = 0; t < nt; ++t) scratch.emplace_back(max_samples);
  }
  for (int it = 0; it < o.iterations; ++it) {
    prepare(st, cloud ? nullptr : &Fw, o, cloud, it == 0);
    res.edge_length = st.e;
    MatX3d Pn = st.P;
    const int na = static_cast<int>(st.act.size());
    const int block = std::max(2048, na / 50);
    for (int start = 0; start < na; start += block) {
      const int end = std::min(na, start + block);
#pragma omp parallel for schedule(dynamic, 64) num_threads(nt)
      for (int a = start; a < end; ++a) {
        const int x = st.act[a];
        if (!movable[x] || st.N.row(x).squaredNorm() == 0) continue;
        const int t = thread_index();
        const double k = o.method == DenoiseMethod::Similarity ? similarity_step(st, x, o, scratch[t], wbuf[t], fb[t])
                                                               : bilateral_step(st, x, o);
        if (std::isfinite(k)) Pn.row(x) += (k * st.e) * st.N.row(x);  // eq. 2.3
      }
      progress((it + static_cast<double>(end) / na) / std::max(1, o.iterations));
    }
    st.P.swap(Pn);
  }
  for (long long f : fb) fallbacks += f;

  // Every copy gets its welded point's displacement, so coincident vertices stay coincident.
  res.vertices.resize(n, 3);
  res.residual.resize(n);
  std::vector<double> moved;
  moved.reserve(n);
  for (int i = 0; i < n; ++i) {
    const int w = wd.rep[i];
    const Eigen::RowVector3d d = st.P.row(w) - P0.row(w);
    res.vertices.row(i) = V.row(i) + d;
    res.residual(i) = d.norm();
    const bool part = cloud || (st.A.size() == nw && st.A(w) > 0);
    if (movable[w] && part) moved.push_back(res.residual(i));
  }
  res.residual_entropy =
      residual_entropy(Eigen::Map<const VecXd>(moved.data(), static_cast<Eigen::Index>(moved.size())));
  res.iterations = o.iterations;
  res.rbf_fallbacks = fallbacks;
  res.welded = wd.merged;
  progress(1.0);
  return res;
}

void check_surface(const MatX3d& V, const MatX3i& F) {
  if (V.rows() == 0) throw MeshError("the mesh has no vertices");
  if (F.rows() == 0) throw MeshError("the mesh has no faces (for a point cloud pass normals and no faces)");
  check_finite(V, "V");
  const int n = static_cast<int>(V.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw MeshError("face " + std::to_string(f) + " has vertex index " + std::to_string(F(f, k)) +
                        " out of range [0, " + std::to_string(n) + ")");
}

void check_cloud(const MatX3d& V, const MatX3d& N) {
  if (V.rows() == 0) throw MeshError("the point cloud has no points");
  if (N.rows() != V.rows())
    throw MeshError("normals have " + std::to_string(N.rows()) + " rows but there are " + std::to_string(V.rows()) +
                    " points");
  check_finite(V, "V");
  check_finite(N, "normals");
}

// Similarity of every point to x. `cloud` selects the area element / e rule.
VecXd similarity_welded(State& st, const MatX3i* F, bool cloud, int x, const SimilarityOptions& so,
                        const ProgressFn& progress_fn) {
  Progress progress(progress_fn);
  progress(0.0);
  DenoiseOptions o;
  o.eta1 = so.eta1;
  o.eta3 = so.eta3;
  o.eta2 = so.eta3;  // only the 2*sigma3 neighbourhoods are needed
  o.max_patch = so.max_patch;
  o.max_window = patch_cap(o);
  const int cap = patch_cap(o);
  prepare(st, F, o, cloud, true);
  const int n = static_cast<int>(st.P.rows());
  VecXd w = VecXd::Zero(n);
  if (!(st.A(x) > 0) && !cloud) throw MeshError("the chosen vertex is in no face");
  if (st.N.row(x).squaredNorm() == 0) throw MeshError("the chosen vertex has no normal");
  const Frame fr(prow(st.N, x));
  const double inv_e = 1.0 / st.e;
  auto s0 = std::make_unique<Scratch>(cap);
  build_patch(st.P, st.nb.list.data() + st.nb.off[x], st.nb.n3[x], x, fr, inv_e, *s0);
  const Patch patch = s0->patch;
  const Vec3 px = prow(st.P, x);
  const int na = static_cast<int>(st.act.size());
  const int nt = num_threads();
  std::vector<std::unique_ptr<Scratch>> scratch(nt);  // large: keep them off worker stacks
  std::vector<std::vector<double>> wbuf(nt);
  // Blocks of vertices, with progress (and cancellation) between them, as in the denoising loop.
  const int block = std::max(2048, na / 50);
  for (int start = 0; start < na; start += block) {
    const int end = std::min(na, start + block);
#pragma omp parallel for schedule(dynamic, 256) num_threads(nt)
    for (int a = start; a < end; ++a) {
      const int t = thread_index();
      if (!scratch[t]) {
        scratch[t] = std::make_unique<Scratch>(cap);
        scratch[t]->patch = patch;
      }
      Scratch& s = *scratch[t];
      std::vector<double>& wy = wbuf[t];
      const int y = st.act[a];
      s.seg.assign({0});
      // Translation invariant: heights of y's neighbourhood measured from y itself.
      if (st.N.row(y).squaredNorm() == 0) continue;  // no normal, no shape: weight 0
      int S;
      if (so.shape_only) {
        const Frame fy(prow(st.N, y), fr);
        S = add_samples(st.P, st.A, 1.0 / st.mean_area, st.nb, y, prow(st.P, y), fy, inv_e, s, 0);
      } else {
        S = add_samples(st.P, st.A, 1.0 / st.mean_area, st.nb, y, px, fr, inv_e, s, 0);
      }
      s.seg.push_back(S);
      eval_patch(s, S);
      segment_weights(s, S, so.eta1, so.eta3, wy);
      w(y) = wy[0];
    }
    progress(static_cast<double>(end) / na);
  }
  progress(1.0);
  return w;
}

void check_similarity_options(const SimilarityOptions& so) {
  if (!(std::isfinite(so.eta1) && so.eta1 >= kMinEta))
    throw MeshError("eta1 must be a number of at least 0.001 (edge lengths), got " + std::to_string(so.eta1));
  if (!(so.eta3 >= kMinEta && so.eta3 <= 20))
    throw MeshError("eta3 must be in [0.001, 20], got " + std::to_string(so.eta3));
  if (so.max_patch != 0 && (so.max_patch < 3 || so.max_patch > kMaxPatch))
    throw MeshError("max_patch must be 0 (automatic) or in [3, " + std::to_string(kMaxPatch) + "]");
}

}  // namespace

DenoiseOptions bilateral_defaults() {
  DenoiseOptions o;
  o.method = DenoiseMethod::Bilateral;
  o.eta1 = 0.25;
  o.eta2 = 1.0;
  o.eta3 = 1.0;
  o.iterations = 3;
  return o;
}

DenoiseOptions denoise_defaults(DenoiseMethod method) {
  return method == DenoiseMethod::Bilateral ? bilateral_defaults() : DenoiseOptions{};
}

DenoiseOptions auto_options(const NoiseEstimate& noise, const DenoiseOptions& base) {
  DenoiseOptions o = base;
  const bool sim = base.method == DenoiseMethod::Similarity;
  const double sigma = std::isfinite(noise.sigma) ? std::max(0.0, noise.sigma) : 0.0;
  // Similarity: D (eq. 2.9) sums squared differences over about sum g = 4 pi eta3^2 / sqrt(3)
  // samples (the unnormalised Gaussian's integral 2 pi eta3^2 over the area sqrt(3)/2 per vertex of
  // a regular mesh), each of variance about 2 sigma^2 between two noisy copies of one shape, so
  // sigma1 = k sqrt(sum g) sigma weighs equal shapes exp(-1 / k^2) whatever eta3. Bilateral: the
  // height Gaussian sees single heights, sigma1 = k sigma.
  const double samples = 4 * detail::kPi * base.eta3 * base.eta3 / std::sqrt(3.0);
  o.eta1 = std::max(kMinEta, sim ? kAutoKernelSimilarity * std::sqrt(samples) * sigma : kAutoKernelBilateral * sigma);
  o.iterations = sim ? kAutoIterationsSimilarity : kAutoIterationsBilateral;
  // The weighted mean's curvature bias (about e kappa / 2 edge lengths per iteration) against the
  // quadratic fit's extra variance (a few times sigma^2): the fit pays where the sampling is coarse
  // for the bending, e kappa > sigma (measured: bench/notes/denoise.md).
  o.quadratic_fit = sim && noise.curvature > sigma;
  o.smoothing_steps = 0;
  return o;
}

int auto_smoothing_steps(const NoiseEstimate& noise) {
  const double sigma = std::isfinite(noise.sigma) ? std::max(0.0, noise.sigma) : 0.0;
  const double detail = std::isfinite(noise.detail) ? std::max(kAutoSmoothMinDetail, noise.detail) : 1.0;
  const double shape = std::min(kAutoSmoothFloor * detail, kAutoSmoothFloorCap);  // the shape's own reading
  const double excess = std::sqrt(std::max(0.0, sigma * sigma - shape * shape));
  const double k = kAutoSmoothScale * std::pow(excess, kAutoSmoothPower) / std::pow(detail, kAutoSmoothDetailPower);
  return static_cast<int>(std::lround(std::min<double>(k, kAutoSmoothMaxSteps)));
}

bool shows_features(const NoiseEstimate& noise) {
  return noise.outliers > kAutoFeatureRatio * std::max(kAutoSmoothMinCurvature, noise.curvature);
}

namespace {

// Automatic mode: the estimate (its own progress share: 5%) and the options after the rule.
DenoiseResult run_auto(const MatX3d& V, const MatX3i* F, const MatX3d* N, const DenoiseOptions& opt,
                       const ProgressFn& progress) {
  if (!opt.automatic) {
    DenoiseResult r = run(V, F, N, opt, progress);
    r.options = opt;
    return r;
  }
  constexpr double kShare = 0.05;
  const ProgressFn first = progress ? ProgressFn([&](double f) { return progress(kShare * f); }) : ProgressFn{};
  const ProgressFn rest =
      progress ? ProgressFn([&](double f) { return progress(kShare + (1 - kShare) * f); }) : ProgressFn{};
  NoiseOptions no;
  no.weld_tolerance = opt.weld_tolerance;
  NoiseEstimate est;
  try {
    est = F ? estimate_noise(V, *F, no, first) : estimate_noise_points(V, no, first);
  } catch (const MeshError& e) {
    throw MeshError(std::string("automatic parameters: ") + e.what() + "; turn automatic off and set the etas");
  }
  const DenoiseOptions o = auto_options(est, opt);
  const bool choose = F && o.method == DenoiseMethod::Similarity;
  const int steps = choose ? auto_smoothing_steps(est) : 0;
  if (choose && steps == 0) {
    // The noise is too small against the shape detail for a smoothing step to pay: leave the mesh
    // as it is (the filter would add its own bias: 3.0 degrees on the noise-free camel).
    DenoiseOptions none = o;
    none.iterations = 0;
    DenoiseResult r = run(V, F, N, none, rest);
    r.noise = est;
    r.options = none;
    return r;
  }
  const ProgressFn filter_part = progress && steps > 0 ? ProgressFn([&](double f) { return rest(0.9 * f); }) : rest;
  DenoiseResult r = run(V, F, N, o, filter_part);
  r.noise = est;
  r.options = o;
  if (steps == 0) return r;
  // The rule asks for smoothing: keep the filter's result if it shows sharp features, else smooth.
  NoiseEstimate after;
  try {
    NoiseOptions feature_test = no;
    feature_test.measure_detail = false;  // only outliers and curvature are read
    after = estimate_noise(r.vertices, *F, feature_test);
  } catch (const MeshError&) {
    return r;  // the filtered mesh is degenerate for a fit: keep it
  }
  if (shows_features(after)) return r;
  DenoiseOptions so = o;
  so.iterations = 0;
  so.smoothing_steps = steps;
  const ProgressFn last = progress ? ProgressFn([&](double f) { return rest(0.9 + 0.1 * f); }) : ProgressFn{};
  DenoiseResult s = run(V, F, N, so, last);
  s.noise = est;
  s.options = so;
  return s;
}

}  // namespace

DenoiseResult denoise(const MatX3d& V, const MatX3i& F, const DenoiseOptions& opt, const ProgressFn& progress) {
  check_surface(V, F);
  check_options(opt, V.rows());
  return run_auto(V, &F, nullptr, opt, progress);
}

DenoiseResult denoise_points(const MatX3d& V, const MatX3d& N, const DenoiseOptions& opt, const ProgressFn& progress) {
  check_cloud(V, N);
  check_options(opt, V.rows());
  if (V.rows() < 4) throw MeshError("a point cloud needs at least 4 points");
  return run_auto(V, nullptr, &N, opt, progress);
}

VecXd similarity(const MatX3d& V, const MatX3i& F, int vertex, const SimilarityOptions& opt,
                 const ProgressFn& progress) {
  check_surface(V, F);
  check_similarity_options(opt);
  if (vertex < 0 || vertex >= V.rows())
    throw MeshError("vertex " + std::to_string(vertex) + " out of range [0, " + std::to_string(V.rows()) + ")");
  Welded wd = weld(V, 1e-9 * bbox_diagonal(V));
  MatX3i Fw(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) Fw(f, k) = wd.rep[F(f, k)];
  State st;
  st.P = wd.P;
  const VecXd w = similarity_welded(st, &Fw, false, wd.rep[vertex], opt, progress);
  VecXd out(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) out(i) = w(wd.rep[i]);
  return out;
}

VecXd similarity_points(const MatX3d& V, const MatX3d& N, int vertex, const SimilarityOptions& opt,
                        const ProgressFn& progress) {
  check_cloud(V, N);
  check_similarity_options(opt);
  if (V.rows() < 4) throw MeshError("a point cloud needs at least 4 points");
  if (vertex < 0 || vertex >= V.rows())
    throw MeshError("vertex " + std::to_string(vertex) + " out of range [0, " + std::to_string(V.rows()) + ")");
  Welded wd = weld(V, 1e-9 * bbox_diagonal(V));
  State st;
  st.P = wd.P;
  st.N.setZero(st.P.rows(), 3);
  for (Eigen::Index i = 0; i < V.rows(); ++i) st.N.row(wd.rep[i]) += N.row(i).normalized();
  normalize_rows(st.N);
  const VecXd w = similarity_welded(st, nullptr, true, wd.rep[vertex], opt, progress);
  VecXd out(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) out(i) = w(wd.rep[i]);
  return out;
}

double residual_entropy(const VecXd& r) {
  constexpr int kBins = 64;
  double sum = 0;
  long long cnt = 0;
  for (Eigen::Index i = 0; i < r.size(); ++i)
    if (std::isfinite(r(i))) {
      sum += std::abs(r(i));
      ++cnt;
    }
  if (cnt == 0 || !(sum > 0)) return 0.0;
  const double mean = sum / static_cast<double>(cnt);
  std::vector<long long> hist(kBins + 1, 0);
  for (Eigen::Index i = 0; i < r.size(); ++i) {
    if (!std::isfinite(r(i))) continue;
    const double t = std::abs(r(i)) / mean / 4.0 * kBins;
    const int b = t >= kBins ? kBins : static_cast<int>(t);
    ++hist[b];
  }
  double H = 0;
  for (long long c : hist)
    if (c > 0) {
      const double p = static_cast<double>(c) / static_cast<double>(cnt);
      H -= p * std::log2(p);
    }
  return H;
}

}  // namespace dgmesh
