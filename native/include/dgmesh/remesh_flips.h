/// \file
/// Edge flips of the remesher (beyond the thesis's section 5.4, which triangulates the samples once):
/// Lawson flips towards the Delaunay triangulation of the triangulation map, and towards that of the
/// lifted 3D mesh while the map stays an embedding. Not part of the library's interface.
#pragma once
#include <array>
#include <utility>
#include <vector>

#include "dgmesh/types.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::detail {

/// Beyond the thesis: edge flips towards a Delaunay triangulation of the lifted 3D mesh (flip an
/// interior edge when its two opposite 3D angles sum to more than pi, the Delaunay criterion that
/// maximises the minimum angle), allowed only when both new triangles keep their orientation in the
/// triangulation map, so the mesh stays an embedding of the chart. Boundary edges never flip.
/// closing: only flips across near-flat edges that do not lower the pair's smallest angle (after
/// the smoothing's closing pass, which must not be undone). Returns the number of flips.
int delaunay_flips_3d(const MatX3d& X, const MatX2d& U, MatX3i& F, double orient_sign, bool closing = false);

int delaunay_flips_map(const MatX2d& P, std::vector<std::array<int, 3>>& T,
                       const std::vector<std::pair<int, int>>& seeds);

}  // namespace dgmesh::detail
