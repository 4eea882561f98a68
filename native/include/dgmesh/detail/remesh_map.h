/// \file
/// Pieces shared by the remesher's stages (remesh.cpp, remesh_flips.cpp, remesh_smoothing.cpp): points
/// of the input located by face and barycentric weights, and small triangle measures. Not part of the
/// library's interface.
#pragma once
#include <algorithm>
#include <cmath>

#include "dgmesh/detail/math.h"
#include "dgmesh/mesh.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::detail {

/// A point of the input surface: input face and the barycentric weights of its three corners.
struct Sample {
  int face;
  double w0, w1, w2;
};

inline Vec2 uv_row(const MatX2d& U, int i) { return U.row(i).transpose(); }

/// Cosine of the smallest angle of the triangle (a, b, c): it is opposite the shortest edge (law of
/// cosines); 1 for a degenerate triangle.
inline double min_angle_cos(const Vec3& a, const Vec3& b, const Vec3& c) {
  double l[3] = {(b - c).squaredNorm(), (c - a).squaredNorm(), (a - b).squaredNorm()};
  std::sort(l, l + 3);
  const double den = 2 * std::sqrt(l[1] * l[2]);
  return den > 0 ? (l[1] + l[2] - l[0]) / den : 1.0;
}

/// the most negative barycentric coordinate. Returns false if the walk leaves the chart.
bool locate_in_map(const MatX2d& U, const MatX3i& F, const Topology& topo, const Vec2& p, int f, Sample& out);

}  // namespace dgmesh::detail
