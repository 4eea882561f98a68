// Noise estimation from the leverage-standardised residuals of local cubic fits (see
// noise_estimate.h for the derivation).
#include "dgmesh/noise_estimate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"
#include "dgmesh/spatial_index.h"

namespace dgmesh {

namespace {

constexpr int kCoeffs = 10;                  // cubic height function
constexpr double kMadToSigma = 1.482602218;  // 1 / Phi^-1(3/4)
constexpr int kDensityK = 6;                 // neighbours for a point cloud's spacing (a regular mesh's one-ring)
// A fit whose centre has leverage above this leaves the centre's residual almost no variance
// (1 - h < 1e-3): its standardised residual would be mostly rounding. Such fits are skipped.
constexpr double kMaxLeverage = 1.0 - 1e-3;

inline Vec3 prow(const MatX3d& P, int i) { return Vec3(P(i, 0), P(i, 1), P(i, 2)); }

void check_finite(const MatX3d& V) {
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(V(i, k)))
        throw MeshError("V has a non-finite coordinate (NaN or inf) at row " + std::to_string(i));
}

void check_options(const NoiseOptions& o) {
  if (o.neighbours < kCoeffs + 2 || o.neighbours > 64)
    throw MeshError("neighbours must be in [12, 64], got " + std::to_string(o.neighbours));
  if (!(o.weld_tolerance >= 0 && o.weld_tolerance < 1e-2))
    throw MeshError("weld_tolerance must be in [0, 0.01), got " + std::to_string(o.weld_tolerance));
}

// The distinct points among `V` rows with `use` set: coincident ones (within tol) count once.
MatX3d distinct_points(const MatX3d& V, const std::vector<char>& use, double tol) {
  std::vector<int> rows;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (use[i]) rows.push_back(static_cast<int>(i));
  MatX3d P(rows.size(), 3);
  for (size_t k = 0; k < rows.size(); ++k) P.row(k) = V.row(rows[k]);
  if (!(tol > 0) || P.rows() < 2) return P;
  const KdTree tree(P);
  std::vector<char> keep(P.rows(), 1);
  std::vector<std::pair<int, double>> hits;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {  // serial: keeps the lowest index of each cluster
    if (!keep[i]) continue;
    tree.radius(prow(P, static_cast<int>(i)), tol, hits);
    for (const auto& h : hits)
      if (h.first > i) keep[h.first] = 0;
  }
  MatX3d Q(std::count(keep.begin(), keep.end(), 1), 3);
  for (Eigen::Index i = 0, k = 0; i < P.rows(); ++i)
    if (keep[i]) Q.row(k++) = P.row(i);
  return Q;
}

double bbox_diagonal(const MatX3d& V) {
  if (V.rows() == 0) return 0;
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

// Standardised residual and e * max |principal curvature| of the fit at point i (in units of e).
// Returns false when the fit is ill-posed (too few points, degenerate layout).
bool fit_point(const KdTree& tree, int i, int k, double inv_e, std::vector<int>& idx, std::vector<double>& d2,
               double& z, double& kappa) {
  const MatX3d& P = tree.points();
  const int got = tree.knn(prow(P, i), k, idx, d2);
  if (got < kCoeffs + 2) return false;
  const Vec3 p = prow(P, i);
  // Principal-component frame of the neighbourhood (the origin stays at p).
  Vec3 mean = Vec3::Zero();
  for (int j = 0; j < got; ++j) mean += prow(P, idx[j]);
  mean /= got;
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int j = 0; j < got; ++j) {
    const Vec3 d = prow(P, idx[j]) - mean;
    C += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(C);
  const Vec3 n = es.eigenvectors().col(0), t1 = es.eigenvectors().col(2), t2 = es.eigenvectors().col(1);
  if (!n.allFinite()) return false;
  Eigen::Matrix<double, kCoeffs, kCoeffs> A = Eigen::Matrix<double, kCoeffs, kCoeffs>::Zero();
  Eigen::Matrix<double, kCoeffs, 1> b = Eigen::Matrix<double, kCoeffs, 1>::Zero();
  for (int j = 0; j < got; ++j) {
    const Vec3 d = (prow(P, idx[j]) - p) * inv_e;
    const double u = t1.dot(d), v = t2.dot(d), h = n.dot(d);
    Eigen::Matrix<double, kCoeffs, 1> x;
    x << 1.0, u, v, u * u, u * v, v * v, u * u * u, u * u * v, u * v * v, v * v * v;
    A.noalias() += x * x.transpose();
    b.noalias() += x * h;
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, kCoeffs, kCoeffs>> lu(A);
  if (lu.rank() < kCoeffs) return false;
  const Eigen::Matrix<double, kCoeffs, 1> c = lu.solve(b);
  Eigen::Matrix<double, kCoeffs, 1> e0 = Eigen::Matrix<double, kCoeffs, 1>::Zero();
  e0(0) = 1.0;
  const double lev = lu.solve(e0)(0);  // [(X^T X)^-1]_00
  if (!(lev > 0 && lev < kMaxLeverage) || !c.allFinite()) return false;
  z = -c(0) / std::sqrt(1.0 - lev);  // p's height is 0: residual 0 - c0
  // Principal curvatures of the graph at p: eigenvalues of I^-1 II.
  const double g1 = c(1), g2 = c(2), w = std::sqrt(1.0 + g1 * g1 + g2 * g2);
  Eigen::Matrix2d I, II;
  I << 1 + g1 * g1, g1 * g2, g1 * g2, 1 + g2 * g2;
  II << 2 * c(3), c(4), c(4), 2 * c(5);
  const Eigen::Matrix2d S = I.inverse() * II / w;
  const double tr = S.trace(), det = S.determinant(), disc = std::sqrt(std::max(0.0, tr * tr / 4 - det));
  kappa = std::max(std::abs(tr / 2 + disc), std::abs(tr / 2 - disc));
  return std::isfinite(z) && std::isfinite(kappa);
}

double median(std::vector<double>& a) {
  const size_t m = a.size() / 2;
  std::nth_element(a.begin(), a.begin() + m, a.end());
  double hi = a[m];
  if (a.size() % 2 == 1) return hi;
  return 0.5 * (hi + *std::max_element(a.begin(), a.begin() + m));
}

// Fits of k points around every point: standardised residuals z (NaN where ill-posed) and curvatures.
// Progress runs over [p0, p1].
void fit_all(const KdTree& tree, int k, double inv_e, std::vector<double>& z, std::vector<double>& kappa,
             Progress& progress, double p0, double p1) {
  const int n = static_cast<int>(tree.points().rows());
  z.assign(n, std::numeric_limits<double>::quiet_NaN());
  kappa.assign(n, 0.0);
  const int block = std::max(4096, n / 20);
  for (int start = 0; start < n; start += block) {
    const int end = std::min(n, start + block);
#pragma omp parallel if (end - start >= kParallelMin)
    {
      std::vector<int> idx;
      std::vector<double> d2;
#pragma omp for schedule(static)
      for (int i = start; i < end; ++i) {
        double zi, ki;
        if (fit_point(tree, i, k, inv_e, idx, d2, zi, ki)) {
          z[i] = zi;
          kappa[i] = ki;
        }
      }
    }
    progress(p0 + (p1 - p0) * static_cast<double>(end) / n);
  }
}

NoiseEstimate estimate(const MatX3d& P, double e, const NoiseOptions& o, const ProgressFn& progress_fn) {
  const int n = static_cast<int>(P.rows());
  if (n < o.neighbours)
    throw MeshError("the noise estimate needs at least " + std::to_string(o.neighbours) + " distinct points, got " +
                    std::to_string(n));
  if (!(e > 0) || !std::isfinite(e)) throw MeshError("the points have no spacing (all coincident)");
  Progress progress(progress_fn);
  progress(0.0);
  const KdTree tree(P);
  const double inv_e = 1.0 / e;
  const int wide = wide_neighbours(o.neighbours);
  const bool detail = o.measure_detail && n >= wide;
  const double split = detail ? 0.4 : 1.0;
  std::vector<double> z, kappa;
  fit_all(tree, o.neighbours, inv_e, z, kappa, progress, 0.0, split);
  std::vector<double> az, ak;
  az.reserve(n);
  ak.reserve(n);
  for (int i = 0; i < n; ++i)
    if (std::isfinite(z[i])) {
      az.push_back(std::abs(z[i]));
      ak.push_back(kappa[i]);
    }
  if (az.empty()) throw MeshError("no point has a well-posed local fit (all points on a line?)");
  NoiseEstimate r;
  r.samples = static_cast<int>(az.size());
  r.edge_length = e;
  std::vector<double> tmp = az;
  r.sigma = kMadToSigma * median(tmp);
  r.sigma_abs = r.sigma * e;
  r.curvature = median(ak);
  const double cut = 3.0 * r.sigma;
  long long out = 0;
  for (double a : az) out += a > cut;
  r.outliers = static_cast<double>(out) / static_cast<double>(az.size());
  if (detail) {  // detail: the wide fits' estimate against this one (see the header)
    fit_all(tree, wide, inv_e, z, kappa, progress, split, 1.0);
    std::vector<double> aw;
    aw.reserve(n);
    for (int i = 0; i < n; ++i)
      if (std::isfinite(z[i])) aw.push_back(std::abs(z[i]));
    if (!aw.empty()) {
      const double wide_sigma = kMadToSigma * median(aw);
      r.detail = std::sqrt(std::max(0.0, wide_sigma * wide_sigma - r.sigma * r.sigma));
    }
  }
  progress(1.0);
  return r;
}

}  // namespace

int wide_neighbours(int neighbours) { return std::min(64, 2 * neighbours - 2); }

NoiseEstimate estimate_noise(const MatX3d& V, const MatX3i& F, const NoiseOptions& opt, const ProgressFn& progress) {
  check_options(opt);
  if (V.rows() == 0) throw MeshError("the mesh has no vertices");
  if (F.rows() == 0) throw MeshError("the mesh has no faces (for a point cloud use estimate_noise_points)");
  check_finite(V);
  const int n = static_cast<int>(V.rows());
  std::vector<char> use(n, 0);
  double edge_sum = 0;
  long long edges = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw MeshError("face " + std::to_string(f) + " has vertex index " + std::to_string(F(f, k)) +
                        " out of range [0, " + std::to_string(n) + ")");
    const Vec3 a = prow(V, F(f, 0)), b = prow(V, F(f, 1)), c = prow(V, F(f, 2));
    if (!((b - a).cross(c - a).norm() > 0)) continue;  // same faces as denoise's e
    edge_sum += (b - a).norm() + (c - b).norm() + (a - c).norm();
    edges += 3;
    for (int k = 0; k < 3; ++k) use[F(f, k)] = 1;
  }
  if (edges == 0) throw MeshError("no face has a positive area");
  const MatX3d P = distinct_points(V, use, opt.weld_tolerance * bbox_diagonal(V));
  return estimate(P, edge_sum / static_cast<double>(edges), opt, progress);
}

NoiseEstimate estimate_noise_points(const MatX3d& V, const NoiseOptions& opt, const ProgressFn& progress) {
  check_options(opt);
  if (V.rows() == 0) throw MeshError("the point cloud has no points");
  check_finite(V);
  const MatX3d P = distinct_points(V, std::vector<char>(V.rows(), 1), opt.weld_tolerance * bbox_diagonal(V));
  if (P.rows() < opt.neighbours)
    throw MeshError("the noise estimate needs at least " + std::to_string(opt.neighbours) + " distinct points, got " +
                    std::to_string(P.rows()));
  // Spacing as denoise_points: mean distance to the nearest kDensityK points.
  const KdTree tree(P);
  double s = 0;
  std::vector<int> idx;
  std::vector<double> d2;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const int got = tree.knn(prow(P, static_cast<int>(i)), kDensityK + 1, idx, d2);
    double si = 0;
    for (int j = 1; j < got; ++j) si += std::sqrt(d2[j]);
    s += got > 1 ? si / (got - 1) : 0.0;
  }
  return estimate(P, s / static_cast<double>(P.rows()), opt, progress);
}

}  // namespace dgmesh
