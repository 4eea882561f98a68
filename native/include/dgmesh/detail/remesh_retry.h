// remesh()'s safety net, apart from the algorithm so that it can be tested on its own.
#pragma once
#include <cstdio>
#include <string>

#include "dgmesh/errors.h"
#include "dgmesh/remesh.h"

namespace dgmesh::detail {

/// The new triangulation is not a disk bounded by the boundary samples (an internal error).
struct InvalidTriangulation : Error {
  using Error::Error;
};

/// Runs attempt(options); when it throws InvalidTriangulation (samples close to the boundary kept
/// the map's Delaunay triangulation from meeting it), once more with the boundary samples' full
/// clearance (boundary_clearance 1), noting it in the result's warnings. If that fails too, a kept
/// boundary gives a MeshError saying what the user can change; otherwise the error stands.
template <class Attempt>
RemeshResult remesh_with_retry(const RemeshOptions& options, Attempt&& attempt) {
  try {
    return attempt(options);
  } catch (const InvalidTriangulation&) {
    if (options.boundary_clearance >= 1.0) throw;
  }
  RemeshOptions wide = options;
  wide.boundary_clearance = 1.0;
  RemeshResult r;
  try {
    r = attempt(wide);
  } catch (const InvalidTriangulation&) {
    if (options.boundary != RemeshBoundary::Keep) throw;
    throw MeshError(
        "remesh: the new triangulation could not be stitched to the kept boundary of this region; select a region "
        "with a smoother border, or remesh the whole disk with the boundary resampled (boundary='resample'; Object "
        "mode: Resample Boundary)");
  }
  char clearance[32];
  std::snprintf(clearance, sizeof clearance, "%g", options.boundary_clearance);
  r.warnings.push_back(
      "the first triangulation missed the kept boundary: remeshed again with more room between the boundary and "
      "the inner vertices (boundary_clearance " +
      std::string(clearance) + " -> 1)");
  return r;
}

}  // namespace dgmesh::detail
