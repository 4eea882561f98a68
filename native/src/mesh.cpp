#include "dgmesh/mesh.h"

#include <algorithm>
#include <numeric>
#include <sstream>

#include "dgmesh/errors.h"
#include "dgmesh/parallel.h"

namespace dgmesh {

namespace {

struct VertexReport {
  // Defects found at one vertex, kept so the message can name the first one.
  int bad_edge_other = -1;     // non-manifold edge v-other (more than two faces)
  int misoriented_other = -1;  // two faces traverse v->other in the same direction
  bool bad_fan = false;        // faces around v form more than one fan
};

int count_next(const Corner* c, int d, int w) {
  int n = 0;
  for (int i = 0; i < d; ++i) n += (c[i].next == w);
  return n;
}
int count_prev(const Corner* c, int d, int w) {
  int n = 0;
  for (int i = 0; i < d; ++i) n += (c[i].prev == w);
  return n;
}

// Orders the d corners of a vertex (in place) into one counter-clockwise fan: corner i's `prev`
// is corner i+1's `next`. A boundary vertex's fan starts at the face whose edge v->next has no
// face on the other side. Returns false (filling `rep`) on non-manifold or misoriented edges
// and on several fans. One pass over the pairs finds both defects and successors: O(d^2 / 2).
bool order_fan(Corner* c, int d, bool& boundary, VertexReport& rep) {
  boundary = false;
  if (d == 0) return true;
  constexpr int kMaxLocal = 64;  // larger stars (rare) fall back to the heap
  int succ_buf[kMaxLocal];
  char has_pred_buf[kMaxLocal];
  std::vector<int> succ_heap;
  std::vector<char> pred_heap;
  int* succ = succ_buf;
  char* has_pred = has_pred_buf;
  if (d > kMaxLocal) {
    succ_heap.assign(d, -1);
    pred_heap.assign(d, 0);
    succ = succ_heap.data();
    has_pred = pred_heap.data();
  }
  std::fill(succ, succ + d, -1);
  std::fill(has_pred, has_pred + d, 0);
  bool repeated = false;
  for (int i = 0; i < d; ++i)
    for (int j = i + 1; j < d; ++j) {
      repeated |= (c[i].next == c[j].next) | (c[i].prev == c[j].prev);
      if (c[j].next == c[i].prev) succ[i] = j, has_pred[j] = 1;
      if (c[i].next == c[j].prev) succ[j] = i, has_pred[i] = 1;
    }
  if (repeated) {  // rare: classify the defect for the message
    for (int i = 0; i < d; ++i)
      for (int w : {c[i].next, c[i].prev}) {
        const int nn = count_next(c, d, w), np = count_prev(c, d, w);
        if (nn + np > 2)
          rep.bad_edge_other = w;
        else if (nn > 1 || np > 1)
          rep.misoriented_other = w;
      }
    return false;
  }
  int start = 0, starts = 0;
  for (int i = 0; i < d; ++i)
    if (!has_pred[i]) start = i, ++starts;
  boundary = starts > 0;
  // Walk the successors from the start; a second fan shows as unvisited corners.
  Corner ordered_buf[kMaxLocal];
  std::vector<Corner> ordered_heap;
  Corner* ordered = ordered_buf;
  if (d > kMaxLocal) ordered_heap.resize(d), ordered = ordered_heap.data();
  int walked = 0;
  for (int i = start; i >= 0 && walked < d; i = succ[i]) {
    ordered[walked++] = c[i];
    if (!boundary && succ[i] == start) break;
  }
  if (walked != d || starts > 1) {
    rep.bad_fan = true;
    return false;
  }
  std::copy(ordered, ordered + d, c);
  return true;
}

}  // namespace

VertexCorners vertex_corners(const MatX3i& F, int n) {
  // Counting sort of the 3m corners by vertex.
  const int m = static_cast<int>(F.rows());
  VertexCorners vc;
  vc.offset.assign(n + 1, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) ++vc.offset[F(f, k) + 1];
  std::partial_sum(vc.offset.begin(), vc.offset.end(), vc.offset.begin());
  vc.corners.resize(3 * static_cast<size_t>(m));
  std::vector<int> fill(vc.offset.begin(), vc.offset.end() - 1);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) vc.corners[fill[F(f, k)]++] = {f, k, F(f, (k + 1) % 3), F(f, (k + 2) % 3)};
  return vc;
}

Topology build_topology(const MatX3i& F, int n_vertices) {
  return build_topology(vertex_corners(F, n_vertices), static_cast<int>(F.rows()));
}

Topology build_topology(const VertexCorners& vc, int n_faces) {
  Topology t;
  t.n_vertices = static_cast<int>(vc.offset.size()) - 1;
  t.n_faces = n_faces;
  const int n = t.n_vertices, m = n_faces;
  t.vf_offset = vc.offset;
  t.vf_index.resize(vc.corners.size());

  // Pass 1 (parallel per vertex): order each vertex's corners into its fan, count ring sizes and
  // the edges each vertex owns (v < w), find defects.
  std::vector<Corner> fan = vc.corners;
  std::vector<int> ring_size(n, 0), owned_edges(n, 0);
  t.on_boundary.assign(n, 0);
  std::vector<VertexReport> reports(n);
  bool any_defect = false;
#pragma omp parallel for schedule(dynamic, 2048) reduction(|| : any_defect) if (n >= kParallelMin)
  for (int v = 0; v < n; ++v) {
    Corner* c = fan.data() + vc.offset[v];
    const int d = vc.offset[v + 1] - vc.offset[v];
    bool boundary = false;
    if (!order_fan(c, d, boundary, reports[v])) {
      any_defect = true;
      continue;
    }
    ring_size[v] = d + (boundary ? 1 : 0);
    t.on_boundary[v] = boundary;
    for (int i = 0; i < d; ++i) owned_edges[v] += (c[i].next > v);
    if (boundary) owned_edges[v] += (c[d - 1].prev > v);
  }
  if (any_defect) {
    int bad_edges = 0, misoriented = 0, bad_fans = 0, first_v = -1, first_w = -1;
    const char* first_kind = nullptr;
    for (int v = 0; v < n; ++v) {
      const VertexReport& r = reports[v];
      bad_edges += (r.bad_edge_other > v);
      misoriented += (r.misoriented_other > v);
      bad_fans += r.bad_fan;
      if (first_kind) continue;
      if (r.bad_edge_other >= 0)
        first_kind = "non-manifold edge", first_v = v, first_w = r.bad_edge_other;
      else if (r.misoriented_other >= 0)
        first_kind = "inconsistently oriented edge", first_v = v, first_w = r.misoriented_other;
      else if (r.bad_fan)
        first_kind = "non-manifold vertex", first_v = v;
    }
    std::ostringstream s;
    s << "mesh is not manifold:";
    if (bad_edges) s << " " << bad_edges << " non-manifold edge(s) (more than two faces);";
    if (misoriented) s << " " << misoriented << " edge(s) with inconsistent face orientation (flipped normals);";
    if (bad_fans) s << " " << bad_fans << " non-manifold vertex(es) (faces touching only at a vertex);";
    s << " first: " << first_kind << " at vertex " << first_v;
    if (first_w >= 0) s << "-" << first_w;
    throw MeshError(s.str());
  }

  t.vv_offset.assign(n + 1, 0);
  std::vector<int> edge_offset(n + 1, 0);
  for (int v = 0; v < n; ++v) {
    t.vv_offset[v + 1] = t.vv_offset[v] + ring_size[v];
    edge_offset[v + 1] = edge_offset[v] + owned_edges[v];
  }
  t.vv_index.resize(t.vv_offset[n]);
  t.edges.resize(edge_offset[n], 2);
  t.face_edges.resize(m, 3);
  t.edge_faces.setConstant(edge_offset[n], 2, -1);

  // Pass 2 (parallel): rings, faces in fan order, edges owned by their smaller vertex with their
  // faces. In fan order, edge v-ring[i] has corner i on its left (v -> ring[i]) and corner i-1 on
  // its right. Every slot is written by exactly one vertex: no synchronisation needed.
#pragma omp parallel for schedule(dynamic, 2048) if (n >= kParallelMin)
  for (int v = 0; v < n; ++v) {
    const Corner* c = fan.data() + vc.offset[v];
    const int d = vc.offset[v + 1] - vc.offset[v];
    if (d == 0) continue;
    const bool boundary = t.on_boundary[v];
    int* ring = t.vv_index.data() + t.vv_offset[v];
    for (int i = 0; i < d; ++i) {
      ring[i] = c[i].next;
      t.vf_index[vc.offset[v] + i] = c[i].face;
    }
    if (boundary) ring[d] = c[d - 1].prev;
    int e = edge_offset[v];
    const int size = d + (boundary ? 1 : 0);
    for (int i = 0; i < size; ++i) {
      const int w = ring[i];
      if (w < v) continue;
      t.edges(e, 0) = v;
      t.edges(e, 1) = w;
      const Corner* left = i < d ? &c[i] : nullptr;                                // traverses v -> w
      const Corner* right = i > 0 ? &c[i - 1] : (boundary ? nullptr : &c[d - 1]);  // w -> v
      int slot = 0;
      if (left) {
        t.edge_faces(e, slot++) = left->face;
        t.face_edges(left->face, left->local) = e;
      }
      if (right) {
        t.edge_faces(e, slot++) = right->face;
        t.face_edges(right->face, (right->local + 2) % 3) = e;
      }
      ++e;
    }
  }

  // Boundary loops: follow boundary half-edges v -> next (the ring's first neighbour is the
  // head of v's outgoing boundary edge, as the fan starts at the face without a left neighbour).
  std::vector<char> visited(n, 0);
  for (int v = 0; v < n; ++v) {
    if (!t.on_boundary[v] || visited[v]) continue;
    std::vector<int> loop;
    int u = v;
    while (!visited[u]) {
      visited[u] = 1;
      loop.push_back(u);
      u = t.vv_index[t.vv_offset[u]];
    }
    t.boundary_loops.push_back(std::move(loop));
  }

  // Components by union-find over edges.
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int e = 0; e < t.edges.rows(); ++e) {
    const int a = find(t.edges(e, 0)), b = find(t.edges(e, 1));
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  t.component.assign(n, -1);
  std::vector<int> label(n, -1);
  for (int v = 0; v < n; ++v) {
    const int r = find(v);
    if (label[r] < 0) label[r] = t.n_components++;
    t.component[v] = label[r];
  }
  return t;
}

void k_ring(const Topology& topo, int v, int k, std::vector<int>& out, std::vector<int>& mark) {
  // `mark` holds a per-vertex stamp; it must be sized n_vertices and is left cleared.
  if (mark.size() != static_cast<size_t>(topo.n_vertices)) mark.assign(topo.n_vertices, 0);
  out.clear();
  out.push_back(v);
  mark[v] = 1;
  size_t begin = 0;
  for (int ring = 0; ring < k; ++ring) {
    const size_t end = out.size();
    for (size_t i = begin; i < end; ++i) {
      const int u = out[i];
      for (int j = topo.vv_offset[u]; j < topo.vv_offset[u + 1]; ++j) {
        const int w = topo.vv_index[j];
        if (!mark[w]) {
          mark[w] = 1;
          out.push_back(w);
        }
      }
    }
    begin = end;
  }
  for (int u : out) mark[u] = 0;
}

double average_edge_length(const MatX3d& V, const Topology& topo) {
  const int ne = topo.n_edges();
  if (ne == 0) return 0.0;
  const double sum = ordered_sums<1>(ne, ne >= kParallelMin, [&](int e, std::array<double, 1>& s) {
    s[0] += (V.row(topo.edges(e, 0)) - V.row(topo.edges(e, 1))).norm();
  })[0];
  return sum / ne;
}

}  // namespace dgmesh
