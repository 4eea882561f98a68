#include "dgmesh/crest_lines.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <string>
#include <utility>

#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"

namespace dgmesh {

namespace {

// Unit vector orthogonal to n.
inline Vec3 any_perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.6 ? Vec3::UnitX() : (std::abs(n.y()) < 0.6 ? Vec3::UnitY() : Vec3::UnitZ());
  return (a - a.dot(n) * n).normalized();
}

// Third directional derivative of the cubic part of eq. 4.7 along (t1, t2): with the binomial
// factors of the 1/6 (c0 x^3 + 3 c1 x^2 y + 3 c2 x y^2 + c3 y^3) term. (Eq. 4.8 as printed writes the
// same cubic form as a matrix product; this is its expanded value.)
inline double cubic_form(const double* c, double t1, double t2) {
  return c[0] * t1 * t1 * t1 + 3 * c[1] * t1 * t1 * t2 + 3 * c[2] * t1 * t2 * t2 + c[3] * t2 * t2 * t2;
}

// A += r r^T, b += r z with r padded to 10: a fixed-size outer product vectorises fully (Eigen's
// rankUpdate on a self-adjoint view dominated the fit's profile).
using Mat10 = Eigen::Matrix<double, 10, 10>;
using Vec10 = Eigen::Matrix<double, 10, 1>;
using Mat9 = Eigen::Matrix<double, 9, 9>;
using Vec9 = Eigen::Matrix<double, 9, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
inline void accumulate(Mat10& A, Vec10& b, const Vec10& r, double z) {
  A.noalias() += r * r.transpose();
  b.noalias() += r * z;
}

struct FitScratch {
  std::vector<int> ring, mark;
};

// In-place Cholesky factorisation A = L L^T of a small positive definite matrix (its lower triangle read, L written
// there): plain loops, which for these sizes beat Eigen's LLT (whose column updates go through general matrix-vector
// products). False when A is not numerically positive definite.
template <int M>
bool cholesky(Eigen::Matrix<double, M, M>& A) {
  for (int j = 0; j < M; ++j) {
    double d = A(j, j);
    for (int k = 0; k < j; ++k) d -= A(j, k) * A(j, k);
    if (!(d > 0.0)) return false;
    d = std::sqrt(d);
    A(j, j) = d;
    for (int i = j + 1; i < M; ++i) {
      double v = A(i, j);
      for (int k = 0; k < j; ++k) v -= A(i, k) * A(j, k);
      A(i, j) = v / d;
    }
  }
  return true;
}

// x with L L^T x = b, L from cholesky().
template <int M>
Eigen::Matrix<double, M, 1> cholesky_solve(const Eigen::Matrix<double, M, M>& L, Eigen::Matrix<double, M, 1> x) {
  for (int i = 0; i < M; ++i) {
    for (int k = 0; k < i; ++k) x[i] -= L(i, k) * x[k];
    x[i] /= L(i, i);
  }
  for (int i = M - 1; i >= 0; --i) {
    for (int k = i + 1; k < M; ++k) x[i] -= L(k, i) * x[k];
    x[i] /= L(i, i);
  }
  return x;
}

// The fields of a vertex without a fit (no normal, too few neighbours): zero curvature and
// derivatives, no directions, its normal n.
void write_no_fit(int i, const Vec3& n, CurvatureDerivatives& out) {
  out.k_max[i] = out.k_min[i] = out.e_max[i] = out.e_min[i] = 0.0;
  out.t_max.row(i).setZero();
  out.t_min.row(i).setZero();
  out.normals.row(i) = n.transpose();
}

// Curvature attributes of the graph z = h(x, y) over the frame (u, w, n) at a point where h has
// gradient (hx, hy), Hessian (hxx, hxy, hyy) and third derivatives cc (h_xxx, h_xxy, h_xyy, h_yyy),
// all in units of 1 / scale; written to vertex i in mesh units.
void write_fields(int i, double hx, double hy, double hxx, double hxy, double hyy, const double* cc, const Vec3& u,
                  const Vec3& w, const Vec3& n, double scale, CurvatureDerivatives& out) {
  // Graph frame (x, y, z along u, w, n): unit normal nn of z = h, tangent basis e1, e2.
  const double G = std::sqrt(1.0 + hx * hx + hy * hy);
  const Vec3 nn(-hx / G, -hy / G, 1.0 / G);
  const Vec3 e1 = Vec3(1.0, 0.0, hx) / std::sqrt(1.0 + hx * hx);
  const Vec3 e2 = nn.cross(e1);
  // Shape operator of the implicit surface z - h = 0 on (e1, e2): P Hess(z - h) P / |grad|; at
  // the origin it is minus the Hessian of h, so curvature is positive where the surface bends
  // away from n (positive on a sphere with outward faces).
  auto hess = [&](const Vec3& a, const Vec3& q) {  // a^T Hess(h) q over the (x, y) components
    return a.x() * (hxx * q.x() + hxy * q.y()) + a.y() * (hxy * q.x() + hyy * q.y());
  };
  const double s00 = -hess(e1, e1) / G, s01 = -hess(e1, e2) / G, s11 = -hess(e2, e2) / G;
  const double mean = 0.5 * (s00 + s11), dev = std::hypot(0.5 * (s00 - s11), s01);
  const double theta = 0.5 * std::atan2(2 * s01, s00 - s11);  // eigenvector of the larger eigenvalue
  const double c1 = std::cos(theta), s1 = std::sin(theta);
  const Vec3 tmax = c1 * e1 + s1 * e2, tmin = -s1 * e1 + c1 * e2;
  const double kmax = mean + dev, kmin = mean - dev;
  // Extremality coefficient e = dk/dt of the implicit surface F = z - h (thesis eq. 4.9, with the
  // sign of the curvature term for this curvature convention, checked against finite differences
  // of k along t): e = (F_ijl t_i t_j t_l - 3 k F_ij t_i n_j) / |grad F|. At the origin it is eq.
  // 4.8: e = -h_ttt.
  auto extremality = [&](const Vec3& t, double k) {
    return (-cubic_form(cc, t.x(), t.y()) + 3.0 * k * hess(t, nn)) / G;
  };
  auto to_mesh = [&](const Vec3& a) { return (a.x() * u + a.y() * w + a.z() * n).transpose(); };
  // Back to mesh units: curvature scales by s, its derivative by s^2.
  out.k_max[i] = kmax * scale;
  out.k_min[i] = kmin * scale;
  out.e_max[i] = extremality(tmax, kmax) * scale * scale;
  out.e_min[i] = extremality(tmin, kmin) * scale * scale;
  out.t_max.row(i) = to_mesh(tmax);
  out.t_min.row(i) = to_mesh(tmin);
  out.normals.row(i) = to_mesh(nn);
}

// Fits eq. 4.7 at vertex i of (P, N) (M' and its Max normals) and writes the curvature attributes
// of the original vertex i (position V.row(i)).
//
// Unknowns (in units of the mean neighbour distance): the gradient (a0, a1), the Hessian (b0, b1,
// b2) and the cubic (c0..c3) of the height h over the tangent plane of n(p'). Rows per neighbour:
// its height (h = z) and, with normals, the slopes of its normal (h_x = -m_x/m_z, h_y = -m_y/m_z)
// [GI04]. With fit_tangent_plane the normal of p' itself is two more slope rows (h_x = h_y = 0 at
// the origin) instead of a constraint, otherwise the gradient is pinned to zero (eq. 4.7 as
// printed). The fields are the exact ones of the fitted graph at the evaluation point.
void fit_vertex(int i, const MatX3d& V, const MatX3d& P, const MatX3d& N, const Topology& topo,
                const DerivativeOptions& opt, FitScratch& s, CurvatureDerivatives& out) {
  const Vec3 n = N.row(i);
  if (n.squaredNorm() == 0.0) return write_no_fit(i, n, out);
  const Vec3 u = any_perpendicular(n), w = n.cross(u);
  const Vec3 p = P.row(i);

  k_ring(topo, i, opt.rings, s.ring, s.mark);
  // Neighbours whose normals make an obtuse angle with n(p') are dropped (thesis 4.5).
  double mean_dist = 0.0;
  int count = 0;
  for (size_t j = 1; j < s.ring.size(); ++j) {
    const int v = s.ring[j];
    if (N.row(v).dot(n) <= 0.0) continue;
    mean_dist += (Vec3(P.row(v)) - p).norm();
    ++count;
  }
  if (count < 2 || mean_dist <= 0.0) return write_no_fit(i, n, out);
  const double scale = count / mean_dist;  // fit in units of the mean neighbour distance
  // The tangent plane adds two unknowns: fit it only with at least five neighbours (17 equations for
  // 9 unknowns). On valence-4 vertices (square grids with alternating diagonals) the free gradient
  // measurably raised the errors of table 4.1 (bench/workloads/crest.py), so they keep eq. 4.7.
  const bool tangent = opt.use_normals && opt.fit_tangent_plane && count >= 5;

  // Both slope rows of a neighbour are the same monomials q = (1, x, y, x^2/2, xy, y^2/2) placed at
  // two index sets (h_x: a0, b0, b1, c0, c1, c2; h_y: a1, b1, b2, c1, c2, c3), so their normal
  // equations are one 6x6 sum of q q^T scattered twice after the loop.
  Mat10 A10 = Mat10::Zero();
  Vec10 b10 = Vec10::Zero();
  Mat6 Q = Mat6::Zero();
  Vec6 qa = Vec6::Zero(), qb = Vec6::Zero();
  for (size_t j = 1; j < s.ring.size(); ++j) {
    const int v = s.ring[j];
    const Vec3 m = N.row(v);
    if (m.dot(n) <= 0.0) continue;
    const Vec3 d = (Vec3(P.row(v)) - p) * scale;
    const double x = d.dot(u), y = d.dot(w), z = d.dot(n);
    const double xx = 0.5 * x * x, xy = x * y, yy = 0.5 * y * y;
    // Position: h(x, y) = z.
    Vec10 r;
    r << (tangent ? x : 0.0), (tangent ? y : 0.0), xx, xy, yy, x * xx / 3, xx * y, x * yy, y * yy / 3, 0;
    accumulate(A10, b10, r, z);
    if (opt.use_normals) {
      // Normal (a, b, c) of the graph z = h(x, y) is parallel to (-h_x, -h_y, 1) [GI04].
      const double ma = m.dot(u), mb = m.dot(w), mc = m.dot(n);
      Vec6 q;
      q << (tangent ? 1.0 : 0.0), x, y, xx, xy, yy;
      Q.noalias() += q * q.transpose();
      qa.noalias() += q * (-ma / mc);
      qb.noalias() += q * (-mb / mc);
    }
  }
  Mat9 A = A10.topLeftCorner<9, 9>();
  Vec9 b = b10.head<9>();
  if (opt.use_normals) {
    static constexpr int ix[6] = {0, 2, 3, 5, 6, 7}, iy[6] = {1, 3, 4, 6, 7, 8};
    for (int k = 0; k < 6; ++k) {
      b[ix[k]] += qa[k];
      b[iy[k]] += qb[k];
      for (int l = 0; l < 6; ++l) {
        A(ix[k], ix[l]) += Q(k, l);
        A(iy[k], iy[l]) += Q(k, l);
      }
    }
  }
  // The normal of p' (slopes 0 at the origin) as two rows of weight 1; when the tangent plane is
  // not fitted the gradient rows are empty and this pins a0 = a1 = 0.
  A(0, 0) += 1.0;
  A(1, 1) += 1.0;
  // A tiny ridge keeps under-determined fits (boundary corners, valence-3 vertices) finite.
  A.diagonal().array() += 1e-9 * (A.trace() + 1.0);
  Mat9 L = A;
  if (!cholesky(L)) return write_no_fit(i, n, out);
  const Vec9 c = cholesky_solve(L, b);
  if (!c.allFinite()) return write_no_fit(i, n, out);
  const double cc[4] = {c[5], c[6], c[7], c[8]};

  // Evaluation point: p' (the origin) or the foot of the original vertex on the tangent plane.
  double dx = 0.0, dy = 0.0;
  if (opt.smooth && opt.transport_to_vertex) {
    const Vec3 d = (Vec3(V.row(i)) - p) * scale;
    dx = d.dot(u), dy = d.dot(w);
  }
  const double hx = c[0] + c[2] * dx + c[3] * dy + 0.5 * cc[0] * dx * dx + cc[1] * dx * dy + 0.5 * cc[2] * dy * dy;
  const double hy = c[1] + c[3] * dx + c[4] * dy + 0.5 * cc[1] * dx * dx + cc[2] * dx * dy + 0.5 * cc[3] * dy * dy;
  const double hxx = c[2] + cc[0] * dx + cc[1] * dy, hxy = c[3] + cc[1] * dx + cc[2] * dy;
  const double hyy = c[4] + cc[2] * dx + cc[3] * dy;
  write_fields(i, hx, hy, hxx, hxy, hyy, cc, u, w, n, scale, out);
}

// --- Two-pass jet fit (the default) -----------------------------------------------------------------
//
// Least squares of a polynomial height h(x, y) = sum_{1 <= a+b <= degree} c_ab x^a y^b / (a! b!)
// over the tangent plane of a frame normal n at the vertex p itself (no p -> p' smoothing), in units
// of the mean neighbour distance. The constant term is 0 (h passes through p), the linear terms are
// free, so the frame only has to be near the tangent plane.

// Number of coefficients of a jet of the given degree without constant term.
inline int jet_size(int degree) { return (degree + 1) * (degree + 2) / 2 - 1; }

// Monomials x^a y^b / (a! b!), 1 <= a + b <= degree, ordered by total degree then by falling a
// (so c[0..1] is the gradient, c[2..4] the Hessian, c[5..8] the third derivatives). `dx` / `dy`
// fill the partial derivatives instead (those of degree-0 monomials being 0).
void jet_row(double x, double y, int degree, int deriv, double* r) {
  // pw[a] = x^a / a!, qw[b] = y^b / b!
  double pw[8], qw[8];
  pw[0] = qw[0] = 1.0;
  for (int a = 1; a <= degree; ++a) pw[a] = pw[a - 1] * x / a, qw[a] = qw[a - 1] * y / a;
  int k = 0;
  for (int t = 1; t <= degree; ++t)
    for (int a = t; a >= 0; --a) {
      const int b = t - a;
      if (deriv == 0)
        r[k++] = pw[a] * qw[b];
      else if (deriv == 1)
        r[k++] = a > 0 ? pw[a - 1] * qw[b] : 0.0;
      else
        r[k++] = b > 0 ? pw[a] * qw[b - 1] : 0.0;
    }
}

using Vec20 = Eigen::Matrix<double, 20, 1>;
using Mat4 = Eigen::Matrix<double, 4, 4>;

struct JetScratch {
  std::vector<int> ring, mark;
  Vec20 c;    // coefficients of the last fit (the first jet_size(degree))
  Mat4 cov3;  // with `error`: covariance of the third derivatives c[5..8] (scaled units)
};

// Exponents (a, b) and 1 / (a! b!) of the jet's monomials of degree D, in jet_row's order.
template <int D>
struct Monomials {
  static constexpr int M = (D + 1) * (D + 2) / 2 - 1;
  int a[M], b[M];
  double f[M];
  Monomials() {
    for (int t = 1, k = 0; t <= D; ++t)
      for (int e = t; e >= 0; --e, ++k) {
        a[k] = e, b[k] = t - e, f[k] = 1.0;
        for (int i = 2; i <= e; ++i) f[k] /= i;
        for (int i = 2; i <= t - e; ++i) f[k] /= i;
      }
  }
};

// Normal equations of the jet fit of degree D over the neighbours listed in s.ring (skipping the
// vertex itself and those whose normal makes an obtuse angle with n). Every entry of the normal equations is a moment
// of the neighbours' tangent coordinates: monomial k is m_k = x^a y^b / (a! b!), so a height row gives m_k m_l =
// x^(a+a') y^(b+b') / (a! b! a'! b'!) and a slope row d/dx the same with a a' x^(a+a'-2) (d/dy: b b' y^(b+b'-2)). The
// moments sum x^i y^j (i + j <= 2D) and those weighted by the right-hand sides are summed once per neighbour, then A is
// filled from them: (2D+1)(2D+2)/2 products a neighbour instead of (1 or 3) M^2. With `error`, also the covariance of
// the third-derivative coefficients, sigma^2 (A^-1)[5..8] with sigma^2 the residual variance per degree of freedom (0
// without spare equations).
template <int D>
bool solve_jet(const MatX3d& V, const MatX3d& N, const Vec3& p, const Vec3& n, const Vec3& u, const Vec3& w,
               double scale, bool slopes, bool error, JetScratch& s) {
  constexpr int M = (D + 1) * (D + 2) / 2 - 1;
  using MatM = Eigen::Matrix<double, M, M>;
  using VecM = Eigen::Matrix<double, M, 1>;
  double mom[2 * D + 1][2 * D + 1] = {}, hz[D + 1][D + 1] = {}, hx[D + 1][D + 1] = {}, hy[D + 1][D + 1] = {};
  double zz = 0.0;
  int rows = 0;
  for (size_t j = 1; j < s.ring.size(); ++j) {
    const int v = s.ring[j];
    const Vec3 nv = N.row(v);
    if (nv.dot(n) <= 0.0) continue;
    const Vec3 d = (Vec3(V.row(v)) - p) * scale;
    const double x = d.dot(u), y = d.dot(w), z = d.dot(n);
    double xp[2 * D + 1], yp[2 * D + 1];
    xp[0] = yp[0] = 1.0;
    for (int i = 1; i <= 2 * D; ++i) xp[i] = xp[i - 1] * x, yp[i] = yp[i - 1] * y;
    for (int i = 0; i <= 2 * D; ++i)
      for (int k = 0; k <= 2 * D - i; ++k) mom[i][k] += xp[i] * yp[k];
    for (int i = 0; i <= D; ++i)
      for (int k = 0; k <= D - i; ++k) hz[i][k] += z * xp[i] * yp[k];
    zz += z * z;
    ++rows;
    if (slopes) {
      const double mc = nv.dot(n), sx = -nv.dot(u) / mc, sy = -nv.dot(w) / mc;
      for (int i = 0; i < D; ++i)
        for (int k = 0; k < D - i; ++k) hx[i][k] += sx * xp[i] * yp[k], hy[i][k] += sy * xp[i] * yp[k];
      zz += sx * sx + sy * sy;
      rows += 2;
    }
  }
  static const Monomials<D> mono;
  const int *ea = mono.a, *eb = mono.b;
  const double* f = mono.f;
  MatM A;
  VecM b;
  for (int k = 0; k < M; ++k) {
    for (int l = 0; l < M; ++l) {
      const int a = ea[k] + ea[l], c = eb[k] + eb[l];
      double m = mom[a][c];
      if (slopes) {
        if (ea[k] > 0 && ea[l] > 0) m += ea[k] * ea[l] * mom[a - 2][c];
        if (eb[k] > 0 && eb[l] > 0) m += eb[k] * eb[l] * mom[a][c - 2];
      }
      A(k, l) = f[k] * f[l] * m;
    }
    double r = hz[ea[k]][eb[k]];
    if (slopes) {
      if (ea[k] > 0) r += ea[k] * hx[ea[k] - 1][eb[k]];
      if (eb[k] > 0) r += eb[k] * hy[ea[k]][eb[k] - 1];
    }
    b[k] = f[k] * r;
  }
  if (slopes) A(0, 0) += 1.0, A(1, 1) += 1.0, rows += 2;  // n itself: h_x = h_y = 0 at p
  A.diagonal().array() += 1e-9 * (A.trace() + 1.0);
  MatM L = A;
  if (!cholesky(L)) return false;
  const VecM c = cholesky_solve(L, b);
  s.c.head<M>() = c;
  if constexpr (D >= 3) {
    if (!error) return c.allFinite();
    // Residual sum of squares from the normal equations: |A c - z|^2 = zz - 2 c.b + c.A c.
    const double rss = std::max(0.0, zz - 2.0 * c.dot(b) + c.dot(A * c));
    const double sigma2 = rows > M ? rss / (rows - M) : 0.0;
    if constexpr (M == 9) {
      // The cubic's third derivatives are its last four coefficients: with A = L L^T, the trailing block of A^-1 is
      // (L22 L22^T)^-1, L22 the trailing 4 x 4 block of L.
      const Mat4 L22 = L.template bottomRightCorner<4, 4>().template triangularView<Eigen::Lower>();
      const Mat4 Li = L22.inverse();
      s.cov3 = sigma2 * Li.transpose() * Li;
    } else {
      for (int k = 0; k < 4; ++k) {  // column by column: fixed-size vector solves, not a general matrix solve
        VecM e = VecM::Zero();
        e[5 + k] = 1.0;
        s.cov3.col(k) = sigma2 * cholesky_solve(L, e).template segment<4>(5);
      }
    }
  }
  return c.allFinite();
}

// Fits the jet at vertex i over its `rings`-ring (neighbours whose normal in N makes an obtuse angle
// with n dropped): heights, and with `slopes` the slopes of the neighbours' normals N (h_x = -m_x /
// m_z, h_y = -m_y / m_z) and of n at p (h_x = h_y = 0). Returns false when too few neighbours are
// left for even a quadratic. `degree` (3, 4 or 5) is lowered, to 3 then 2, when the rows do not
// determine it: a quartic needs two spare equations, the others 1.5 equations per unknown (a square
// fit interpolates and amplifies errors). On success s.c holds the coefficients
// (scaled units, s.cov3 their error with `error`) and u, w, scale the frame.
bool fit_jet(int i, const MatX3d& V, const MatX3d& N, const Vec3& n, const Topology& topo, int rings, int degree,
             bool slopes, bool error, JetScratch& s, Vec3& u, Vec3& w, double& scale, int& used_degree) {
  u = any_perpendicular(n), w = n.cross(u);
  const Vec3 p = V.row(i);
  k_ring(topo, i, rings, s.ring, s.mark);
  double mean_dist = 0.0;
  int count = 0;
  for (size_t j = 1; j < s.ring.size(); ++j) {
    const int v = s.ring[j];
    if (N.row(v).dot(n) <= 0.0) continue;
    mean_dist += (Vec3(V.row(v)) - p).norm();
    ++count;
  }
  if (count < 2 || mean_dist <= 0.0) return false;
  scale = count / mean_dist;
  const int rows = (slopes ? 3 : 1) * count + (slopes ? 2 : 0);
  if (degree == 5 && 2 * rows < 3 * jet_size(5)) degree = 3;
  if (degree == 4 && rows < jet_size(4) + 2) degree = 3;
  if (degree == 3 && 2 * rows < 3 * jet_size(3)) degree = 2;
  if (rows < jet_size(degree)) return false;
  used_degree = degree;
  if (degree == 5) return solve_jet<5>(V, N, p, n, u, w, scale, slopes, error, s);
  if (degree == 4) return solve_jet<4>(V, N, p, n, u, w, scale, slopes, error, s);
  if (degree == 3) return solve_jet<3>(V, N, p, n, u, w, scale, slopes, error, s);
  return solve_jet<2>(V, N, p, n, u, w, scale, slopes, error, s);
}

// Pass 1: the normal of a jet fitted to the heights of the 2-ring over the Max normal's tangent plane:
// a cubic (as CGAL's Monge_via_jet_fitting with d = 3) or a quartic (18 points on a closed valence-6
// mesh; a cubic where fewer than 16). The quartic removes the fourth-order terms that leak into the
// gradient on an irregular neighbourhood, which the one-ring fit of pass 2 differentiates twice more
// (jittered meshes: bench/notes/crest_derivatives.md); on regular lattices, where they cancel, the
// cubic is more accurate, and wider pass-2 fits average the normals' errors out. Falls back to the
// Max normal where the fit is not determined.
Vec3 jet_normal(int i, const MatX3d& V, const MatX3d& Nmax, const Topology& topo, int pass1_degree, JetScratch& s) {
  const Vec3 n = Nmax.row(i);
  if (n.squaredNorm() == 0.0) return n;
  Vec3 u, w;
  double scale;
  int degree;
  if (!fit_jet(i, V, Nmax, n, topo, 2, pass1_degree, false, false, s, u, w, scale, degree)) return n;
  const Vec3 g = -s.c[0] * u - s.c[1] * w + n;
  return g.normalized();
}

// Pass 2 at vertex i: heights and the pass-1 normals N of the k-ring, degree 3 on the one-ring and
// 5 on larger rings (a cubic over a wider neighbourhood is biased by the surface's fifth-order
// terms, bench/notes/crest_derivatives.md). A one-ring of fewer than six vertices (valence-4 vertices
// of square grids) does not determine the cubic's mixed terms well: there the 2-ring's quintic is
// fitted. Writes the fields of vertex i and the standard errors of its e_max, e_min (from the
// covariance of the third derivatives; the curvature term of eq. 4.9 is taken as exact).
void fit_vertex_jet(int i, const MatX3d& V, const MatX3d& N, const Topology& topo, const DerivativeOptions& opt,
                    JetScratch& s, CurvatureDerivatives& out) {
  out.e_max_error[i] = out.e_min_error[i] = 0.0;
  const Vec3 n = N.row(i);
  if (n.squaredNorm() == 0.0) return write_no_fit(i, n, out);
  int rings = opt.rings;
  if (rings == 1 && topo.valence(i) < 6) rings = 2;
  Vec3 u, w;
  double scale;
  int degree;
  if (!fit_jet(i, V, N, n, topo, rings, rings == 1 ? 3 : 5, true, true, s, u, w, scale, degree))
    return write_no_fit(i, n, out);
  const Vec20& c = s.c;
  double cc[4] = {0.0, 0.0, 0.0, 0.0};
  if (degree >= 3)
    for (int k = 0; k < 4; ++k) cc[k] = c[5 + k];
  write_fields(i, c[0], c[1], c[2], c[3], c[4], cc, u, w, n, scale, out);
  if (degree < 3) return;
  // e = -cubic_form(c, t) / G + ...: its gradient in c[5..8] along the principal direction t (in the frame).
  auto error = [&](const Vec3& t) {
    const double t1 = t.dot(u), t2 = t.dot(w);
    const Eigen::Vector4d g(t1 * t1 * t1, 3 * t1 * t1 * t2, 3 * t1 * t2 * t2, t2 * t2 * t2);
    return std::sqrt(std::max(0.0, g.dot(s.cov3 * g))) * scale * scale;
  };
  out.e_max_error[i] = error(out.t_max.row(i));
  out.e_min_error[i] = error(out.t_min.row(i));
}

// Noise test of the jet fit (DerivativeOptions::noise_adaptive): on at most kSamples vertices spread evenly by
// index, a cubic and a quartic jet fitted to the heights of the 2-ring over the Max normal's tangent plane (units of
// the mean neighbour distance, as pass 1); returns sqrt(median v4 / median v3) of their residual variances per degree
// of freedom over the samples where the cubic does not fit to round-off; 0 when fewer than 16 such samples have the
// 16 neighbours a quartic needs (dof >= 2). Truncation error falls with the degree, noise does not.
double jet_noise_ratio(const Mesh& mesh, const MatX3d& Nmax) {
  constexpr int kSamples = 2048;
  constexpr double kExactFit = 1e-20;  // residual variance in units of the mean neighbour distance squared
  const int nv = mesh.topo.n_vertices;
  const int stride = std::max(1, nv / kSamples);
  const int samples = (nv + stride - 1) / stride;
  std::vector<double> var3(samples, -1.0), var4(samples, -1.0);  // -1: no estimate at this sample
#pragma omp parallel
  {
    std::vector<int> ring, mark;
    Eigen::MatrixXd A;
    Eigen::VectorXd z;
#pragma omp for schedule(dynamic, 64)
    for (int si = 0; si < samples; ++si) {
      const int i = si * stride;
      const Vec3 n = Nmax.row(i);
      if (n.squaredNorm() == 0.0) continue;
      const Vec3 u = any_perpendicular(n), w = n.cross(u), p = mesh.V.row(i);
      k_ring(mesh.topo, i, 2, ring, mark);
      int count = 0;
      double mean_dist = 0.0;
      for (size_t j = 1; j < ring.size(); ++j)
        if (Nmax.row(ring[j]).dot(n) > 0.0) mean_dist += (Vec3(mesh.V.row(ring[j])) - p).norm(), ++count;
      if (count < jet_size(4) + 2 || mean_dist <= 0.0) continue;
      const double scale = count / mean_dist;
      A.resize(count, jet_size(4));
      z.resize(count);
      for (size_t j = 1, r = 0; j < ring.size(); ++j) {
        const int v = ring[j];
        if (Nmax.row(v).dot(n) <= 0.0) continue;
        const Vec3 d = (Vec3(mesh.V.row(v)) - p) * scale;
        double row[20];
        jet_row(d.dot(u), d.dot(w), 4, 0, row);
        for (int k = 0; k < jet_size(4); ++k) A(r, k) = row[k];
        z[r++] = d.dot(n);
      }
      // The quartic's monomials extend the cubic's (same order), so the cubic is the first jet_size(3) columns.
      double var[2];
      for (int degree : {3, 4}) {
        const int m = jet_size(degree);
        const auto Ad = A.leftCols(m);
        Eigen::MatrixXd M = Ad.transpose() * Ad;
        M.diagonal().array() += 1e-9 * (M.trace() + 1.0);
        const Eigen::VectorXd c = M.ldlt().solve(Ad.transpose() * z);
        var[degree - 3] = (Ad * c - z).squaredNorm() / (count - m);
      }
      // A cubic that fits to round-off (planar or quadric patches of exact meshes) says nothing about noise.
      if (!(var[0] > kExactFit)) continue;
      var3[si] = var[0], var4[si] = var[1];
    }
  }
  std::vector<double> v3, v4;
  for (int si = 0; si < samples; ++si)
    if (var3[si] >= 0.0) v3.push_back(var3[si]), v4.push_back(var4[si]);
  if (v3.size() < 16) return 0.0;
  auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  const double m3 = median(v3), m4 = median(v4);
  if (!(m3 > 0.0) || !std::isfinite(m3) || !std::isfinite(m4)) return 0.0;
  return std::sqrt(m4 / m3);
}

// Builds ordered polylines from segments; fills line_offset, line_points and segment_line.
void build_lines(CrestLines& cl) {
  const int np = static_cast<int>(cl.points.rows());
  const int ns = static_cast<int>(cl.segments.rows());
  std::vector<int> off(np + 1, 0), adj(2 * ns);
  for (int s = 0; s < ns; ++s) ++off[cl.segments(s, 0) + 1], ++off[cl.segments(s, 1) + 1];
  for (int i = 0; i < np; ++i) off[i + 1] += off[i];
  {
    std::vector<int> fill(off.begin(), off.end() - 1);
    for (int s = 0; s < ns; ++s) adj[fill[cl.segments(s, 0)]++] = s, adj[fill[cl.segments(s, 1)]++] = s;
  }
  cl.segment_line.assign(ns, -1);
  cl.line_offset.assign(1, 0);
  cl.line_points.clear();
  auto degree = [&](int p) { return off[p + 1] - off[p]; };
  auto walk = [&](int start, int seg) {
    const int line = static_cast<int>(cl.line_offset.size()) - 1;
    cl.line_points.push_back(start);
    int p = start;
    while (seg >= 0 && cl.segment_line[seg] < 0) {
      cl.segment_line[seg] = line;
      const int q = cl.segments(seg, 0) == p ? cl.segments(seg, 1) : cl.segments(seg, 0);
      cl.line_points.push_back(q);
      p = q;
      seg = -1;
      if (degree(p) == 2 && p != start)
        for (int j = off[p]; j < off[p + 1]; ++j)
          if (cl.segment_line[adj[j]] < 0) seg = adj[j];
    }
    cl.line_offset.push_back(static_cast<int>(cl.line_points.size()));
  };
  // Open lines run between points of degree != 2 (ends and junctions); what remains are cycles.
  for (int p = 0; p < np; ++p)
    if (degree(p) != 2)
      for (int j = off[p]; j < off[p + 1]; ++j)
        if (cl.segment_line[adj[j]] < 0) walk(p, adj[j]);
  for (int s = 0; s < ns; ++s)
    if (cl.segment_line[s] < 0) walk(cl.segments(s, 0), s);
}

// Kind of a line = kind of its first point's crossing (stored per point while tracing).
void line_measures(CrestLines& cl, const std::vector<int>& point_kind) {
  const int nl = static_cast<int>(cl.line_offset.size()) - 1;
  cl.line_kind.resize(nl);
  cl.line_strength.resize(nl);
  cl.line_length.resize(nl);
  for (int l = 0; l < nl; ++l) {
    double len = 0.0, integral = 0.0;
    for (int j = cl.line_offset[l]; j + 1 < cl.line_offset[l + 1]; ++j) {
      const int a = cl.line_points[j], b = cl.line_points[j + 1];
      const double ds = (cl.points.row(a) - cl.points.row(b)).norm();
      len += ds;
      integral += 0.5 * ds * (cl.point_cyclideness[a] + cl.point_cyclideness[b]);  // trapezoid rule
    }
    cl.line_kind[l] = point_kind[cl.line_points[cl.line_offset[l]]];
    cl.line_length[l] = len;
    cl.line_strength[l] = len * integral;  // eq. 4.10
  }
}

// The thesis's fit (4.5, eq. 4.7) at the listed vertices: M' (p' = mean of the centroids of the faces around p) with
// its Max normals, then fit_vertex. Progress over the list when given.
void thesis_fit(const Mesh& mesh, const DerivativeOptions& opt, const std::vector<int>& vertices,
                CurvatureDerivatives& out, Progress* progress = nullptr) {
  const Topology& topo = mesh.topo;
  const int nv = topo.n_vertices;
  MatX3d P = mesh.V;
  if (opt.smooth) {
#pragma omp parallel for schedule(static)
    for (int v = 0; v < nv; ++v) {
      const int a = topo.vf_offset[v], b = topo.vf_offset[v + 1];
      if (a == b) continue;
      Vec3 sum = Vec3::Zero();
      for (int j = a; j < b; ++j) {
        const int f = topo.vf_index[j];
        sum += Vec3(mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2)));
      }
      P.row(v) = (sum / (3.0 * (b - a))).transpose();
    }
  }
  const MatX3d N = vertex_normals(P, mesh.F, topo, NormalWeights::Max);  // Max's normals on M'
  std::vector<FitScratch> scratch(std::max(1, omp_get_max_threads()));
  const int n = static_cast<int>(vertices.size()), chunk = 32768;
  for (int begin = 0; begin < n; begin += chunk) {
    const int end = std::min(n, begin + chunk);
#pragma omp parallel
    {
      FitScratch& s = scratch[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 256)
      for (int j = begin; j < end; ++j) fit_vertex(vertices[j], mesh.V, P, N, topo, opt, s, out);
    }
    if (progress) (*progress)(static_cast<double>(end) / n);
  }
}

// DerivativeOptions::plateaus: the vertices whose closed one-ring has, for the curvature of larger magnitude at each
// vertex, an extremality coefficient within kPlateauErrors standard errors of zero (or round-off): there k is constant
// to within the jet's own error and its zero crossings are noise. Grown by `margin` rings; sorted. Five standard
// errors, not three: on a blend five vertices wide (shapes.rounded_cube(24, 0.3)) the vertices beside the middle have
// |e| / se 2.5-3.8 and the rims 9.5-10, so at three no one-ring is flat (bench/notes/crest_derivatives.md).
constexpr double kPlateauErrors = 5.0;
std::vector<int> plateau_vertices(const Topology& topo, const CurvatureDerivatives& d, int margin) {
  const int nv = topo.n_vertices;
  std::vector<char> flat(nv);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < nv; ++v) {
    const bool use_max = std::abs(d.k_max[v]) >= std::abs(d.k_min[v]);
    const double e = use_max ? d.e_max[v] : d.e_min[v], err = use_max ? d.e_max_error[v] : d.e_min_error[v];
    const double k = use_max ? d.k_max[v] : d.k_min[v];
    flat[v] = std::abs(e) <= kPlateauErrors * err + 1e-9 * (std::abs(k) + 1.0) * (std::abs(k) + 1.0);
  }
  // Plateau cores: the whole closed one-ring flat.
  std::vector<char> in(nv, 0);
  std::vector<int> out;
  for (int v = 0; v < nv; ++v) {
    bool all = flat[v] && topo.valence(v) > 0;
    for (int j = topo.vv_offset[v]; all && j < topo.vv_offset[v + 1]; ++j) all = flat[topo.vv_index[j]];
    if (all) in[v] = 1, out.push_back(v);
  }
  // Grown by `margin` rings.
  size_t begin = 0;
  for (int r = 0; r < margin; ++r) {
    const size_t end = out.size();
    for (size_t i = begin; i < end; ++i)
      for (int j = topo.vv_offset[out[i]]; j < topo.vv_offset[out[i] + 1]; ++j)
        if (const int u = topo.vv_index[j]; !in[u]) in[u] = 1, out.push_back(u);
    begin = end;
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

CurvatureDerivatives curvature_derivatives(const Mesh& mesh, const DerivativeOptions& opt,
                                           const ProgressFn& progress_fn) {
  if (opt.rings < 1 || opt.rings > 8)
    throw MeshError("rings must be between 1 and 8, got " + std::to_string(opt.rings));
  const Topology& topo = mesh.topo;
  const int nv = topo.n_vertices;
  Progress progress(progress_fn);
  progress(0.0);

  CurvatureDerivatives out;
  out.normals.resize(nv, 3);
  out.k_max.resize(nv);
  out.k_min.resize(nv);
  out.e_max.resize(nv);
  out.e_min.resize(nv);
  out.t_max.resize(nv, 3);
  out.t_min.resize(nv, 3);
  // Chunks so that progress (one thread) and cancellation happen between parallel loops.
  const int chunk = 32768;

  MatX3d Nmax;
  if (opt.jet) {
    Nmax = vertex_normals(mesh.V, mesh.F, topo, NormalWeights::Max);
    out.noise_ratio = jet_noise_ratio(mesh, Nmax);
    out.jet_used = !opt.noise_adaptive || out.noise_ratio <= kJetNoiseRatio;
  }
  if (out.jet_used) {
    MatX3d N(nv, 3);
    const int pass1_degree = opt.rings == 1 ? 4 : 3;
    out.e_max_error.resize(nv);
    out.e_min_error.resize(nv);
    std::vector<JetScratch> scratch(std::max(1, omp_get_max_threads()));
    for (int pass = 0; pass < 2; ++pass)
      for (int begin = 0; begin < nv; begin += chunk) {
        const int end = std::min(nv, begin + chunk);
#pragma omp parallel
        {
          JetScratch& s = scratch[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 256)
          for (int v = begin; v < end; ++v) {
            if (pass == 0)
              N.row(v) = jet_normal(v, mesh.V, Nmax, topo, pass1_degree, s).transpose();
            else
              fit_vertex_jet(v, mesh.V, N, topo, opt, s, out);
          }
        }
        progress(0.5 * pass + 0.5 * end / nv);
      }
    progress(1.0);
    return out;
  }

  std::vector<int> all(nv);
  for (int v = 0; v < nv; ++v) all[v] = v;
  thesis_fit(mesh, opt, all, out, &progress);
  progress(1.0);
  return out;
}

CrestLines trace_crest_lines(const Mesh& mesh, const CurvatureDerivatives& d, const CrestOptions& opt) {
  const Topology& topo = mesh.topo;
  const int nv = topo.n_vertices, ne = topo.n_edges(), nf = topo.n_faces;
  if (d.k_max.size() != nv || d.e_max.size() != nv || d.t_max.rows() != nv)
    throw MeshError("curvature derivatives do not match the mesh (" + std::to_string(d.k_max.size()) + " values for " +
                    std::to_string(nv) + " vertices)");
  // Cyclideness C = sqrt(e_max^2 + e_min^2) (eq. 4.11) per vertex.
  const VecXd C = (d.e_max.array().square() + d.e_min.array().square()).sqrt();

  // Zero crossings per edge and kind: lambda in (0, 1), or -1 when none.
  std::vector<double> cross[2] = {std::vector<double>(ne, -1.0), std::vector<double>(ne, -1.0)};
  const bool want[2] = {opt.ridges, opt.valleys};
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) {
    const int p = topo.edges(e, 0), q = topo.edges(e, 1);
    if (opt.skip_boundary && (topo.on_boundary[p] || topo.on_boundary[q])) continue;
    const Vec3 pq = mesh.V.row(q) - mesh.V.row(p);
    for (int kind = 0; kind < 2; ++kind) {
      if (!want[kind]) continue;
      // Convex: k_max > |k_min| (maximum of k_max); concave: k_min < -|k_max| (minimum of k_min).
      const VecXd& k = kind == kRidge ? d.k_max : d.k_min;
      const VecXd& ko = kind == kRidge ? d.k_min : d.k_max;
      const VecXd& ev = kind == kRidge ? d.e_max : d.e_min;
      const MatX3d& t = kind == kRidge ? d.t_max : d.t_min;
      const double sign = kind == kRidge ? 1.0 : -1.0;
      if (!(sign * k[p] > std::abs(ko[p]) && sign * k[q] > std::abs(ko[q]))) continue;
      const Vec3 tp = t.row(p);
      Vec3 tq = t.row(q);
      double ep = ev[p], eq = ev[q];
      if (tp.dot(tq) < 0) tq = -tq, eq = -eq;  // consistent orientation across the edge
      if (!(ep * eq < 0)) continue;
      // Maximum of k_max: e goes from + to - along t; minimum of k_min: from - to +.
      const double s = pq.dot(tp + tq);
      if (!(sign * ep * s > 0)) continue;
      cross[kind][e] = ep / (ep - eq);
    }
  }

  CrestLines cl;
  std::vector<int> point_of_edge[2] = {std::vector<int>(ne, -1), std::vector<int>(ne, -1)};
  std::vector<int> point_kind;
  std::vector<Vec3> pts;
  std::vector<std::pair<int, int>> pedge;
  std::vector<double> pt, pc;
  for (int kind = 0; kind < 2; ++kind)
    for (int e = 0; e < ne; ++e) {
      const double lam = cross[kind][e];
      if (lam < 0) continue;
      const int p = topo.edges(e, 0), q = topo.edges(e, 1);
      point_of_edge[kind][e] = static_cast<int>(pts.size());
      pts.push_back((1 - lam) * Vec3(mesh.V.row(p)) + lam * Vec3(mesh.V.row(q)));
      pedge.emplace_back(p, q);
      pt.push_back(lam);
      // Weights a = |e(q)|, b = |e(p)| of 4.6 are the linear-interpolation weights (1-lam, lam).
      pc.push_back((1 - lam) * C[p] + lam * C[q]);
      point_kind.push_back(kind);
    }

  // Segments inside triangles: two crossings -> one segment; three -> a junction at their mean.
  std::vector<std::pair<int, int>> segs;
  std::vector<int> seg_face;
  for (int f = 0; f < nf; ++f)
    for (int kind = 0; kind < 2; ++kind) {
      int ids[3], n = 0;
      for (int k = 0; k < 3; ++k) {
        const int id = point_of_edge[kind][topo.face_edges(f, k)];
        if (id >= 0) ids[n++] = id;
      }
      if (n == 2) {
        segs.emplace_back(ids[0], ids[1]);
        seg_face.push_back(f);
      } else if (n == 3) {
        const int j = static_cast<int>(pts.size());
        pts.push_back((pts[ids[0]] + pts[ids[1]] + pts[ids[2]]) / 3.0);
        pedge.emplace_back(-1, -1);
        pt.push_back(0.0);
        pc.push_back((pc[ids[0]] + pc[ids[1]] + pc[ids[2]]) / 3.0);
        point_kind.push_back(kind);
        for (int k = 0; k < 3; ++k) segs.emplace_back(ids[k], j), seg_face.push_back(f);
      }
    }

  // Gap jumping (thesis fig. 4.10): end points within the one-ring of a common vertex are joined
  // when alpha, beta <= pi/3 and gamma <= pi/2.
  if (opt.join_gaps) {
    const int np = static_cast<int>(pts.size());
    std::vector<int> deg(np, 0), nb(np, -1);
    for (auto [a, b] : segs) ++deg[a], ++deg[b], nb[a] = b, nb[b] = a;
    // (vertex, end point) for every vertex whose one-ring holds the end point's edge.
    std::vector<std::pair<int, int>> owner;
    for (int i = 0; i < np; ++i) {
      if (deg[i] != 1 || pedge[i].first < 0) continue;
      const int p = pedge[i].first, q = pedge[i].second;
      owner.emplace_back(p, i);
      owner.emplace_back(q, i);
      // Opposite vertices of the edge's faces (the edge is on their one-ring's rim).
      for (int j = topo.vf_offset[p]; j < topo.vf_offset[p + 1]; ++j) {
        const int f = topo.vf_index[j];
        for (int k = 0; k < 3; ++k) {
          const int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3), c = mesh.F(f, (k + 2) % 3);
          if ((a == p && b == q) || (a == q && b == p)) owner.emplace_back(c, i);
        }
      }
    }
    std::sort(owner.begin(), owner.end());
    struct Candidate {
      double score;
      int a, b;
    };
    std::vector<Candidate> cand;
    const double third = detail::kPi / 3, half = detail::kPi / 2;
    auto angle = [](const Vec3& x, const Vec3& y) { return std::atan2(x.cross(y).norm(), x.dot(y)); };
    for (size_t g = 0; g < owner.size();) {
      size_t h = g;
      while (h < owner.size() && owner[h].first == owner[g].first) ++h;
      for (size_t i = g; i < h; ++i)
        for (size_t j = i + 1; j < h; ++j) {
          const int a = owner[i].second, b = owner[j].second;
          if (a == b || point_kind[a] != point_kind[b] || nb[a] == b) continue;
          const Vec3 da = pts[a] - pts[nb[a]], db = pts[b] - pts[nb[b]];  // outward end segments
          const Vec3 c = pts[b] - pts[a];
          if (c.squaredNorm() == 0 || da.squaredNorm() == 0 || db.squaredNorm() == 0) continue;
          const double alpha = angle(da, c), beta = angle(db, -c), gamma = angle(da, -db);
          if (alpha <= third && beta <= third && gamma <= half)
            cand.push_back({alpha + beta, std::min(a, b), std::max(a, b)});
        }
      g = h;
    }
    std::sort(cand.begin(), cand.end(), [](const Candidate& x, const Candidate& y) {
      return x.score < y.score || (x.score == y.score && (x.a < y.a || (x.a == y.a && x.b < y.b)));
    });
    std::vector<char> used(np, 0);
    for (const Candidate& c : cand) {
      if (used[c.a] || used[c.b]) continue;
      used[c.a] = used[c.b] = 1;
      segs.emplace_back(c.a, c.b);
      seg_face.push_back(-1);
    }
  }

  const int np = static_cast<int>(pts.size()), ns = static_cast<int>(segs.size());
  cl.points.resize(np, 3);
  cl.point_edge.resize(np, 2);
  cl.point_t.resize(np);
  cl.point_cyclideness.resize(np);
  for (int i = 0; i < np; ++i) {
    cl.points.row(i) = pts[i].transpose();
    cl.point_edge(i, 0) = pedge[i].first;
    cl.point_edge(i, 1) = pedge[i].second;
    cl.point_t[i] = pt[i];
    cl.point_cyclideness[i] = pc[i];
  }
  cl.segments.resize(ns, 2);
  for (int s = 0; s < ns; ++s) cl.segments(s, 0) = segs[s].first, cl.segments(s, 1) = segs[s].second;
  cl.segment_face = std::move(seg_face);
  build_lines(cl);
  line_measures(cl, point_kind);
  if (opt.threshold > 0) return filter_crest_lines(cl, opt.threshold, opt.ridges, opt.valleys);
  return cl;
}

CurvatureDerivatives crest_fields(const Mesh& mesh, const DerivativeOptions& opt, const ProgressFn& progress) {
  CurvatureDerivatives d = curvature_derivatives(mesh, opt, progress);
  if (d.jet_used && opt.plateaus) {
    // Grown by the jet's support (pass 1's 2-ring, pass 2's k-ring): next to a plateau's rim, where k jumps (a G1
    // blend meeting a flat side), the polynomial overshoots and puts maxima of k beside the blend's middle.
    const std::vector<int> plateau = plateau_vertices(mesh.topo, d, opt.rings + 2);
    d.plateau_vertices = static_cast<int>(plateau.size());
    if (!plateau.empty()) thesis_fit(mesh, opt, plateau, d);
  }
  return d;
}

CrestLines crest_lines(const Mesh& mesh, const DerivativeOptions& fit, const CrestOptions& opt,
                       const ProgressFn& progress) {
  return trace_crest_lines(mesh, crest_fields(mesh, fit, progress), opt);
}

CrestLines filter_crest_lines(const CrestLines& in, double threshold, bool ridges, bool valleys) {
  const int nl = in.n_lines();
  std::vector<int> new_line(nl, -1);
  CrestLines out;
  for (int l = 0; l < nl; ++l) {
    const bool kind_ok = in.line_kind[l] == kRidge ? ridges : valleys;
    if (!kind_ok || !(in.line_strength[l] >= threshold)) continue;
    new_line[l] = out.n_lines();
    out.line_kind.push_back(in.line_kind[l]);
    out.line_strength.push_back(in.line_strength[l]);
    out.line_length.push_back(in.line_length[l]);
  }
  // The points of the kept lines, numbered in their input order.
  const int np = static_cast<int>(in.points.rows());
  std::vector<int> new_point(np, -1);
  for (int l = 0; l < nl; ++l)
    if (new_line[l] >= 0)
      for (int j = in.line_offset[l]; j < in.line_offset[l + 1]; ++j) new_point[in.line_points[j]] = 0;
  int n_points = 0;
  for (int& q : new_point)
    if (q == 0) q = n_points++;
  for (int l = 0; l < nl; ++l) {
    if (new_line[l] < 0) continue;
    for (int j = in.line_offset[l]; j < in.line_offset[l + 1]; ++j)
      out.line_points.push_back(new_point[in.line_points[j]]);
    out.line_offset.push_back(static_cast<int>(out.line_points.size()));
  }
  out.points.resize(n_points, 3);
  out.point_edge.resize(n_points, 2);
  out.point_t.resize(n_points);
  out.point_cyclideness.resize(n_points);
  for (int p = 0; p < np; ++p) {
    const int q = new_point[p];
    if (q < 0) continue;
    out.points.row(q) = in.points.row(p);
    out.point_edge.row(q) = in.point_edge.row(p);
    out.point_t[q] = in.point_t[p];
    out.point_cyclideness[q] = in.point_cyclideness[p];
  }
  int ns = 0;
  for (int s = 0; s < in.segments.rows(); ++s) ns += new_line[in.segment_line[s]] >= 0;
  out.segments.resize(ns, 2);
  ns = 0;
  for (int s = 0; s < in.segments.rows(); ++s) {
    const int l = new_line[in.segment_line[s]];
    if (l < 0) continue;
    out.segments(ns, 0) = new_point[in.segments(s, 0)];
    out.segments(ns, 1) = new_point[in.segments(s, 1)];
    out.segment_line.push_back(l);
    out.segment_face.push_back(in.segment_face[s]);
    ++ns;
  }
  return out;
}

FeatureOptions decimate_feature_defaults() {
  FeatureOptions o;
  o.feature_weight = 6.0;
  return o;
}

FeatureOptions segment_feature_defaults() {
  FeatureOptions o;
  o.feature_weight = 2.0;
  return o;
}

VecXd crest_face_distance(const Mesh& mesh, const CrestLines& lines) {
  const Topology& topo = mesh.topo;
  const int nf = topo.n_faces;
  const double inf = std::numeric_limits<double>::infinity();
  VecXd dist = VecXd::Constant(nf, inf);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  auto seed = [&](int f) {
    if (f >= 0 && f < nf && dist[f] != 0.0) dist[f] = 0.0, heap.emplace(0.0, f);
  };
  // Faces of an edge (v0, v1), found through v0's faces.
  auto edge_faces = [&](int v0, int v1) {
    if (v0 < 0) return;
    for (int j = topo.vf_offset[v0]; j < topo.vf_offset[v0 + 1]; ++j) {
      const int f = topo.vf_index[j];
      if (mesh.F(f, 0) == v1 || mesh.F(f, 1) == v1 || mesh.F(f, 2) == v1) seed(f);
    }
  };
  for (int s = 0; s < lines.segments.rows(); ++s) {
    if (s < static_cast<int>(lines.segment_face.size()) && lines.segment_face[s] >= 0) {
      seed(lines.segment_face[s]);
    } else {  // a gap jump: the faces of the edges its end points lie on
      for (int k = 0; k < 2; ++k) {
        const int p = lines.segments(s, k);
        edge_faces(lines.point_edge(p, 0), lines.point_edge(p, 1));
      }
    }
  }
  if (heap.empty()) return VecXd::Zero(nf);
  MatX3d centroid(nf, 3);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f)
    centroid.row(f) = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
  while (!heap.empty()) {
    const auto [df, f] = heap.top();
    heap.pop();
    if (df > dist[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const int e = topo.face_edges(f, k);
      const int g = topo.edge_faces(e, 0) == f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
      if (g < 0) continue;
      const Vec3 mid = 0.5 * (mesh.V.row(topo.edges(e, 0)) + mesh.V.row(topo.edges(e, 1))).transpose();
      const double len = (Vec3(centroid.row(f)) - mid).norm() + (Vec3(centroid.row(g)) - mid).norm();
      if (df + len < dist[g]) dist[g] = df + len, heap.emplace(df + len, g);
    }
  }
  double dmax = 0.0;
  for (int f = 0; f < nf; ++f)
    if (dist[f] < inf) dmax = std::max(dmax, dist[f]);
  for (int f = 0; f < nf; ++f)
    if (dist[f] == inf) dist[f] = dmax;
  return dist;
}

VecXd feature_function(const VecXd& distance, double eta, double eps) {
  if (!(eps > 0)) throw MeshError("the regularisation eps of F(d) must be positive");
  const double dmax = distance.size() ? distance.maxCoeff() : 0.0;
  if (!(dmax > 0) || eta == 0.0) return VecXd::Ones(distance.size());
  return (distance.array() / dmax + eps).pow(eta);
}

}  // namespace dgmesh
