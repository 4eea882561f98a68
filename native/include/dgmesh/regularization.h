/// \file
/// Tangential regularisation (thesis 3.3, eq. 3.8 with tau = 0 and eq. 3.10; fig. 3.3-3.4): vertices
/// drift in their tangent planes by the tangent part of the area-weighted bi-umbrella operator,
/// T = -(U2 - (U2 . N) N), U2 = U_area(U_area(P)), which evens out triangle sizes and shapes while
/// keeping the surface. regularize() (the drift alone, with an optional projection back onto the
/// input) is declared in fair.h; the Willmore flow adds the same drift to its normal speed.
#pragma once
#include <vector>

#include "dgmesh/fair.h"
#include "dgmesh/mesh.h"
#include "dgmesh/types.h"

namespace dgmesh {

/// Tangential drift (eq. 3.8, 3.10): P += eps * T, T = -(U2 - (U2.N)N), U2 = U_area(U_area(P)), with
/// U_area the umbrella operator weighted by the areas of the triangles around each edge (thesis eq.
/// 3.10; zero on the boundary). Buffers are reused across calls.
struct TangentialDrift {
  std::vector<double> wts;  // CSR weights aligned with topo.vv_index
  MatX3d U, U2;

  /// U_area's weights for the positions P.
  void weights(const MatX3d& P, const Topology& t);
  /// out = U_area(X) with the current weights.
  void apply(const MatX3d& X, MatX3d& out, const Topology& t) const;
  /// Computes T into U2 (as the tangent field) for the positions P and unit normals N.
  void field(const MatX3d& P, const MatX3d& N, const Topology& t);
};

}  // namespace dgmesh
