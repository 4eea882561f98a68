// Delaunay triangulations with Qhull (the Quickhull algorithm the thesis used, [BDH96]):
// 3D Delaunay tetrahedra with their circumcentres, which are the vertices of the Voronoi diagram
// (thesis 6.1: Voronoi poles), and a 2D Delaunay triangulation of planar points.
#pragma once
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

using MatX4i = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;
using MatX2d = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

struct Delaunay3 {
  MatX4i tets;           // positively oriented: det(b-a, c-a, d-a) > 0
  MatX3d circumcenters;  // one per tet: the Voronoi vertices
  VecXd circumradii;
  // Tets around each input point (CSR): the Voronoi vertices of its cell. Points that Qhull
  // dropped as duplicates (or coplanar with the hull) have none.
  std::vector<int> point_offset, point_tets;
};

// Delaunay tetrahedralisation of n >= 4 finite points that are not all coplanar. Degenerate
// (cospherical) configurations are triangulated (Qhull's Qt). Throws MeshError otherwise.
Delaunay3 delaunay_3d(const MatX3d& points);

// Delaunay triangulation of n >= 3 finite points that are not all collinear, counter-clockwise
// triangles. Throws MeshError otherwise.
MatX3i delaunay_2d(const MatX2d& points);

// Circumcentre of the tetrahedron (a, b, c, d); returns false (and the centroid) when it is flat.
bool tet_circumcenter(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, Vec3& center);

}  // namespace dgmesh
