#include "dgmesh/mesh.h"

#include <algorithm>
#include <numeric>
#include <sstream>

#include "dgmesh/errors.h"

namespace dgmesh {

namespace {

// The corners of the faces around one vertex: for face (v, next, prev) in CCW order.
struct Corner {
  int face, local, next, prev;
};

struct VertexReport {
  // Defects found at one vertex, kept so the message can name the first one.
  int bad_edge_other = -1;       // non-manifold edge v-other (more than two faces)
  int misoriented_other = -1;    // two faces traverse v->other in the same direction
  bool bad_fan = false;          // faces around v form more than one fan
};

void gather_corners(const MatX3i& F, const Topology& t, int v, std::vector<Corner>& c) {
  c.clear();
  for (int i = t.vf_offset[v]; i < t.vf_offset[v + 1]; ++i) {
    const int f = t.vf_index[i];
    for (int k = 0; k < 3; ++k)
      if (F(f, k) == v) {
        c.push_back({f, k, F(f, (k + 1) % 3), F(f, (k + 2) % 3)});
        break;
      }
  }
}

int count_next(const std::vector<Corner>& c, int w) {
  int n = 0;
  for (const Corner& x : c) n += (x.next == w);
  return n;
}
int count_prev(const std::vector<Corner>& c, int w) {
  int n = 0;
  for (const Corner& x : c) n += (x.prev == w);
  return n;
}

// Orders the corners of v into one fan, writing the ring. Returns false if they form several fans.
bool order_fan(std::vector<Corner>& c, std::vector<int>& ring, bool& boundary, VertexReport& rep) {
  ring.clear();
  boundary = false;
  if (c.empty()) return true;
  // Check the edges: each v-w edge has at most one face per direction and at most two in all.
  int n_boundary_edges = 0;
  size_t start = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    for (int w : {c[i].next, c[i].prev}) {
      const int nn = count_next(c, w), np = count_prev(c, w);
      if (nn + np > 2) rep.bad_edge_other = w;
      else if (nn > 1 || np > 1) rep.misoriented_other = w;
    }
    if (count_prev(c, c[i].next) == 0) {  // edge v->next has no face on the other side
      ++n_boundary_edges;
      start = i;
      boundary = true;
    }
  }
  if (rep.bad_edge_other >= 0 || rep.misoriented_other >= 0) return false;
  // Walk: the face after corner i around v is the one whose `next` is corner i's `prev`.
  std::swap(c[0], c[start]);
  ring.push_back(c[0].next);
  for (size_t i = 0; i + 1 < c.size(); ++i) {
    size_t j = i + 1;
    while (j < c.size() && c[j].next != c[i].prev) ++j;
    if (j == c.size()) break;
    std::swap(c[i + 1], c[j]);
    ring.push_back(c[i + 1].next);
  }
  const size_t walked = ring.size();
  if (boundary) ring.push_back(c[walked - 1].prev);
  if (walked != c.size() || n_boundary_edges > 1) {
    rep.bad_fan = true;
    return false;
  }
  return true;
}

}  // namespace

Topology build_topology(const MatX3i& F, int n_vertices) {
  Topology t;
  t.n_vertices = n_vertices;
  t.n_faces = static_cast<int>(F.rows());
  const int n = n_vertices, m = t.n_faces;

  // Vertex-face incidence by counting sort.
  t.vf_offset.assign(n + 1, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) ++t.vf_offset[F(f, k) + 1];
  std::partial_sum(t.vf_offset.begin(), t.vf_offset.end(), t.vf_offset.begin());
  t.vf_index.resize(3 * static_cast<size_t>(m));
  {
    std::vector<int> fill(t.vf_offset.begin(), t.vf_offset.end() - 1);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) t.vf_index[fill[F(f, k)]++] = f;
  }

  // Pass 1 (parallel per vertex): ring sizes, owned edges (v < w), defects.
  std::vector<int> ring_size(n, 0), owned_edges(n, 0);
  t.on_boundary.assign(n, 0);
  std::vector<VertexReport> reports(n);
  bool any_defect = false;
#pragma omp parallel reduction(|| : any_defect)
  {
    std::vector<Corner> c;
    std::vector<int> ring;
#pragma omp for schedule(dynamic, 1024)
    for (int v = 0; v < n; ++v) {
      gather_corners(F, t, v, c);
      bool boundary = false;
      if (!order_fan(c, ring, boundary, reports[v])) {
        any_defect = true;
        continue;
      }
      ring_size[v] = static_cast<int>(ring.size());
      t.on_boundary[v] = boundary;
      for (int w : ring) owned_edges[v] += (w > v);
    }
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
      if (r.bad_edge_other >= 0) first_kind = "non-manifold edge", first_v = v, first_w = r.bad_edge_other;
      else if (r.misoriented_other >= 0) first_kind = "inconsistently oriented edge", first_v = v, first_w = r.misoriented_other;
      else if (r.bad_fan) first_kind = "non-manifold vertex", first_v = v;
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

  // Pass 2 (parallel): rings, edges owned by their smaller vertex, edge-face and face-edge links.
  // Every slot is written by exactly one vertex, so no synchronisation is needed.
#pragma omp parallel
  {
    std::vector<Corner> c;
    std::vector<int> ring;
    VertexReport unused;
#pragma omp for schedule(dynamic, 1024)
    for (int v = 0; v < n; ++v) {
      gather_corners(F, t, v, c);
      bool boundary = false;
      order_fan(c, ring, boundary, unused);
      std::copy(ring.begin(), ring.end(), t.vv_index.begin() + t.vv_offset[v]);
      int e = edge_offset[v];
      for (int w : ring) {
        if (w < v) continue;
        t.edges(e, 0) = v;
        t.edges(e, 1) = w;
        for (const Corner& x : c) {
          if (x.next == w) {  // face traverses v->w: its corner k edge
            t.edge_faces(e, 0) = x.face;
            t.face_edges(x.face, x.local) = e;
          }
          if (x.prev == w) {  // face traverses w->v: the edge leaving w's corner
            t.edge_faces(e, 1) = x.face;
            t.face_edges(x.face, (x.local + 2) % 3) = e;
          }
        }
        if (t.edge_faces(e, 0) < 0) std::swap(t.edge_faces(e, 0), t.edge_faces(e, 1));
        ++e;
      }
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
  double sum = 0.0;
#pragma omp parallel for reduction(+ : sum)
  for (int e = 0; e < ne; ++e) sum += (V.row(topo.edges(e, 0)) - V.row(topo.edges(e, 1))).norm();
  return sum / ne;
}

}  // namespace dgmesh
