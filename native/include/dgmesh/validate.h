// Input validation with clear messages. Each algorithm states which defects it rejects by the
// set of checks it passes; MeshError carries a message that counts the defects and names the first.
#pragma once
#include "dgmesh/mesh.h"
#include "dgmesh/types.h"

namespace dgmesh {

enum Check : unsigned {
  kNonEmpty = 1u << 0,         // at least one vertex and one face
  kIndices = 1u << 1,          // face indices within [0, n)
  kFinite = 1u << 2,           // no NaN / inf coordinates
  kNoRepeatedIndex = 1u << 3,  // no face like (a, a, b)
  kNoZeroArea = 1u << 4,       // no face with area below 1e-12 of the squared bbox diagonal
  kNoDuplicateFaces = 1u << 5,
  kNoLooseVertices = 1u << 6,  // every vertex in some face
  kManifold = 1u << 7,         // edges with <= 2 faces, consistently oriented, single fan per vertex
  // What nearly every surface algorithm needs. Loose vertices are tolerated (they are skipped).
  kSurface = kNonEmpty | kIndices | kFinite | kNoRepeatedIndex | kNoZeroArea | kNoDuplicateFaces | kManifold,
};

// Throws MeshError on the first failed check (cheap checks first). kManifold is checked by
// building the topology, which is returned so that callers do not build it twice.
Topology validate(const MatX3d& V, const MatX3i& F, unsigned checks = kSurface);

// Validates and bundles V, F and their topology.
Mesh make_mesh(MatX3d V, MatX3i F, unsigned checks = kSurface);

// Point clouds: non-empty, finite.
void validate_points(const MatX3d& V);

}  // namespace dgmesh
