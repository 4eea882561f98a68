// Meshes of surfaces with known answers, for tests, benchmarks and demos.
#pragma once
#include "dgmesh/types.h"

namespace dgmesh {

struct TriMesh {
  MatX3d V;
  MatX3i F;
};

// Icosahedron subdivided `level` times (1-to-4), projected onto the sphere of radius r.
TriMesh icosphere(int level, double r = 1.0);
// Torus with centre-line radius R and tube radius r, nu x nv quads split into triangles.
TriMesh torus(double R, double r, int nu, int nv);
// Regular grid of nx x ny quads over [0,1]^2 in the z = 0 plane, triangles alternating diagonals.
TriMesh grid(int nx, int ny);
// Loop-free 1-to-4 linear subdivision (new vertices at edge midpoints).
TriMesh subdivide_linear(const MatX3d& V, const MatX3i& F);

}  // namespace dgmesh
