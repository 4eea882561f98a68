/// \file
/// Tangential smoothing of the remesher's output (beyond the thesis's section 5.4): interior vertices
/// move towards the optimal-Delaunay position inside the triangulation map (so they stay on the input
/// surface and the map stays an embedding) without creating small 3D angles, interior vertices of
/// valence 3 or 4 with a small angle in their star are removed, and the sweeps alternate with the 3D
/// edge flips. Not part of the library's interface.
#pragma once
#include <vector>

#include "dgmesh/detail/remesh_map.h"
#include "dgmesh/mesh.h"
#include "dgmesh/remesh.h"

namespace dgmesh::detail {

/// Vertex -> incident triangles of T over nv vertices, as offsets and a flat list (CSR).
void vertex_triangles(const MatX3i& T, int nv, std::vector<int>& off, std::vector<int>& ring);

/// Beyond the thesis: removes interior vertices of valence 3 or 4 whose star holds a small 3D angle.
/// Such a vertex cannot be smoothed out of it (three triangles around a vertex average 120 degrees
/// there, leaving small angles elsewhere; four share a quadrilateral that the vertex crowds). The
/// star becomes its link: one triangle for valence 3, two for valence 4 (the diagonal whose smaller
/// angle is larger). Only when every new triangle keeps its orientation in the triangulation map (so
/// the mesh stays an embedding of the chart) and the smallest angle grows. Stars are handled once
/// per pass and never overlap, so the pass is deterministic. Boundary vertices (index < nb) stay;
/// vertices are compacted afterwards. Returns the number of vertices removed.
int remove_low_valence(MatX3i& T, MatX3d& X, MatX2d& P, std::vector<Sample>& S, VecXd& rho_out, int nb,
                       double orient_sign, double max_cos);

/// Beyond the thesis: one sweep of tangential smoothing of the new mesh's interior vertices in the
/// surface metric, moved inside the triangulation map so that they stay on the input surface and
/// the map stays an embedding. Each vertex goes towards the density-and-area-weighted mean of its
/// incident triangles' 3D circumcentres (the optimal Delaunay triangulation step of Chen & Xu 2004;
/// with centroids it would be the area-weighted relaxation of Botsch & Kobbelt 2004); the 3D
/// displacement d becomes a map displacement by the least-squares inverse of the Jacobian J of the
/// input face under the vertex (du = (J^T J)^-1 J^T d, the tangential part). A move is halved until
/// no incident triangle flips in the map, or skipped. Gauss-Seidel by colour: `groups` lists the
/// interior vertices colour by colour (group_off), no two neighbours in one colour, so a colour's
/// vertices move in parallel without touching each other's stars (the last group, vertices the
/// colouring could not place, runs serially). Deterministic. Returns the moves made.
int smooth_in_map(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Ut, const VecXd& rho,
                  const std::vector<int>& ring_off, const std::vector<int>& ring, const std::vector<int>& groups,
                  const std::vector<int>& group_off, double orient_sign, const MatX3i& T, MatX3d& X, MatX2d& P,
                  std::vector<Sample>& S, VecXd& rho_out);

/// The smoothing stage of remesh(): o.smooth_iterations sweeps of smooth_in_map, each followed by
/// the 3D flips (o.flip_3d) and the removal of low-valence vertices, then a closing sweep and up to
/// kRepairRounds repair rounds over the stars still holding an angle below the sharp-feature goal.
/// (V, F, topo): the input chart; Ut: its triangulation map; rho: the density per input vertex; nb:
/// the boundary vertices (first in res, never moved); orient_sign: the chart's orientation in Ut.
/// Updates res.V, res.uv, res.F, the counters res.n_flips, res.smooth_moves and res.n_removed, and
/// the output vertices' input locations S (removed vertices are compacted away).
void smooth_remeshed(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Ut, const VecXd& rho,
                     const RemeshOptions& o, int nb, double orient_sign, std::vector<Sample>& S, RemeshResult& res);

}  // namespace dgmesh::detail
