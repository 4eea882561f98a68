/// \file
/// Hole filling after Liepa (P. Liepa, "Filling holes in meshes", SGP 2003): the minimum-weight
/// triangulation of a hole's boundary loop (sec. 3.2), and refine_region (declared in fair.h, used by
/// fair() with `refine`), which re-triangulates a fill without inner vertices that way and refines it
/// to the edge lengths of the mesh around the hole (sec. 3.3). See bench/notes/hole_filling.md for
/// measurements.
#pragma once
#include <functional>
#include <vector>

#include "dgmesh/fair.h"
#include "dgmesh/types.h"

namespace dgmesh {

/// Liepa's minimum-weight triangulation of a hole's boundary polygon (sec. 3.2): among all
/// triangulations of the loop without inner vertices, the one whose largest dihedral angle (between
/// adjacent triangles, and between the fill and the faces around the hole) is smallest, ties broken
/// by the smaller area; dynamic programming over the loop's sub-polygons, O(n^3) time, O(n^2) memory.
/// Unlike a fan, it does not fold across a hole whose rim is not planar.
/// P: vertex positions; loop: the hole's vertices (indices into P) in the fill's orientation;
/// outer_normal[i]: the unit normal of the face outside the hole along edge (loop[i], loop[i+1])
/// (zero on a mesh border); is_edge(a, b): whether the diagonal (a, b) already exists outside the
/// hole (then it is not used). Returns the n - 2 triangles (vertex indices into P, oriented as the
/// loop), or nothing when the loop has fewer than 3 vertices or no valid triangulation exists.
std::vector<Eigen::Vector3i> min_weight_triangulation(const std::vector<Vec3>& P, const std::vector<int>& loop,
                                                      const std::vector<Vec3>& outer_normal,
                                                      const std::function<bool(int, int)>& is_edge);

}  // namespace dgmesh
