/// \file
/// Small helpers shared by the algorithms' sources: constants and 2D vectors (the UV and chart maps).
/// Not part of the library's interface.
#pragma once
#include <Eigen/Core>
#include <limits>

namespace dgmesh::detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

using Vec2 = Eigen::Vector2d;

/// z component of the 3D cross product of (a, 0) and (b, 0): twice the signed area of the triangle
/// (0, a, b), positive when b lies counter-clockwise of a.
inline double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace dgmesh::detail
