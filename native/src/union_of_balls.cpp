// Distance to a union of balls (thesis eq. 6.13); see skeletal.h.
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

}  // namespace dgmesh
