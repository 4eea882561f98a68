/// \file
/// Integer keys of mesh edges for hash maps and sorting. Not part of the library's interface.
#pragma once
#include <algorithm>

namespace dgmesh::detail {

/// The undirected edge {a, b} (vertex indices >= 0): equal for (a, b) and (b, a), distinct for
/// distinct edges.
inline long long edge_key(int a, int b) {
  return (static_cast<long long>(std::min(a, b)) << 32) | static_cast<unsigned>(std::max(a, b));
}

/// The directed edge (half-edge) a -> b.
inline long long half_edge_key(int a, int b) { return (static_cast<long long>(a) << 32) | static_cast<unsigned>(b); }

}  // namespace dgmesh::detail
