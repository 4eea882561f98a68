// Differential-geometry operators on triangle meshes: normals, areas, the cotangent
// Laplace-Beltrami operator, mean and Gaussian curvature, umbrella operators (thesis 3.1).
#pragma once
#include "dgmesh/mesh.h"
#include "dgmesh/types.h"

namespace dgmesh {

MatX3d face_normals(const MatX3d& V, const MatX3i& F);  // unit length
VecXd face_areas(const MatX3d& V, const MatX3i& F);

enum class NormalWeights {
  Max,    // Nelson Max's weights: sum of e_i x e_{i+1} / (|e_i|^2 |e_{i+1}|^2); exact on spheres
  Area,   // area-weighted face normals (thesis eq. 3.7)
  Angle,  // angle-weighted face normals
};
MatX3d vertex_normals(const MatX3d& V, const MatX3i& F, const Topology& topo, NormalWeights w = NormalWeights::Max);

// Mixed Voronoi areas (Meyer et al. 2003): Voronoi area for non-obtuse triangles, half / quarter
// of the triangle area at obtuse ones. They sum to the surface area.
VecXd mixed_areas(const MatX3d& V, const MatX3i& F, const Topology& topo);

// Cotangent stiffness matrix L: L_ij = (cot a_ij + cot b_ij) / 2, L_ii = -sum_j L_ij, so that
// (M^-1 L V)_i is the Laplace-Beltrami of the position, -2 H_i N_i (thesis eq. 3.11, with the
// mixed areas M in place of A/3).
SpMat cotan_laplacian(const MatX3d& V, const MatX3i& F);

struct Curvature {
  VecXd mean;      // H, positive on a sphere with outward normals (1/r)
  VecXd gaussian;  // K by angle deficit over the mixed area (1/r^2 on a sphere)
  MatX3d normals;  // unit vertex normals (Max weights)
  VecXd area;      // mixed Voronoi area per vertex
  MatX3d laplace;  // Laplace-Beltrami of the position per vertex (the mean-curvature normal, -2HN)
};

// Curvatures at every vertex. Boundary vertices have no angle deficit of their own: they take the
// mean of their interior neighbours' values (0 if none). Loose vertices get 0 and a zero normal.
Curvature curvature(const MatX3d& V, const MatX3i& F, const Topology& topo);

enum class Umbrella {
  Uniform,  // U0: the mean of (Q_i - P)  (thesis eq. 3.9 with equal weights)
  Area,     // U_area of thesis eq. 3.10: neighbours weighted by adjacent triangle areas / edge lengths
};
// The umbrella operator as a sparse matrix W (rows of boundary and loose vertices are zero), so
// that W V is the umbrella vector field and W (W V) the bi-umbrella.
SpMatR umbrella_matrix(const MatX3d& V, const Topology& topo, Umbrella kind);
MatX3d umbrella(const MatX3d& V, const Topology& topo, Umbrella kind);
MatX3d bi_umbrella(const MatX3d& V, const Topology& topo, Umbrella kind);

}  // namespace dgmesh
