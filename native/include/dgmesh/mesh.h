// Triangle mesh connectivity, built once in O(n) per vertex (in parallel) and shared by every
// algorithm: vertex-face incidence, ordered one-rings, edges, boundary loops, components.
#pragma once
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

struct Topology {
  int n_vertices = 0;
  int n_faces = 0;

  // Faces around each vertex (CSR), in the counter-clockwise order of the ring:
  // vf_index[vf_offset[v] + i] lies between ring neighbours i and i+1.
  std::vector<int> vf_offset, vf_index;
  // One-ring neighbours of each vertex in counter-clockwise order (CSR). For a boundary vertex
  // the ring starts and ends at its two boundary neighbours (valence = faces + 1).
  std::vector<int> vv_offset, vv_index;
  std::vector<char> on_boundary;  // vertex lies on a boundary loop

  MatX2i edges;                                  // unique undirected edges, edges(e,0) < edges(e,1)
  MatX3i face_edges;                             // face_edges(f,k): edge from F(f,k) to F(f,(k+1)%3)
  MatX2i edge_faces;                             // the (one or two) faces of an edge; -1 when on the boundary
  std::vector<std::vector<int>> boundary_loops;  // vertex cycles, orientation follows the faces
  std::vector<int> component;                    // connected component of each vertex (loose vertices get their own)
  int n_components = 0;

  int valence(int v) const { return vv_offset[v + 1] - vv_offset[v]; }
  int n_edges() const { return static_cast<int>(edges.rows()); }
  bool is_loose(int v) const { return vf_offset[v] == vf_offset[v + 1]; }
};

// The corners of the faces around each vertex, in CSR order: for face (v, next, prev) listed
// counter-clockwise. Built in one pass over F so that per-vertex loops read memory in order.
struct Corner {
  int face, local, next, prev;
};
struct VertexCorners {
  std::vector<int> offset;  // corners of v: corners[offset[v] .. offset[v+1])
  std::vector<Corner> corners;
};
VertexCorners vertex_corners(const MatX3i& F, int n_vertices);

// Builds the topology of F over n_vertices vertices. Requires a manifold, consistently oriented
// triangle mesh with valid indices (see validate.h); throws MeshError naming the first offending
// edge or vertex otherwise.
Topology build_topology(const MatX3i& F, int n_vertices);
Topology build_topology(const VertexCorners& vc, int n_faces);

// A validated mesh with its topology: the common input of algorithms.
struct Mesh {
  MatX3d V;
  MatX3i F;
  Topology topo;
};

// Vertices within k edges of v (including v), breadth first; `out` is reused to avoid allocation.
void k_ring(const Topology& topo, int v, int k, std::vector<int>& out, std::vector<int>& mark_scratch);

double average_edge_length(const MatX3d& V, const Topology& topo);

}  // namespace dgmesh
