/// \file
/// Small helpers shared by the algorithms' sources: constants and 2D vectors (the UV and chart maps).
/// Not part of the library's interface.
#pragma once
#include <Eigen/Core>
#include <algorithm>
#include <limits>

namespace dgmesh::detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

using Vec2 = Eigen::Vector2d;

/// z component of the 3D cross product of (a, 0) and (b, 0): twice the signed area of the triangle
/// (0, a, b), positive when b lies counter-clockwise of a.
inline double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

/// 3 x^2 - 2 x^3 of x clamped to [0, 1]: 0 below 0, 1 above 1, with zero slope at both ends.
inline double smoothstep(double x) {
  const double s = std::clamp(x, 0.0, 1.0);
  return s * s * (3 - 2 * s);
}

}  // namespace dgmesh::detail
