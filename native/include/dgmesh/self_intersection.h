// Self-intersecting triangle pairs of a triangle mesh, through a uniform grid over the triangles'
// bounding boxes (issue 33: the count the skeletal deformation's joint quality is measured by, and
// the fold detector of its untangling step).
#pragma once
#include <utility>
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

// Pairs (i, j), i < j, of faces of (V, F) sharing no vertex where an edge of one crosses the other's
// interior (strict orientation tests: touching or coplanar pairs do not count), sorted. `faces`
// (optional): only pairs of these faces are tested. Faces with an index out of range are rejected
// by the caller (not checked here); degenerate (zero-area) faces cross nothing.
std::vector<std::pair<int, int>> self_intersecting_pairs(const MatX3d& V, const MatX3i& F,
                                                         const std::vector<int>* faces = nullptr);

// The same pairs restricted to those with at least one face flagged in `touching` (indexed by face,
// F.rows() entries): after moving some vertices, the pairs of the faces around them are the only
// ones that can have changed. Only the faces of `faces` (all when null) whose box meets the box of
// the flagged ones are gridded, so the cost follows the moved region, not the mesh. Exact: equal to
// the full search's pairs with a flagged face.
std::vector<std::pair<int, int>> self_intersecting_pairs_touching(const MatX3d& V, const MatX3i& F,
                                                                  const std::vector<int>* faces,
                                                                  const std::vector<char>& touching);

}  // namespace dgmesh
