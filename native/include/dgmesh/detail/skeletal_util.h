/// \file
/// Pieces shared by the skeletal deformation's sources (skeletal.cpp: the rig; skeletal_mesh.cpp,
/// skinning.cpp, union_of_balls.cpp). Not part of the library's interface.
#pragma once
#include <utility>
#include <vector>

#include "dgmesh/spatial_index.h"
#include "dgmesh/types.h"

namespace dgmesh::detail {

using Mat3 = Eigen::Matrix3d;
using MatX9d = Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>;  // a 3x3 matrix per row

/// Nearest rotation (polar decomposition) of a 3x3 matrix; the identity for a zero matrix.
/// Scaled Newton iteration R <- (g R + R^-T / g) / 2 (Higham), a few 3x3 inverses, with the SVD as
/// the fallback for (nearly) singular or reflecting input.
Mat3 nearest_rotation(const Mat3& C);

/// The rigid motion x -> R x + t of a blend of unit dual quaternions (Kavan et al. 2007): r and d the
/// weighted sums of their real and dual parts (Eigen's coefficient order x, y, z, w), normalised here.
/// False, R and t untouched, when the real part vanishes.
bool dual_quaternion_motion(const Eigen::Vector4d& r, const Eigen::Vector4d& d, Mat3& R, Vec3& t);

/// The bone rotations q blended with the weights w (one per bone) as quaternions: each turned to the
/// hemisphere of the one with the largest weight, the result normalised; the identity when the sum
/// vanishes. (A linear blend of rotation matrices loses rank under twists.)
Mat3 blended_rotation(const Eigen::Ref<const Eigen::RowVectorXd>& w, const std::vector<Eigen::Quaterniond>& q);

/// Signed volume enclosed by the closed triangle mesh (V, F) (positive for outward faces).
double signed_volume(const MatX3d& V, const MatX3i& F);

/// The point of segment [a, b] closest to p (a for a zero-length segment).
Vec3 segment_closest(const Vec3& p, const Vec3& a, const Vec3& b);

/// Squared distance from p to segment [a, b].
double segment_sq_dist(const Vec3& p, const Vec3& a, const Vec3& b);

/// min_j |x - s_j| - r_j over the balls, with the kd-tree over the centres. `bound_index` gives a
/// first candidate (its ball bounds the search); -1 starts from the nearest centre.
double union_distance(const KdTree& tree, const MatX3d& centers, const VecXd& radii, double r_max, const Vec3& x,
                      int bound_index, int& arg, std::vector<std::pair<int, double>>& scratch);

}  // namespace dgmesh::detail
