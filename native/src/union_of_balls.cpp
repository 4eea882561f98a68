// Distances to a union of balls (thesis eq. 6.13) and to the convex hull of three balls (the E_T
// of eq. 6.5); see skeletal.h.
#include "dgmesh/skeletal.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dgmesh/detail/skeletal_util.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace detail {

double union_distance(const KdTree& tree, const MatX3d& centers, const VecXd& radii, double r_max, const Vec3& x,
                      int bound_index, int& arg, std::vector<std::pair<int, double>>& scratch) {
  if (bound_index < 0) bound_index = tree.nearest(x);
  double best = (x - row3(centers, bound_index)).norm() - radii[bound_index];
  arg = bound_index;
  tree.radius(x, std::max(best + r_max, 0.0), scratch);
  for (const auto& [j, d2] : scratch) {
    const double f = std::sqrt(d2) - radii[j];
    if (f < best) best = f, arg = j;
  }
  return best;
}

}  // namespace detail

using detail::union_distance;

VecXd union_of_balls_distance(const MatX3d& X, const MatX3d& centers, const VecXd& radii, std::vector<int>* nearest) {
  if (centers.rows() == 0 || radii.size() != centers.rows()) throw MeshError("union of balls: need centres and radii");
  const KdTree tree(centers);
  const double r_max = radii.maxCoeff();
  const int n = static_cast<int>(X.rows());
  VecXd f(n);
  if (nearest) nearest->assign(n, -1);
#pragma omp parallel
  {
    std::vector<std::pair<int, double>> scratch;
#pragma omp for schedule(dynamic, 256)
    for (int i = 0; i < n; ++i) {
      int arg;
      f[i] = union_distance(tree, centers, radii, r_max, row3(X, i), -1, arg, scratch);
      if (nearest) (*nearest)[i] = arg;
    }
  }
  return f;
}

namespace {

// |x - c| - r and the unit vector from c to x (`normal` when x = c).
double ball_value(const Vec3& x, const Vec3& c, double r, const Vec3& normal, Vec3& u) {
  const Vec3 d = x - c;
  const double len = d.norm();
  u = len > 0 ? Vec3(d / len) : normal;
  return len - r;
}

// min over t in [0, 1] of |x - c(t)| - r(t) along the edge (a, ra) -> (b, rb): the cone-sphere.
// With e the unit edge direction, the stationary point satisfies u . e = (ra - rb) / |b - a|
// = cos(theta), i.e. it lies y cot(theta) before x's foot on the edge line (y: x's distance from
// the line); the function is convex in t, so clamping that point to the edge gives the minimum.
double edge_value(const Vec3& x, const Vec3& a, double ra, const Vec3& b, double rb, const Vec3& normal, Vec3& u) {
  const Vec3 e = b - a;
  const double L = e.norm();
  double tau = 0;  // distance from a along the edge
  if (L > 0) {
    const double cos_t = -(rb - ra) / L;
    const Vec3 q = x - a;
    const double s = q.dot(e) / L;
    if (cos_t <= -1) {
      tau = L;  // ball b contains ball a
    } else if (cos_t < 1) {
      const double y = (q - (s / L) * e).norm();
      tau = std::clamp(s - y * cos_t / std::sqrt(1 - cos_t * cos_t), 0.0, L);
    }  // else ball a contains ball b: tau = 0
  }
  const double t = L > 0 ? tau / L : 0.0;
  return ball_value(x, a + t * e, ra + t * (rb - ra), normal, u);
}

}  // namespace

double ball_hull_distance(const Vec3& x, const std::array<Vec3, 3>& c, const Vec3& r, Vec3* gradient) {
  const Vec3 e1 = c[1] - c[0], e2 = c[2] - c[0];
  Vec3 n = e1.cross(e2);
  const double n_len = n.norm();
  const double scale = std::max(e1.squaredNorm(), e2.squaredNorm());
  const bool flat = !(n_len > 1e-12 * scale);  // collinear or coincident centres: edges only
  n = flat ? Vec3::UnitZ() : Vec3(n / n_len);
  const double h = (x - c[0]).dot(n);
  const Vec3 side = h < 0 ? Vec3(-n) : n;
  double best = std::numeric_limits<double>::infinity();
  Vec3 best_u = side, u;
  if (!flat) {
    // Interior stationary point: u . e_k = -(r_k - r_0) fixes u's in-plane part p, the unit length
    // its normal part (on x's side); the centre c(l) = x - t u then lies in the plane.
    Eigen::Matrix2d G;
    G << e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2);
    const Eigen::Matrix2d Gi = G.inverse();
    const Eigen::Vector2d ab = Gi * Eigen::Vector2d(r[0] - r[1], r[0] - r[2]);
    const Vec3 p = ab[0] * e1 + ab[1] * e2;
    const double p2 = p.squaredNorm();
    if (p2 < 1) {
      const double un = std::sqrt(1 - p2);
      const Vec3 uu = p + un * side;
      const double t = std::abs(h) / un;
      const Vec3 cl = x - t * uu;
      const Eigen::Vector2d l = Gi * Eigen::Vector2d((cl - c[0]).dot(e1), (cl - c[0]).dot(e2));
      if (l[0] >= 0 && l[1] >= 0 && l[0] + l[1] <= 1) {
        best = t - (r[0] + l[0] * (r[1] - r[0]) + l[1] * (r[2] - r[0]));
        best_u = uu;
      }
    }
  }
  if (!std::isfinite(best)) {
    // The minimum lies on the boundary (the function is convex): the best of the three edges.
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3;
      const double f = edge_value(x, c[k], r[k], c[j], r[j], side, u);
      if (f < best) best = f, best_u = u;
    }
  }
  if (gradient) *gradient = best_u;
  return best;
}

}  // namespace dgmesh
