// Direct minimisation of the L2 stretch with an injectivity barrier; see uv_stretch_opt.h.
#include "dgmesh/uv_stretch_opt.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/detail/timer.h"
#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"
#include "dgmesh/sparse_solver.h"

namespace dgmesh::detail {

namespace {

using Mat4 = Eigen::Matrix4d;
using Vec4 = Eigen::Vector4d;
using Mat46 = Eigen::Matrix<double, 4, 6>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// Per triangle: A(T) and the 4x6 map D from the corner UVs (u0x, u0y, u1x, u1y, u2x, u2y) to
// vec(J) = (J00, J01, J10, J11), J = [u1 - u0, u2 - u0] X^{-1} with X the edges in T's frame.
struct Tri {
  double area = 0;  // 0: a degenerate 3D triangle (no energy)
  Mat46 D = Mat46::Zero();
};

Tri make_tri(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
  Tri t;
  const Vec3 e1 = p1 - p0, e2 = p2 - p0;
  const double l1 = e1.norm(), c = e1.cross(e2).norm();
  if (!(l1 > 0) || !(c > 1e-14 * e1.squaredNorm() + 1e-300) || !std::isfinite(c)) return t;
  const double x11 = l1, x12 = e2.dot(e1) / l1, x22 = c / l1;  // X = [[x11, x12], [0, x22]]
  // X^{-1} = [[1/x11, -x12/(x11 x22)], [0, 1/x22]]
  const double i00 = 1 / x11, i01 = -x12 / (x11 * x22), i10 = 0, i11 = 1 / x22;
  const double g0[3] = {-(i00 + i10), i00, i10};  // J_r0 = sum_j g0[j] u_j,r
  const double g1[3] = {-(i01 + i11), i01, i11};  // J_r1
  for (int r = 0; r < 2; ++r)
    for (int j = 0; j < 3; ++j) {
      t.D(2 * r + 0, 2 * j + r) = g0[j];
      t.D(2 * r + 1, 2 * j + r) = g1[j];
    }
  t.area = 0.5 * c;
  return t;
}

inline Vec6 corners(const MatX2d& U, const MatX3i& F, int f) {
  Vec6 x;
  for (int j = 0; j < 3; ++j) x.segment<2>(2 * j) = U.row(F(f, j)).transpose();
  return x;
}

// f(J) = |J|^2 / (2 det^2) + det; +inf when det <= 0.
inline double energy_j(const Vec4& x) {
  const double d = x[0] * x[3] - x[1] * x[2];
  if (!(d > 0)) return kInf;
  return x.squaredNorm() / (2 * d * d) + d;
}

// Gradient and Hessian of energy_j (checked against finite differences in test_unwrap.cpp through
// the energy's decrease; derivation in the header's terms: g = d det / dJ).
inline void derivs_j(const Vec4& x, Vec4& grad, Mat4& H) {
  const double d = x[0] * x[3] - x[1] * x[2], I = x.squaredNorm();
  const Vec4 g(x[3], -x[2], -x[1], x[0]);
  const double d2 = d * d, d3 = d2 * d, d4 = d2 * d2;
  grad = x / d2 + (1 - I / d3) * g;
  Mat4 Hd = Mat4::Zero();
  Hd(0, 3) = Hd(3, 0) = 1;
  Hd(1, 2) = Hd(2, 1) = -1;
  H = Mat4::Identity() / d2 - 2 * (x * g.transpose() + g * x.transpose()) / d3 + 3 * I * g * g.transpose() / d4 +
      (1 - I / d3) * Hd;
}

inline double det2(const Vec6& u) { return (u[2] - u[0]) * (u[5] - u[1]) - (u[4] - u[0]) * (u[3] - u[1]); }

// Smallest t > 0 with det2(u + t du) = 0 (kInf if none).
double first_root(const Vec6& u, const Vec6& du) {
  const double ax = u[2] - u[0], ay = u[3] - u[1], bx = u[4] - u[0], by = u[5] - u[1];
  const double dax = du[2] - du[0], day = du[3] - du[1], dbx = du[4] - du[0], dby = du[5] - du[1];
  // det(t) = A t^2 + B t + C
  const double A = dax * dby - dbx * day;
  const double B = ax * dby + dax * by - bx * day - dbx * ay;
  const double C = ax * by - bx * ay;
  const double scale = std::abs(B) + std::abs(C) + 1e-300;
  if (std::abs(A) <= 1e-12 * scale) return B < 0 ? -C / B : kInf;
  const double disc = B * B - 4 * A * C;
  if (disc < 0) return kInf;
  const double sq = std::sqrt(disc);
  const double q = -0.5 * (B + (B >= 0 ? sq : -sq));
  double t = kInf;
  for (double r : {q / A, q != 0 ? C / q : kInf})
    if (r > 0) t = std::min(t, r);
  return t;
}

// Barrier keeping UV triangles away from zero area: b(a) = -k (a - a0)^2 log(a / a0) for
// 0 < a < a0, else 0 (C2 at a0, +inf at 0), on the UV area a of every triangle; returns b, b', b''.
struct Barrier {
  double a0 = 0, k = 0;
  double value(double a) const {
    if (a >= a0) return 0;
    if (!(a > 0)) return kInf;
    return -k * (a - a0) * (a - a0) * std::log(a / a0);
  }
  void derivs(double a, double& d1, double& d2) const {
    d1 = d2 = 0;
    if (a >= a0 || !(a > 0)) return;
    const double l = std::log(a / a0), e = a - a0;
    d1 = -k * (2 * e * l + e * e / a);
    d2 = -k * (2 * l + 4 * e / a - e * e / (a * a));
  }
};

// Gradient of the UV area (det2 / 2) with respect to the 6 corner coordinates.
inline Vec6 area_grad(const Vec6& u) {
  Vec6 g;
  g << u[3] - u[5], u[4] - u[2], u[5] - u[1], u[0] - u[4], u[1] - u[3], u[2] - u[0];
  return 0.5 * g;
}

}  // namespace

StretchOptResult minimize_stretch(const MatX3d& V, const MatX3i& F, const MatX2d& UV, const StretchOptOptions& opt,
                                  const ProgressFn& progress_fn) {
  if (opt.iterations < 0) throw MeshError("stretch_iterations must be >= 0, got " + std::to_string(opt.iterations));
  if (!(opt.tolerance >= 0)) throw MeshError("stretch_tolerance must be >= 0");
  const int n = static_cast<int>(UV.rows()), nf = static_cast<int>(F.rows());
  if (UV.rows() != V.rows()) throw MeshError("minimize_stretch: UV must have one row per vertex");
  Progress progress(progress_fn);
  // DGMESH_UNWRAP_PROFILE=1 prints the CPU seconds of the phases (inside unwrap()'s profile if any).
  std::optional<ProfileScope> profile;
  if (!current_profile) profile.emplace("DGMESH_UNWRAP_PROFILE");
  StretchOptResult res;
  res.uv = UV;
  MatX2d U = UV;
  // Orientation: work on a counter-clockwise map (mirror v if the chart's total area is negative).
  double signed_area = 0;
  for (int f = 0; f < nf; ++f) signed_area += det2(corners(U, F, f));
  const double orient = signed_area >= 0 ? 1.0 : -1.0;
  if (orient < 0) U.col(1) *= -1;
  int bad = 0;
  for (int f = 0; f < nf; ++f)
    if (!(det2(corners(U, F, f)) > 0)) ++bad;
  if (bad)
    throw MeshError("minimize_stretch: the start map has " + std::to_string(bad) +
                    " flipped or zero-area triangles (it must be locally injective)");
  std::vector<Tri> tri(nf);
  const bool par = nf >= kParallelMin;
#pragma omp parallel for schedule(static) if (par)
  for (int f = 0; f < nf; ++f) tri[f] = make_tri(V.row(F(f, 0)), V.row(F(f, 1)), V.row(F(f, 2)));
  double area3 = 0;
  for (const Tri& t : tri) area3 += t.area;
  if (!(area3 > 0) || !std::isfinite(area3)) return res;  // nothing to measure (or overflow): the start

  // uv_metrics counts a UV triangle of area <= 1e-10 of the total as zero-area; an isometric map
  // would give a scan's sliver (3D area ~1e-10 of the total) such an area. The barrier keeps every
  // UV triangle above 1e-9 of the 3D area (the UV area is >= the 3D area at the optimal scale: P = Q
  // = A L2 >= A). Its weight makes it 1% of A at a = a0 / e.
  Barrier bar;
  bar.a0 = 1e-9 * area3;
  bar.k = 1e-2 * area3 / (bar.a0 * bar.a0);
  // P (UV area of the energetic triangles), Q and the barrier B; E = P + Q + B. All triangles must
  // stay positive.
  double B = 0;
  auto pq = [&](const MatX2d& W, double& P, double& Q) {
    P = 0, Q = 0, B = 0;
    bool ok = true;
    for (int f = 0; f < nf; ++f) {
      const Vec6 u = corners(W, F, f);
      const double a = 0.5 * det2(u);
      if (!(a > 0)) ok = false;
      B += bar.value(a);
      const Tri& t = tri[f];
      if (t.area == 0) continue;
      const Vec4 x = t.D * u;
      const double d = x[0] * x[3] - x[1] * x[2];
      if (!(d > 0)) {
        ok = false;
        continue;
      }
      P += t.area * d;
      Q += t.area * x.squaredNorm() / (2 * d * d);
    }
    return ok && std::isfinite(B);
  };
  auto l2_of = [&](double P, double Q) { return std::sqrt(P * Q) / area3; };
  // Optimal scale: P scales by s^2, Q by 1/s^2; P = Q at s^4 = Q / P (then the barrier again).
  auto rescale = [&](MatX2d& W, double& P, double& Q) {
    W *= std::sqrt(std::sqrt(Q / P));
    pq(W, P, Q);
  };
  double P, Q;
  if (!pq(U, P, Q)) throw MeshError("minimize_stretch: the start map is not locally injective");
  if (!std::isfinite(P * Q) || !(P * Q > 0)) return res;
  const Eigen::RowVector2d centre0 = 0.5 * (U.colwise().minCoeff() + U.colwise().maxCoeff());
  rescale(U, P, Q);
  res.l2_before = res.l2_after = l2_of(P, Q);
  if (opt.iterations == 0) return res;
  double E = P + Q + B;

  // Sparsity pattern (2x2 blocks per vertex pair of a triangle), interleaved unknowns 2 v + r.
  SpMat H(2 * n, 2 * n);
  std::vector<int> slot(static_cast<size_t>(nf) * 36);
  {
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(static_cast<size_t>(nf) * 36 + 2 * n);
    for (int f = 0; f < nf; ++f)
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) trip.emplace_back(2 * F(f, a / 2) + a % 2, 2 * F(f, b / 2) + b % 2, 0.0);
    for (int i = 0; i < 2 * n; ++i) trip.emplace_back(i, i, 0.0);
    H.setFromTriplets(trip.begin(), trip.end());
    H.makeCompressed();
    const int* outer = H.outerIndexPtr();
    const int* inner = H.innerIndexPtr();
    auto find = [&](int r, int c) {
      const int* lo = inner + outer[c];
      const int* hi = inner + outer[c + 1];
      return static_cast<int>(std::lower_bound(lo, hi, r) - inner);
    };
#pragma omp parallel for schedule(static) if (par)
    for (int f = 0; f < nf; ++f)
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) slot[36 * f + 6 * a + b] = find(2 * F(f, a / 2) + a % 2, 2 * F(f, b / 2) + b % 2);
  }
  std::vector<int> diag(2 * n);
  for (int i = 0; i < 2 * n; ++i) {
    const int* lo = H.innerIndexPtr() + H.outerIndexPtr()[i];
    const int* hi = H.innerIndexPtr() + H.outerIndexPtr()[i + 1];
    diag[i] = static_cast<int>(std::lower_bound(lo, hi, i) - H.innerIndexPtr());
  }

  SparseSolver solver;
  bool factored = false;
  std::vector<Mat6> Hloc(nf);
  std::vector<Vec6> gloc(nf);
  Eigen::VectorXd grad(2 * n);
  res.stopped = "iterations";
  for (int it = 0; it < opt.iterations; ++it) {
    progress(static_cast<double>(it) / opt.iterations);
#pragma omp parallel for schedule(static) if (par)
    for (int f = 0; f < nf; ++f) {
      const Tri& t = tri[f];
      const Vec6 u = corners(U, F, f);
      Hloc[f].setZero();
      gloc[f].setZero();
      if (t.area > 0) {
        const Vec4 x = t.D * u;
        Vec4 gj;
        Mat4 Hj;
        derivs_j(x, gj, Hj);
        Eigen::SelfAdjointEigenSolver<Mat4> es(Hj);
        const Vec4 lam = es.eigenvalues().cwiseMax(0.0);
        const Mat4 Hp = es.eigenvectors() * lam.asDiagonal() * es.eigenvectors().transpose();
        Hloc[f] = t.area * t.D.transpose() * Hp * t.D;
        gloc[f] = t.area * t.D.transpose() * gj;
      }
      double b1, b2;
      bar.derivs(0.5 * det2(u), b1, b2);
      if (b1 != 0 || b2 != 0) {
        // b'' grad(a) grad(a)^T is positive semi-definite; the b' Hess(a) part (indefinite) is left out.
        const Vec6 ga = area_grad(u);
        gloc[f] += b1 * ga;
        Hloc[f] += b2 * ga * ga.transpose();
      }
    }
    profile_mark("sopt:local");
    std::fill(H.valuePtr(), H.valuePtr() + H.nonZeros(), 0.0);
    grad.setZero();
    double* val = H.valuePtr();
    for (int f = 0; f < nf; ++f) {
      for (int a = 0; a < 6; ++a) {
        grad[2 * F(f, a / 2) + a % 2] += gloc[f][a];
        for (int b = 0; b < 6; ++b) val[slot[36 * f + 6 * a + b]] += Hloc[f](a, b);
      }
    }
    // Translations (and, at a critical point, rotations) are null directions: a small
    // Levenberg-Marquardt shift relative to the mean diagonal keeps the system definite.
    double tr = 0;
    for (int i = 0; i < 2 * n; ++i) tr += val[diag[i]];
    const double shift = 1e-8 * tr / (2 * n) + 1e-300;
    for (int i = 0; i < 2 * n; ++i) val[diag[i]] += shift;
    profile_mark("sopt:assemble");
    if (!factored) {
      solver.factor(H, SparseSolver::Kind::Supernodal);
      factored = true;
    } else {
      solver.refactor(H);
    }
    profile_mark("sopt:factor");
    const Eigen::VectorXd step = -solver.solve(grad);
    profile_mark("sopt:solve");
    const double slope = grad.dot(step);
    if (!(slope < 0) || !step.allFinite()) {
      res.stopped = "no descent";
      break;
    }
    // Largest step keeping every UV triangle positive (Smith & Schaefer 2015), times 0.8.
    double tmax = kInf;
#pragma omp parallel for schedule(static) reduction(min : tmax) if (par)
    for (int f = 0; f < nf; ++f) {
      Vec6 du;
      for (int j = 0; j < 3; ++j) du.segment<2>(2 * j) = step.segment<2>(2 * F(f, j));
      tmax = std::min(tmax, first_root(corners(U, F, f), du));
    }
    double alpha = std::min(1.0, 0.8 * tmax);
    MatX2d Un(n, 2);
    double Pn = 0, Qn = 0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls) {
      for (int v = 0; v < n; ++v) Un.row(v) = U.row(v) + alpha * step.segment<2>(2 * v).transpose();
      if (pq(Un, Pn, Qn) && Pn + Qn + B <= E + 1e-4 * alpha * slope) {
        accepted = true;
        break;
      }
      alpha *= 0.5;
    }
    if (!accepted) {
      res.stopped = "no descent";
      break;
    }
    rescale(Un, Pn, Qn);
    profile_mark("sopt:linesearch");
    E = Pn + Qn + B;
    U.swap(Un);
    const double l2 = l2_of(Pn, Qn);
    const double rel = (res.l2_after - l2) / res.l2_after;
    ++res.iterations;
    res.l2_after = l2;
    if (rel < opt.tolerance) {
      res.stopped = "converged";
      break;
    }
  }
  // Back to the start's orientation, its bounding-box centre and size (the caller's frame).
  const Eigen::RowVector2d lo = U.colwise().minCoeff(), hi = U.colwise().maxCoeff();
  const Eigen::RowVector2d lo0 = UV.colwise().minCoeff(), hi0 = UV.colwise().maxCoeff();
  const double s = std::max(hi0.x() - lo0.x(), hi0.y() - lo0.y()) / std::max(hi.x() - lo.x(), hi.y() - lo.y());
  const Eigen::RowVector2d c = 0.5 * (lo + hi);
  for (int v = 0; v < n; ++v) U.row(v) = (U.row(v) - c) * s + centre0;
  if (orient < 0) U.col(1) *= -1;
  res.uv = U;
  progress(1.0);
  return res;
}

}  // namespace dgmesh::detail
