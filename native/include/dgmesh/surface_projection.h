/// \file
/// Closest points on triangle meshes: on one triangle, on a frozen copy of a surface (the
/// regularisation's projection back onto its input), and point-to-mesh distances
/// (point_mesh_distance, declared in remesh.h).
#pragma once
#include <vector>

#include "dgmesh/mesh.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/types.h"

namespace dgmesh {

/// Closest point on the triangle (a, b, c) to p, by the Voronoi regions of its vertices, edges and
/// face (Ericson, Real-Time Collision Detection, 5.1.5). Degenerate triangles are allowed.
Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

/// |p - closest_point_on_triangle(p, a, b, c)|.
double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

/// Distance from p to the segment (a, b) (a point when a == b).
double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b);

/// Projection onto a frozen copy of a surface (V, F) with its topology t: the closest point on the
/// faces around the 4 nearest vertices of p (exact where those faces hold the closest point, as for
/// points moved a small step off the surface). project() is thread safe with per-thread scratch
/// buffers idx and d2.
class SurfaceProjector {
 public:
  SurfaceProjector(const MatX3d& V, const MatX3i& F, const Topology& t);
  Vec3 project(const Vec3& p, std::vector<int>& idx, std::vector<double>& d2) const;

 private:
  MatX3d V_;
  MatX3i F_;
  Topology topo_;
  KdTree tree_;
};

}  // namespace dgmesh
