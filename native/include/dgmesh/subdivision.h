// Loop subdivision through OpenSubdiv (no hand-written subdivision rules).
#pragma once
#include "dgmesh/shapes.h"
#include "dgmesh/types.h"

namespace dgmesh {

// Uniform Loop refinement: each level splits every triangle in four and smooths with Loop's
// rules (boundaries as crease curves). Requires a manifold triangle mesh.
TriMesh loop_subdivide(const MatX3d& V, const MatX3i& F, int levels);

}  // namespace dgmesh
