// auto_unwrap(): disk charts by VSA segmentation and splitting, each unwrapped by unwrap(), packed
// on shelves (charts.h).
#include "dgmesh/charts.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <queue>
#include <string>
#include <tuple>
#include <utility>

#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/mesh.h"
#include "dgmesh/segment.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {

using detail::cross2;
using detail::kInf;
using detail::kPi;
using detail::Vec2;

// Faces of the mesh and their neighbours across edges, for work restricted to one chart.
struct Surface {
  const Topology& topo;
  MatX3d N;                // unit face normals
  VecXd A;                 // face areas
  MatX3d C;                // face centroids
  std::vector<int> local;  // face -> index in the chart being split, -1 outside
  std::vector<int> rep;    // face -> the first triangle of its group

  int neighbour(int f, int k) const {
    const int e = topo.face_edges(f, k);
    return topo.edge_faces(e, 0) == f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
  }
};

using Heap = std::priority_queue<std::tuple<double, int, int>, std::vector<std::tuple<double, int, int>>,
                                 std::greater<std::tuple<double, int, int>>>;

// Multi-source growth inside the chart S (s.local set): each face goes to the seed whose front
// reaches it first. cumulative: Dijkstra over centroid distances; otherwise VSA's priority
// A |n - P_k|^2 against the proxies P. Every region is connected (grown across edges).
std::vector<int> grow(const Surface& s, const std::vector<int>& S, const std::vector<int>& seeds,
                      const std::vector<Vec3>& proxies, bool cumulative) {
  std::vector<int> lab(S.size(), -1);
  std::vector<double> dist(S.size(), kInf);
  Heap heap;
  for (size_t k = 0; k < seeds.size(); ++k) {
    dist[seeds[k]] = 0;
    heap.emplace(0.0, seeds[k], static_cast<int>(k));
  }
  while (!heap.empty()) {
    const auto [d, i, k] = heap.top();
    heap.pop();
    if (lab[i] >= 0) continue;
    lab[i] = k;
    const int f = S[i];
    for (int j = 0; j < 3; ++j) {
      const int g = s.neighbour(f, j);
      if (g < 0 || s.local[g] < 0 || lab[s.local[g]] >= 0) continue;
      const int gi = s.local[g];
      const double p =
          cumulative ? d + (s.C.row(f) - s.C.row(g)).norm() : s.A[g] * (Vec3(s.N.row(g)) - proxies[k]).squaredNorm();
      if (p < dist[gi]) {
        dist[gi] = p;
        heap.emplace(p, gi, k);
      }
    }
  }
  return lab;
}

// The face of S farthest (centroid-distance Dijkstra) from local face `from`.
int farthest(const Surface& s, const std::vector<int>& S, int from) {
  std::vector<double> dist(S.size(), kInf);
  Heap heap;
  dist[from] = 0;
  heap.emplace(0.0, from, 0);
  int last = from;
  while (!heap.empty()) {
    const auto [d, i, unused] = heap.top();
    heap.pop();
    if (d > dist[i]) continue;
    last = i;
    const int f = S[i];
    for (int j = 0; j < 3; ++j) {
      const int g = s.neighbour(f, j);
      if (g < 0 || s.local[g] < 0) continue;
      const int gi = s.local[g];
      const double p = d + (s.C.row(f) - s.C.row(g)).norm();
      if (p < dist[gi]) {
        dist[gi] = p;
        heap.emplace(p, gi, 0);
      }
    }
  }
  return last;  // the last face settled is the farthest
}

// The connected pieces (across edges) of the faces of S with equal lab (s.local set for S).
void add_pieces(const Surface& s, const std::vector<int>& S, const std::vector<int>& lab,
                std::vector<std::vector<int>>& out) {
  std::vector<char> seen(S.size(), 0);
  for (size_t i0 = 0; i0 < S.size(); ++i0) {
    if (seen[i0]) continue;
    std::vector<int> piece = {S[i0]};
    seen[i0] = 1;
    for (size_t q = 0; q < piece.size(); ++q)
      for (int j = 0; j < 3; ++j) {
        const int g = s.neighbour(piece[q], j);
        if (g < 0 || s.local[g] < 0 || seen[s.local[g]] || lab[s.local[g]] != lab[i0]) continue;
        seen[s.local[g]] = 1;
        piece.push_back(g);
      }
    out.push_back(std::move(piece));
  }
}

// Splits the chart S (at least two groups, connected): a 2-proxy VSA (a few Lloyd steps) grown
// from its two mutually farthest faces, so the cut follows the normal's turn; when that leaves one
// part under 5% of the faces, a plain geodesic split from the same seeds. Each group goes to the
// side of its first triangle; returns the connected pieces of both sides (at least two).
std::vector<std::vector<int>> split(Surface& s, const std::vector<int>& S) {
  for (size_t i = 0; i < S.size(); ++i) s.local[S[i]] = static_cast<int>(i);
  const int a = farthest(s, S, 0);
  int b = farthest(s, S, a);
  if (b == a) b = a == 0 ? 1 : 0;
  std::vector<int> seeds = {a, b};
  std::vector<Vec3> proxies = {Vec3(s.N.row(S[a])), Vec3(s.N.row(S[b]))};
  std::vector<int> lab;
  for (int it = 0; it < 4; ++it) {
    lab = grow(s, S, seeds, proxies, false);
    std::vector<Vec3> sum(2, Vec3::Zero());
    for (size_t i = 0; i < S.size(); ++i) sum[lab[i]] += s.A[S[i]] * Vec3(s.N.row(S[i]));
    for (int k = 0; k < 2; ++k)
      if (sum[k].norm() > 0) proxies[k] = sum[k].normalized();
    std::vector<double> best(2, kInf);
    for (size_t i = 0; i < S.size(); ++i) {
      const int k = lab[i];
      const double e = (Vec3(s.N.row(S[i])) - proxies[k]).squaredNorm();
      if (e < best[k]) {
        best[k] = e;
        seeds[k] = static_cast<int>(i);
      }
    }
  }
  lab = grow(s, S, seeds, proxies, false);
  const long n0 = std::count(lab.begin(), lab.end(), 0);
  const long small = std::min<long>(n0, static_cast<long>(S.size()) - n0);
  if (small < std::max<long>(1, static_cast<long>(0.05 * S.size()))) lab = grow(s, S, {a, b}, proxies, true);
  auto harmonise = [&]() {
    std::vector<int> own(lab);
    for (size_t i = 0; i < S.size(); ++i) lab[i] = own[s.local[s.rep[S[i]]]];
    return std::count(lab.begin(), lab.end(), lab[0]) < static_cast<long>(S.size());
  };
  if (!harmonise()) {  // every group went to one side: the seed's group against the rest
    for (size_t i = 0; i < S.size(); ++i) lab[i] = s.rep[S[i]] == s.rep[S[a]] ? 0 : 1;
  }
  std::vector<std::vector<int>> parts;
  add_pieces(s, S, lab, parts);
  for (int f : S) s.local[f] = -1;
  return parts;
}

// One chart's triangles as a mesh of its own, cut open along `cuts` (sorted mesh edges inside the
// chart): corners of a vertex in two chart faces across an edge that is not a cut are one vertex.
struct SubMesh {
  std::vector<int> verts;  // local vertex -> vertex of V
  MatX3d V;
  MatX3i F;
};

SubMesh submesh(const Surface& s, const MatX3d& V, const MatX3i& F, const std::vector<int>& faces,
                const std::vector<int>& cuts) {
  const int n = static_cast<int>(faces.size());
  std::vector<int> local(F.rows(), -1);
  for (int i = 0; i < n; ++i) local[faces[i]] = i;
  std::vector<int> parent(3 * n);
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> root = [&](int x) { return parent[x] == x ? x : parent[x] = root(parent[x]); };
  auto corner = [&](int i, int v) {
    const int f = faces[i];
    return 3 * i + (F(f, 0) == v ? 0 : F(f, 1) == v ? 1 : 2);
  };
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      const int e = s.topo.face_edges(faces[i], k);
      const int g = s.neighbour(faces[i], k);
      if (g < 0 || local[g] < 0 || local[g] < i || std::binary_search(cuts.begin(), cuts.end(), e)) continue;
      for (int j = 0; j < 2; ++j) {
        const int v = s.topo.edges(e, j);
        parent[root(corner(i, v))] = root(corner(local[g], v));
      }
    }
  SubMesh m;
  std::vector<int> id(3 * n, -1);
  m.F.resize(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      int& r = id[root(3 * i + k)];
      if (r < 0) {
        r = static_cast<int>(m.verts.size());
        m.verts.push_back(F(faces[i], k));
      }
      m.F(i, k) = r;
    }
  m.V.resize(static_cast<Eigen::Index>(m.verts.size()), 3);
  for (size_t i = 0; i < m.verts.size(); ++i) m.V.row(i) = V.row(m.verts[i]);
  return m;
}

// Makes the chart `faces` (connected) a disk by cutting it open, when it is a sphere with holes
// (genus 0, b >= 2 boundary loops): adds to `cuts` the shortest edge path (3D length) from one
// loop to another through interior vertices, b - 1 times, never along an edge inside a group.
// Returns whether the cut-open chart is a disk (false: closed, of higher genus, or no such path).
bool cut_to_disk(const Surface& s, const MatX3d& V, const MatX3i& F, const std::vector<int>& faces,
                 std::vector<int>& cuts) {
  std::vector<int> local(faces.size());  // the submesh's faces, all of them
  std::iota(local.begin(), local.end(), 0);
  for (;;) {
    const SubMesh m = submesh(s, V, F, faces, cuts);
    if (chart_is_disk(m.F, local)) return true;
    // Half-edges of the cut-open chart: boundary ones have no twin.
    const int nv = static_cast<int>(m.verts.size());
    std::vector<std::tuple<int, int, int>> he;  // (a, b, mesh edge)
    for (Eigen::Index i = 0; i < m.F.rows(); ++i)
      for (int k = 0; k < 3; ++k) he.emplace_back(m.F(i, k), m.F(i, (k + 1) % 3), s.topo.face_edges(faces[i], k));
    std::sort(he.begin(), he.end());
    auto twin = [&](int a, int b) {
      auto it = std::lower_bound(he.begin(), he.end(), std::make_tuple(b, a, -1));
      return it != he.end() && std::get<0>(*it) == b && std::get<1>(*it) == a;
    };
    std::vector<int> next(nv, -1), loop(nv, -1);
    long edges2 = 0;
    for (const auto& [a, b, e] : he) {
      if (twin(a, b)) {
        ++edges2;
        continue;
      }
      edges2 += 2;
      if (next[a] >= 0) return false;  // pinched
      next[a] = b;
    }
    int loops = 0;
    for (int v = 0; v < nv; ++v) {
      if (next[v] < 0 || loop[v] >= 0) continue;
      for (int w = v; loop[w] < 0; w = next[w]) {
        loop[w] = loops;
        if (next[w] < 0) return false;
      }
      ++loops;
    }
    const long chi = nv - edges2 / 2 + static_cast<long>(faces.size());
    if (loops < 2 || chi + loops != 2) return false;  // closed, or not genus 0
    // Dijkstra from loop 0 over interior edges, to the first vertex of another loop.
    std::vector<std::vector<std::pair<int, int>>> adj(nv);  // (neighbour, mesh edge)
    for (const auto& [a, b, e] : he) {
      if (!twin(a, b)) continue;
      const int f0 = s.topo.edge_faces(e, 0), f1 = s.topo.edge_faces(e, 1);
      if (s.rep[f0] == s.rep[f1]) continue;  // inside a polygon
      adj[a].emplace_back(b, e);
    }
    std::vector<double> dist(nv, kInf);
    std::vector<int> via(nv, -1), from(nv, -1);
    Heap heap;
    for (int v = 0; v < nv; ++v)
      if (loop[v] == 0) {
        dist[v] = 0;
        heap.emplace(0.0, v, -1);
      }
    int hit = -1;
    while (!heap.empty()) {
      const auto [d, v, unused] = heap.top();
      heap.pop();
      if (d > dist[v]) continue;
      if (loop[v] > 0) {
        hit = v;
        break;
      }
      if (loop[v] < 0 || d == 0)
        for (const auto& [w, e] : adj[v]) {
          if (loop[w] == 0) continue;
          const double p = d + (m.V.row(v) - m.V.row(w)).norm();
          if (p < dist[w]) {
            dist[w] = p;
            via[w] = e;
            from[w] = v;
            heap.emplace(p, w, 0);
          }
        }
    }
    if (hit < 0) return false;
    for (int v = hit; via[v] >= 0; v = from[v]) cuts.insert(std::upper_bound(cuts.begin(), cuts.end(), via[v]), via[v]);
  }
}

// A single triangle laid flat with its 3D edge lengths.
MatX2d flat_triangle(const MatX3d& V) {
  MatX2d uv(3, 2);
  const Vec3 e1 = V.row(1) - V.row(0), e2 = V.row(2) - V.row(0);
  const double l1 = e1.norm();
  const double x = e1.dot(e2) / l1;
  uv << 0, 0, l1, 0, x, e1.cross(e2).norm() / l1;
  return uv;
}

struct Chart {
  std::vector<int> faces;
  std::vector<int> cuts;  // sorted mesh edges inside the chart along which it is cut open
  SubMesh mesh;
  MatX2d uv;                // per chart vertex
  double stretch = 1;       // L2 stretch of its own map (eq. 5.5)
  double area = 0;          // 3D area
  bool failed = false;      // the map has a flipped or zero-area triangle (or none could be made)
  bool splittable = false;  // holds more than one group
  long id = 0;              // unique per map made, for the merge step
};

// Shelf packing (charts.h, step 4): the corner UVs of every triangle.
double pack(const VecXd& A, std::vector<Chart>& charts, double margin, MatX2d& out) {
  const int k = static_cast<int>(charts.size());
  std::vector<Vec2> size(k), offset(k);
  std::vector<MatX2d> placed(k);
  double box_area = 0;
  for (int c = 0; c < k; ++c) {
    Chart& ch = charts[c];
    const MatX3i& Fc = ch.mesh.F;
    double a3 = 0, auv = 0, signed_uv = 0;
    for (int i = 0; i < Fc.rows(); ++i) {
      a3 += A[ch.faces[i]];
      const Vec2 p0 = ch.uv.row(Fc(i, 0)), p1 = ch.uv.row(Fc(i, 1)), p2 = ch.uv.row(Fc(i, 2));
      auv += 0.5 * std::abs(cross2(p1 - p0, p2 - p0));
      signed_uv += cross2(p1 - p0, p2 - p0);
    }
    MatX2d P = ch.uv.rowwise() - ch.uv.colwise().mean();
    P *= auv > 0 ? std::sqrt(a3 / auv) : 1.0;
    if (signed_uv < 0) P.col(0) = -P.col(0);  // every chart counter-clockwise, as the triangles in 3D
    // The rotation with the smallest bounding box among 16 angles of a quarter turn.
    double best = kInf, best_t = 0;
    for (int r = 0; r < 16; ++r) {
      const double t = 0.5 * kPi * r / 16, cs = std::cos(t), sn = std::sin(t);
      const Eigen::ArrayXd x = (cs * P.col(0) - sn * P.col(1)).array();
      const Eigen::ArrayXd y = (sn * P.col(0) + cs * P.col(1)).array();
      const double area = (x.maxCoeff() - x.minCoeff()) * (y.maxCoeff() - y.minCoeff());
      if (area < best) {
        best = area;
        best_t = t;
      }
    }
    const double cs = std::cos(best_t), sn = std::sin(best_t);
    MatX2d Q(P.rows(), 2);
    Q.col(0) = cs * P.col(0) - sn * P.col(1);
    Q.col(1) = sn * P.col(0) + cs * P.col(1);
    Q = Q.rowwise() - Q.colwise().minCoeff();
    Vec2 sz = Q.colwise().maxCoeff().transpose();
    if (sz.x() < sz.y()) {                     // lie down: shelves of low charts waste less
      const Eigen::VectorXd old_x = Q.col(0);  // a quarter turn (a reflection would flip the triangles)
      Q.col(0) = (sz.y() - Q.col(1).array()).matrix();
      Q.col(1) = old_x;
      std::swap(sz.x(), sz.y());
    }
    placed[c] = std::move(Q);
    size[c] = sz;
    box_area += sz.x() * sz.y();
  }
  const double side = std::sqrt(box_area);
  const double gap = margin * side;
  double width = 0;
  for (int c = 0; c < k; ++c) width = std::max(width, size[c].x());
  width = std::max(width, side * (1 + margin * std::sqrt(static_cast<double>(k))));
  std::vector<int> order(k);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return size[a].y() > size[b].y(); });
  double x = 0, y = 0, shelf = 0, extent_x = 0;
  for (int c : order) {
    if (x > 0 && x + size[c].x() > width) {
      y += shelf + gap;
      x = 0;
      shelf = 0;
    }
    offset[c] = Vec2(x, y);
    x += size[c].x() + gap;
    extent_x = std::max(extent_x, x - gap);
    shelf = std::max(shelf, size[c].y());
  }
  const double extent = std::max(extent_x, y + shelf);
  const double scale = extent > 0 ? 1.0 / extent : 1.0;
  double used = 0;
  for (int c = 0; c < k; ++c) {
    const Chart& ch = charts[c];
    for (int i = 0; i < ch.mesh.F.rows(); ++i) {
      Vec2 p[3];
      for (int j = 0; j < 3; ++j) {
        p[j] = (Vec2(placed[c].row(ch.mesh.F(i, j))) + offset[c]) * scale;
        out.row(3 * ch.faces[i] + j) = p[j];
      }
      used += 0.5 * std::abs(cross2(p[1] - p[0], p[2] - p[0]));
    }
  }
  return used;
}

}  // namespace

bool chart_is_disk(const MatX3i& F, const std::vector<int>& faces) {
  if (faces.empty()) return false;
  std::vector<std::pair<int, int>> he;  // directed half-edges
  std::vector<int> verts;
  he.reserve(3 * faces.size());
  for (int f : faces) {
    if (f < 0 || f >= F.rows()) throw MeshError("chart_is_disk: face index out of range");
    for (int k = 0; k < 3; ++k) {
      he.emplace_back(F(f, k), F(f, (k + 1) % 3));
      verts.push_back(F(f, k));
    }
  }
  std::sort(he.begin(), he.end());
  if (std::adjacent_find(he.begin(), he.end()) != he.end()) return false;  // non-manifold or inconsistent
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  auto id = [&](int v) { return static_cast<int>(std::lower_bound(verts.begin(), verts.end(), v) - verts.begin()); };
  const int nv = static_cast<int>(verts.size());
  std::vector<int> next(nv, -1);
  long interior = 0, boundary = 0;
  for (const auto& [a, b] : he) {
    if (std::binary_search(he.begin(), he.end(), std::make_pair(b, a))) {
      ++interior;
      continue;
    }
    ++boundary;
    int& n = next[id(a)];
    if (n >= 0) return false;  // two boundary edges leave a: a pinched vertex
    n = id(b);
  }
  if (boundary == 0) return false;  // closed
  const long edges = boundary + interior / 2;
  if (nv - edges + static_cast<long>(faces.size()) != 1) return false;
  // One boundary loop through every boundary edge.
  const int start = id(std::find_if(he.begin(), he.end(), [&](const auto& h) {
                         return !std::binary_search(he.begin(), he.end(), std::make_pair(h.second, h.first));
                       })->first);
  long steps = 0;
  int v = start;
  do {
    v = next[v];
    ++steps;
  } while (v >= 0 && v != start && steps <= boundary);
  if (v != start || steps != boundary) return false;
  // Connected (with no pinched vertex, vertex-connected is edge-connected).
  std::vector<int> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> root = [&](int x) { return parent[x] == x ? x : parent[x] = root(parent[x]); };
  int components = nv;
  for (const auto& [a, b] : he) {
    const int ra = root(id(a)), rb = root(id(b));
    if (ra != rb) {
      parent[ra] = rb;
      --components;
    }
  }
  return components == 1;
}

AutoUnwrapResult auto_unwrap(const MatX3d& V, const MatX3i& F, const AutoUnwrapOptions& opt,
                             const ProgressFn& progress_fn) {
  if (!(opt.max_stretch > 1.0))
    throw MeshError("max_stretch must be above 1 (the L2 stretch of an isometry), got " +
                    std::to_string(opt.max_stretch));
  if (!(opt.target_stretch > 1.0))
    throw MeshError("target_stretch must be above 1 (the L2 stretch of an isometry), got " +
                    std::to_string(opt.target_stretch));
  if (opt.charts < 0) throw MeshError("charts must be >= 0 (0: automatic), got " + std::to_string(opt.charts));
  if (opt.max_charts < 1) throw MeshError("max_charts must be >= 1, got " + std::to_string(opt.max_charts));
  if (!(opt.margin >= 0.0 && opt.margin < 0.25))
    throw MeshError("margin must be in [0, 0.25), got " + std::to_string(opt.margin));
  const Mesh mesh = make_mesh(V, F, kSurface);
  const int nf = static_cast<int>(F.rows());
  if (opt.groups.size() != 0 && opt.groups.size() != nf)
    throw MeshError("groups must have one value per triangle (" + std::to_string(nf) + "), got " +
                    std::to_string(opt.groups.size()));
  if (opt.groups.size() != 0 && opt.groups.minCoeff() < 0) throw MeshError("groups must be >= 0");
  if (opt.charts > nf)
    throw MeshError("cannot make " + std::to_string(opt.charts) + " charts from " + std::to_string(nf) + " triangles");
  Progress progress(progress_fn);
  progress(0.0);

  Surface s{mesh.topo,     face_normals(mesh.V, mesh.F), face_areas(mesh.V, mesh.F),
            MatX3d(nf, 3), std::vector<int>(nf, -1),     std::vector<int>(nf)};
  for (int f = 0; f < nf; ++f) s.C.row(f) = (mesh.V.row(F(f, 0)) + mesh.V.row(F(f, 1)) + mesh.V.row(F(f, 2))) / 3.0;
  std::iota(s.rep.begin(), s.rep.end(), 0);
  if (opt.groups.size() != 0) {
    std::vector<int> first(opt.groups.maxCoeff() + 1, -1);
    for (int f = 0; f < nf; ++f) {
      int& r = first[opt.groups[f]];
      if (r < 0) r = f;
      s.rep[f] = r;
    }
  }

  AutoUnwrapResult res;
  SegmentOptions so;
  so.segments = opt.charts > 0 ? opt.charts : std::min(8, nf);
  const double seg_share = 0.1;
  const SegmentResult seg =
      segment(mesh, so,
              progress_fn ? ProgressFn([&progress_fn, seg_share](double f) { return progress_fn(seg_share * f); })
                          : ProgressFn());
  // The segments, each group in the segment of its first triangle, as connected pieces.
  std::vector<std::vector<int>> pieces;
  {
    std::vector<int> all(nf), lab(nf);
    std::iota(all.begin(), all.end(), 0);
    for (int f = 0; f < nf; ++f) {
      s.local[f] = f;
      lab[f] = seg.labels[s.rep[f]];
    }
    add_pieces(s, all, lab, pieces);
    std::fill(s.local.begin(), s.local.end(), -1);
  }
  res.initial_charts = static_cast<int>(pieces.size());

  auto can_split = [&](const std::vector<int>& S) {
    return std::any_of(S.begin(), S.end(), [&](int f) { return s.rep[f] != s.rep[S[0]]; });
  };
  // Step 2: cut open or split pieces until every one is a disk (or a single group): (faces, cuts).
  using Piece = std::pair<std::vector<int>, std::vector<int>>;
  auto make_disks = [&](std::vector<std::vector<int>> todo) {
    std::vector<Piece> disks;
    while (!todo.empty()) {
      std::vector<int> S = std::move(todo.back());
      todo.pop_back();
      std::vector<int> cuts;
      if (!can_split(S) || chart_is_disk(F, S)) {
        disks.emplace_back(std::move(S), std::move(cuts));
      } else if (cut_to_disk(s, mesh.V, F, S, cuts)) {
        ++res.path_cuts;
        disks.emplace_back(std::move(S), std::move(cuts));
      } else {
        for (auto& p : split(s, S)) todo.push_back(std::move(p));
        ++res.topology_splits;
      }
    }
    return disks;
  };
  // Step 3: one disk's own map, its L2 stretch and 3D area.
  long next_id = 0;
  auto unwrap_chart = [&](Piece piece) {
    Chart ch;
    ch.id = next_id++;
    ch.mesh = submesh(s, mesh.V, F, piece.first, piece.second);
    ch.faces = std::move(piece.first);
    ch.cuts = std::move(piece.second);
    for (int f : ch.faces) ch.area += s.A[f];
    ch.splittable = can_split(ch.faces);
    if (ch.faces.size() == 1) {
      ch.uv = flat_triangle(ch.mesh.V);
      return ch;
    }
    try {
      UnwrapResult r = unwrap(ch.mesh.V, ch.mesh.F, opt.unwrap);
      const UvMetrics& m = r.steps[r.chosen].metrics;
      ch.failed = m.flipped > 0 || m.zero_area > 0;
      ch.stretch = m.stretch_l2;
      ch.uv = std::move(r.uv);
    } catch (const MeshError&) {  // cannot be for a disk; split it all the same
      if (!ch.splittable)
        throw MeshError("auto_unwrap: a polygon of " + std::to_string(ch.faces.size()) +
                        " triangles is not a disk and cannot be unwrapped");
      ch.failed = true;
      ch.stretch = kInf;
    }
    if (!std::isfinite(ch.stretch)) ch.failed = true;
    return ch;
  };

  std::vector<Chart> charts;
  {
    std::vector<Piece> disks = make_disks(std::move(pieces));
    long done = 0;
    for (auto& d : disks) {
      done += static_cast<long>(d.first.size());
      charts.push_back(unwrap_chart(std::move(d)));
      progress(seg_share + 0.4 * static_cast<double>(done) / nf);
    }
  }
  double total_area = 0;
  for (int f = 0; f < nf; ++f) total_area += s.A[f];
  // The whole map's L2 stretch: every chart is scaled to its 3D area when packed, so the packed
  // map's eq. 5.5 is the area-weighted root mean square of the charts' own.
  auto energy = [](const Chart& c) { return c.area * c.stretch * c.stretch; };
  auto whole = [&]() {
    double e = 0;
    for (const Chart& c : charts) e += energy(c);
    return std::sqrt(e / total_area);
  };

  // Step 3: split the worst chart (a failed map first, then one above max_stretch, then the one
  // whose stretch costs most, A (s^2 - 1)) until the whole map is within target_stretch. Only the
  // two new charts are unwrapped; the others keep their maps.
  const double start_excess = std::max(1e-12, whole() - opt.target_stretch);
  double shown = seg_share + 0.4;
  for (;;) {
    int worst = -1;
    int rank = 0;  // 3: failed map, 2: above max_stretch, 1: above target_stretch overall
    double cost = -1;
    const bool over_target = whole() > opt.target_stretch;
    const bool below_cap = static_cast<int>(charts.size()) + 1 <= opt.max_charts;
    for (size_t c = 0; c < charts.size(); ++c) {
      const Chart& ch = charts[c];
      if (!ch.splittable) continue;
      const int r = ch.failed ? 3 : ch.stretch > opt.max_stretch ? 2 : over_target ? 1 : 0;
      if (r == 0 || (r < 3 && !below_cap)) continue;
      const double k = ch.failed ? ch.area : ch.area * (ch.stretch * ch.stretch - 1);
      if (r > rank || (r == rank && k > cost)) {
        worst = static_cast<int>(c);
        rank = r;
        cost = k;
      }
    }
    if (worst < 0) break;
    std::vector<int> S = std::move(charts[worst].faces);
    charts.erase(charts.begin() + worst);
    for (auto& d : make_disks(split(s, S))) charts.push_back(unwrap_chart(std::move(d)));
    ++res.stretch_splits;
    const double w = whole();
    if (std::isfinite(w))
      shown =
          std::max(shown, seg_share + 0.4 + 0.4 * std::clamp(1 - (w - opt.target_stretch) / start_excess, 0.0, 1.0));
    progress(shown);
  }

  // Step 4: merge neighbouring charts while the union is a disk whose map has no failed triangle,
  // stays within max_stretch, and the whole map stays within target_stretch (charts cut only by
  // the initial segmentation or a topology split often share a developable surface: a CAD part's
  // plane and cylinder). Pairs are tried in decreasing length of their common border.
  if (opt.merge) {
    const Topology& topo = mesh.topo;
    std::vector<int> owner(nf);
    std::vector<std::pair<long, long>> tried;  // chart ids of pairs tried, sorted
    for (;;) {
      for (size_t c = 0; c < charts.size(); ++c)
        for (int f : charts[c].faces) owner[f] = static_cast<int>(c);
      std::vector<std::tuple<double, int, int>> pairs;  // (-common length, c, d)
      {
        std::vector<std::tuple<int, int, double>> border;
        for (int e = 0; e < topo.n_edges(); ++e) {
          const int f0 = topo.edge_faces(e, 0), f1 = topo.edge_faces(e, 1);
          if (f0 < 0 || f1 < 0 || owner[f0] == owner[f1]) continue;
          const double len = (mesh.V.row(topo.edges(e, 0)) - mesh.V.row(topo.edges(e, 1))).norm();
          border.emplace_back(std::min(owner[f0], owner[f1]), std::max(owner[f0], owner[f1]), len);
        }
        std::sort(border.begin(), border.end());
        for (size_t i = 0; i < border.size();) {
          size_t j = i;
          double len = 0;
          while (j < border.size() && std::get<0>(border[j]) == std::get<0>(border[i]) &&
                 std::get<1>(border[j]) == std::get<1>(border[i]))
            len += std::get<2>(border[j++]);
          pairs.emplace_back(-len, std::get<0>(border[i]), std::get<1>(border[i]));
          i = j;
        }
        std::sort(pairs.begin(), pairs.end());
      }
      double e_all = 0;
      for (const Chart& c : charts) e_all += energy(c);
      if (!std::isfinite(e_all)) break;  // a chart without a usable map (kept as a warning below)
      const double budget = opt.target_stretch * opt.target_stretch * total_area;
      bool merged = false;
      for (const auto& [neg_len, c, d] : pairs) {
        const Chart &a = charts[c], &b = charts[d];
        if (a.failed || b.failed) continue;
        const std::pair<long, long> key = {std::min(a.id, b.id), std::max(a.id, b.id)};
        if (std::binary_search(tried.begin(), tried.end(), key)) continue;
        // Skip pairs that could fit only if the union stretched less than its worse part (a
        // heuristic: it rarely does; it saves unwrapping the union).
        const double lower = (a.area + b.area) * std::max(a.stretch, b.stretch) * std::max(a.stretch, b.stretch);
        if (std::max(a.stretch, b.stretch) > opt.max_stretch || e_all - energy(a) - energy(b) + lower > budget) {
          tried.insert(std::upper_bound(tried.begin(), tried.end(), key), key);
          continue;
        }
        Piece U = {a.faces, {}};
        U.first.insert(U.first.end(), b.faces.begin(), b.faces.end());
        std::set_union(a.cuts.begin(), a.cuts.end(), b.cuts.begin(), b.cuts.end(), std::back_inserter(U.second));
        tried.insert(std::upper_bound(tried.begin(), tried.end(), key), key);
        if (!cut_to_disk(s, mesh.V, F, U.first, U.second)) continue;
        Chart u = unwrap_chart(std::move(U));
        progress(shown);  // (cancellation)
        if (u.failed || u.stretch > opt.max_stretch || e_all - energy(a) - energy(b) + energy(u) > budget) continue;
        charts[c] = std::move(u);
        charts.erase(charts.begin() + d);
        ++res.merges;
        merged = true;
        break;
      }
      if (!merged) break;
    }
  }
  int failed_maps = 0;
  bool capped = false;
  for (const Chart& c : charts) {
    if (c.failed) ++failed_maps;
    if (c.splittable && !c.failed && c.stretch > opt.max_stretch) capped = true;
  }
  if (capped || (whole() > opt.target_stretch && std::isfinite(whole())))
    res.warnings.push_back("max_charts (" + std::to_string(opt.max_charts) +
                           ") reached: the map keeps an L2 stretch above target_stretch or max_stretch");
  if (failed_maps)
    res.warnings.push_back(std::to_string(failed_maps) + " chart(s) kept a flipped or zero-area triangle");

  // Largest charts first: chart ids in decreasing order of size.
  std::stable_sort(charts.begin(), charts.end(),
                   [](const Chart& a, const Chart& b) { return a.faces.size() > b.faces.size(); });
  res.n_charts = static_cast<int>(charts.size());
  res.chart.resize(nf);
  res.chart_stretch.resize(res.n_charts);
  for (int c = 0; c < res.n_charts; ++c) {
    for (int f : charts[c].faces) res.chart[f] = c;
    res.chart_stretch[c] = charts[c].stretch;
  }
  res.uv.setZero(3 * nf, 2);
  res.uv_area_used = pack(s.A, charts, opt.margin, res.uv);

  const Topology& topo = mesh.topo;
  std::vector<char> cut(topo.n_edges(), 0);
  for (const Chart& c : charts)
    for (int e : c.cuts) cut[e] = 1;
  std::vector<int> seam_edges;
  for (int e = 0; e < topo.n_edges(); ++e) {
    const double len = (mesh.V.row(topo.edges(e, 0)) - mesh.V.row(topo.edges(e, 1))).norm();
    res.edge_length += len;
    const int f0 = topo.edge_faces(e, 0), f1 = topo.edge_faces(e, 1);
    if (f0 >= 0 && f1 >= 0 && (res.chart[f0] != res.chart[f1] || cut[e])) {
      seam_edges.push_back(e);
      res.seam_length += len;
    }
  }
  res.seams.resize(static_cast<Eigen::Index>(seam_edges.size()), 2);
  for (size_t i = 0; i < seam_edges.size(); ++i) res.seams.row(i) = topo.edges.row(seam_edges[i]);

  // The packed map's metrics over the triangle soup of the corners.
  MatX3d Vs(3 * nf, 3);
  MatX3i Fs(nf, 3);
  for (int f = 0; f < nf; ++f)
    for (int j = 0; j < 3; ++j) {
      Vs.row(3 * f + j) = mesh.V.row(F(f, j));
      Fs(f, j) = 3 * f + j;
    }
  res.metrics = uv_metrics(Vs, Fs, res.uv, opt.unwrap.zero_area_eps);
  progress(1.0);
  return res;
}

}  // namespace dgmesh
