/// \file
/// Serial threshold of the UV unwrapping's loops and its linear solvers. Not part of the library's
/// interface.
#pragma once

namespace dgmesh::detail {

/// Loops over fewer rows (vertices; faces and ring entries are about 2x and 6x as many) run
/// serially: on a loaded machine OpenMP's fork/join and spin-waiting cost more than the work (see
/// kFairParallelMin in detail/fair_mesh.h).
constexpr int kParallelRows = 20000;

}  // namespace dgmesh::detail
