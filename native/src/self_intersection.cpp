// Self-intersecting triangle pairs through a bounding-volume hierarchy with normal-cone culling
// (see self_intersection.h).
#include "dgmesh/self_intersection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#include "dgmesh/parallel.h"

namespace dgmesh {

namespace {

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) { return (b - a).dot((c - a).cross(d - a)); }

// Whether the segment pq crosses the interior of the triangle abc (strictly); s1, s2: orient(p, a,
// b, c) and orient(q, a, b, c), the endpoints' sides of the triangle's plane.
bool edge_crosses(double s1, double s2, const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  if (!(s1 * s2 < 0)) return false;
  const double u = orient(p, q, a, b), v = orient(p, q, b, c), w = orient(p, q, c, a);
  return (u > 0 && v > 0 && w > 0) || (u < 0 && v < 0 && w < 0);
}

// Each vertex's side of the other triangle's plane once (six orientations; most pairs stop there).
bool triangles_cross(const std::array<Vec3, 3>& s, const std::array<Vec3, 3>& t) {
  std::array<double, 3> ds, dt;
  for (int k = 0; k < 3; ++k) ds[k] = orient(s[k], t[0], t[1], t[2]), dt[k] = orient(t[k], s[0], s[1], s[2]);
  for (int k = 0; k < 3; ++k) {
    const int l = (k + 1) % 3;
    if (edge_crosses(ds[k], ds[l], s[k], s[l], t[0], t[1], t[2]) ||
        edge_crosses(dt[k], dt[l], t[k], t[l], s[0], s[1], s[2]))
      return true;
  }
  return false;
}

bool boxes_meet(const Vec3& lo0, const Vec3& hi0, const Vec3& lo1, const Vec3& hi1) {
  return !((lo0.array() > hi1.array()).any() || (lo1.array() > hi0.array()).any());
}

void face_box(const MatX3d& V, const MatX3i& F, int f, Vec3& lo, Vec3& hi) {
  lo = hi = V.row(F(f, 0)).transpose();
  for (int c = 1; c < 3; ++c) {
    lo = lo.cwiseMin(V.row(F(f, c)).transpose());
    hi = hi.cwiseMax(V.row(F(f, c)).transpose());
  }
}

constexpr int kLeafFaces = 16;
constexpr double kHalfPi = 1.5707963267948966;

// A cone of directions (unit axis, half-angle and its cosine and sine); wide (angle >= pi / 2, the
// axis unused) where it vouches for nothing.
struct Cone {
  Vec3 axis = Vec3::Zero();
  double angle = 2 * kHalfPi, c = -1, s = 0;
  Cone() = default;
  Cone(const Vec3& axis, double angle) : axis(axis), angle(angle), c(std::cos(angle)), s(std::sin(angle)) {}
  bool narrow() const { return angle < kHalfPi - 1e-9; }
};

// The smallest cone holding both.
Cone merge(const Cone& a, const Cone& b) {
  if (!a.narrow() || !b.narrow()) return {};
  // Wide unless the axes are less than pi - a - b apart: cos(phi) > -cos(a + b), no trigonometry.
  const double dot = a.axis.dot(b.axis);
  if (!(dot > a.s * b.s - a.c * b.c)) return {};
  const double phi = std::atan2(a.axis.cross(b.axis).norm(), dot);
  if (a.angle >= phi + b.angle) return a;
  if (b.angle >= phi + a.angle) return b;
  const double angle = 0.5 * (a.angle + phi + b.angle);
  if (!(angle < kHalfPi)) return {};
  const double t = (angle - a.angle) / phi, sp = std::sin(phi);  // phi > |a.angle - b.angle| >= 0 here
  return Cone(((std::sin((1 - t) * phi) / sp) * a.axis + (std::sin(t * phi) / sp) * b.axis).normalized(), angle);
}

}  // namespace

SelfIntersectionTree::SelfIntersectionTree(const MatX3d& V, const MatX3i& F, const std::vector<int>* faces) : F_(F) {
  if (faces) {
    faces_ = *faces;
  } else {
    faces_.resize(F.rows());
    std::iota(faces_.begin(), faces_.end(), 0);
  }
  order_ = faces_;
  const int m = static_cast<int>(faces_.size());
  if (m == 0) return;
  std::vector<Vec3> centre(F.rows());
  for (int f : faces_) centre[f] = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))).transpose() / 3;
  // Median splits of the centroids along the longest side of their box, down to kLeafFaces faces.
  const auto build = [&](auto&& self, int begin, int end) -> int {
    const int id = static_cast<int>(nodes_.size());
    nodes_.push_back({begin, end});
    if (end - begin <= kLeafFaces) return id;
    Vec3 lo = centre[order_[begin]], hi = lo;
    for (int k = begin + 1; k < end; ++k) lo = lo.cwiseMin(centre[order_[k]]), hi = hi.cwiseMax(centre[order_[k]]);
    Eigen::Index axis;
    (hi - lo).maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](int a, int b) { return centre[a][axis] < centre[b][axis]; });
    const int left = self(self, begin, mid), right = self(self, mid, end);
    nodes_[id].left = left, nodes_[id].right = right;
    return id;
  };
  build(build, 0, m);
  // Edge neighbours among the tree's faces (an edge with more than two faces joins none).
  std::vector<std::pair<uint64_t, int>> edges;  // (edge key, 3 slot + corner)
  edges.reserve(static_cast<size_t>(m) * 3);
  for (int k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c) {
      const uint64_t a = static_cast<uint32_t>(F(order_[k], c)), b = static_cast<uint32_t>(F(order_[k], (c + 1) % 3));
      edges.emplace_back(std::min(a, b) << 32 | std::max(a, b), 3 * k + c);
    }
  std::sort(edges.begin(), edges.end());
  across_.assign(m, {-1, -1, -1});
  for (size_t a = 0; a < edges.size();) {
    size_t b = a;
    while (b < edges.size() && edges[b].first == edges[a].first) ++b;
    const int p = edges[a].second, q = edges[a + 1 < b ? a + 1 : a].second;
    if (b - a == 2 && p / 3 != q / 3) across_[p / 3][p % 3] = q / 3, across_[q / 3][q % 3] = p / 3;
    a = b;
  }
  // Which nodes are edge-connected (a search from the first face within the node's range).
  std::vector<int> seen(m, -1), queue;
  for (int id = 0; id < static_cast<int>(nodes_.size()); ++id) {
    Node& nd = nodes_[id];
    queue.assign(1, nd.begin);
    seen[nd.begin] = id;
    for (size_t q = 0; q < queue.size(); ++q)
      for (int l : across_[queue[q]])
        if (l >= nd.begin && l < nd.end && seen[l] != id) seen[l] = id, queue.push_back(l);
    nd.connected = static_cast<int>(queue.size()) == nd.end - nd.begin;
    nd.rim_begin = static_cast<int>(rim_.size());
    for (int k = nd.begin; k < nd.end; ++k)
      for (int l : across_[k])
        if (l < nd.begin || l >= nd.end) {
          rim_.push_back(k);
          break;
        }
    nd.rim_end = static_cast<int>(rim_.size());
  }
}

bool SelfIntersectionTree::adjacent(const Node& a, const Node& b) const {
  const Node& small = a.rim_end - a.rim_begin <= b.rim_end - b.rim_begin ? a : b;
  const Node& other = &small == &a ? b : a;
  for (int r = small.rim_begin; r < small.rim_end; ++r)
    for (int l : across_[rim_[r]])
      if (l >= other.begin && l < other.end) return true;
  return false;
}

bool SelfIntersectionTree::contour_crosses(const MatX3d& V, const Vec3& axis, const Node& a, const Node* b) const {
  const auto inside = [&](int l) { return (l >= a.begin && l < a.end) || (b && l >= b->begin && l < b->end); };
  // A basis of the plane across the axis, and the boundary edges projected onto it.
  Eigen::Index drop;
  axis.cwiseAbs().minCoeff(&drop);
  const Vec3 u = axis.cross(Vec3::Unit(drop)).normalized(), v = axis.cross(u);
  struct Segment {
    Eigen::Vector2d p, q;
    int i, j;  // mesh vertices
  };
  thread_local std::vector<Segment> seg;  // (scratch: a search tests thousands of contours)
  seg.clear();
  const auto collect = [&](const Node& n) {
    for (int r = n.rim_begin; r < n.rim_end; ++r)
      for (int c = 0, k = rim_[r]; c < 3; ++c) {
        const int l = across_[k][c];
        if (l >= 0 && inside(l)) continue;
        const int f = order_[k], i = F_(f, c), j = F_(f, (c + 1) % 3);
        const Vec3 x = row3(V, i), y = row3(V, j);
        seg.push_back({{x.dot(u), x.dot(v)}, {y.dot(u), y.dot(v)}, i, j});
      }
  };
  collect(a);
  if (b) collect(*b);
  for (auto& s : seg)
    if (s.q.x() < s.p.x()) std::swap(s.p, s.q), std::swap(s.i, s.j);
  // Few segments (the boundary of a leaf or two): every pair; more: a sweep along x, each segment
  // against those starting before it ends.
  constexpr size_t kSweepFrom = 32;
  const bool sweep = seg.size() > kSweepFrom;
  if (sweep) std::sort(seg.begin(), seg.end(), [](const Segment& s, const Segment& t) { return s.p.x() < t.p.x(); });
  const auto orient = [](const Eigen::Vector2d& o, const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
    return (p - o).x() * (q - o).y() - (p - o).y() * (q - o).x();
  };
  for (size_t s = 0; s < seg.size(); ++s)
    for (size_t t = s + 1; t < seg.size() && (!sweep || seg[t].p.x() <= seg[s].q.x()); ++t) {
      const Segment &S = seg[s], &T = seg[t];
      if (T.p.x() > S.q.x() || S.p.x() > T.q.x()) continue;
      if (S.i == T.i || S.i == T.j || S.j == T.i || S.j == T.j) continue;  // consecutive on the boundary
      if (std::max(S.p.y(), S.q.y()) < std::min(T.p.y(), T.q.y()) ||
          std::max(T.p.y(), T.q.y()) < std::min(S.p.y(), S.q.y()))
        continue;
      const double o1 = orient(S.p, S.q, T.p), o2 = orient(S.p, S.q, T.q);
      const double o3 = orient(T.p, T.q, S.p), o4 = orient(T.p, T.q, S.q);
      if (o1 * o2 <= 0 && o3 * o4 <= 0) return true;  // crossing, touching or collinear: not vouched for
    }
  return false;
}

std::vector<std::pair<int, int>> SelfIntersectionTree::search(const MatX3d& V,
                                                              const std::vector<char>* touching) const {
  std::vector<std::pair<int, int>> out;
  const int m = static_cast<int>(order_.size());
  if (m < 2) return out;
  // Per face slot: box and area-weighted normal (zero for a degenerate face).
  std::vector<Vec3> lo(m), hi(m), normal(m);
#pragma omp parallel for if (m >= kParallelMin)
  for (int k = 0; k < m; ++k) {
    const int f = order_[k];
    face_box(V, F_, f, lo[k], hi[k]);
    normal[k] = (V.row(F_(f, 1)) - V.row(F_(f, 0))).transpose().cross((V.row(F_(f, 2)) - V.row(F_(f, 0))).transpose());
  }
  // Per node, bottom-up (children follow their parent): box, normal cone, and whether it holds a
  // flagged face.
  const int nn = static_cast<int>(nodes_.size());
  std::vector<Vec3> nlo(nn), nhi(nn);
  std::vector<Cone> cone(nn);
  std::vector<char> flagged(nn, 1);
  for (int id = nn - 1; id >= 0; --id) {
    const Node& nd = nodes_[id];
    if (nd.left >= 0) {
      nlo[id] = nlo[nd.left].cwiseMin(nlo[nd.right]), nhi[id] = nhi[nd.left].cwiseMax(nhi[nd.right]);
      cone[id] = merge(cone[nd.left], cone[nd.right]);
      if (touching) flagged[id] = flagged[nd.left] || flagged[nd.right];
      continue;
    }
    nlo[id] = lo[nd.begin], nhi[id] = hi[nd.begin];
    Vec3 sum = Vec3::Zero();
    bool degenerate = false;
    for (int k = nd.begin; k < nd.end; ++k) {
      nlo[id] = nlo[id].cwiseMin(lo[k]), nhi[id] = nhi[id].cwiseMax(hi[k]);
      const double len = normal[k].norm();
      degenerate |= !(len > 1e-14 * (hi[k] - lo[k]).squaredNorm()) || !std::isfinite(len);
      sum += normal[k];
    }
    if (!degenerate && sum.norm() > 0) {
      const Vec3 axis = sum.normalized();
      double cos_min = 1;
      for (int k = nd.begin; k < nd.end; ++k) cos_min = std::min(cos_min, axis.dot(normal[k]) / normal[k].norm());
      if (cos_min > 0) cone[id] = Cone{axis, std::acos(std::min(cos_min, 1.0))};
    }
    if (touching) {
      flagged[id] = 0;
      for (int k = nd.begin; k < nd.end && !flagged[id]; ++k) flagged[id] = (*touching)[order_[k]] != 0;
    }
  }
  const auto test = [&](int k, int l) {
    const int fp = order_[k], fq = order_[l];
    if (touching && !(*touching)[fp] && !(*touching)[fq]) return;
    if (!boxes_meet(lo[k], hi[k], lo[l], hi[l])) return;
    for (int s = 0; s < 3; ++s)
      for (int t = 0; t < 3; ++t)
        if (F_(fp, s) == F_(fq, t)) return;
    const std::array<Vec3, 3> S{V.row(F_(fp, 0)).transpose(), V.row(F_(fp, 1)).transpose(),
                                V.row(F_(fp, 2)).transpose()};
    const std::array<Vec3, 3> T{V.row(F_(fq, 0)).transpose(), V.row(F_(fq, 1)).transpose(),
                                V.row(F_(fq, 2)).transpose()};
    if (triangles_cross(S, T)) out.emplace_back(std::min(fp, fq), std::max(fp, fq));
  };
  // Node pairs to visit: (id, id) the pairs inside a node, (a, b) those across two disjoint nodes.
  std::vector<std::pair<int, int>> stack{{0, 0}};
  std::vector<int> near_a, near_b;
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node &A = nodes_[a], &B = nodes_[b];
    if (a == b) {
      if (!flagged[a]) continue;
      if (A.left < 0) {  // (a leaf's faces cost less to test than its contour)
        for (int k = A.begin; k < A.end; ++k)
          for (int l = k + 1; l < A.end; ++l) test(k, l);
      } else if (!(A.connected && cone[a].narrow() && !contour_crosses(V, cone[a].axis, A, nullptr))) {
        stack.push_back({A.left, A.left}), stack.push_back({A.right, A.right}), stack.push_back({A.left, A.right});
      }
      continue;
    }
    if ((!flagged[a] && !flagged[b]) || !boxes_meet(nlo[a], nhi[a], nlo[b], nhi[b])) continue;
    if (A.connected && B.connected && (A.left >= 0 || B.left >= 0)) {  // (two leaves: their faces)
      const Cone c = merge(cone[a], cone[b]);
      if (c.narrow() && adjacent(A, B) && !contour_crosses(V, c.axis, A, &B)) continue;
    }
    if (A.left < 0 && B.left < 0) {
      near_a.clear(), near_b.clear();
      for (int k = A.begin; k < A.end; ++k)
        if (boxes_meet(lo[k], hi[k], nlo[b], nhi[b])) near_a.push_back(k);
      for (int l = B.begin; l < B.end; ++l)
        if (boxes_meet(lo[l], hi[l], nlo[a], nhi[a])) near_b.push_back(l);
      for (int k : near_a)
        for (int l : near_b) test(k, l);
    } else if (B.left < 0 || (A.left >= 0 && A.end - A.begin >= B.end - B.begin)) {
      stack.push_back({A.left, b}), stack.push_back({A.right, b});
    } else {
      stack.push_back({a, B.left}), stack.push_back({a, B.right});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::pair<int, int>> SelfIntersectionTree::pairs(const MatX3d& V) const { return search(V, nullptr); }

std::vector<std::pair<int, int>> SelfIntersectionTree::pairs_touching(const MatX3d& V,
                                                                      const std::vector<char>& touching) const {
  return search(V, &touching);
}

std::vector<std::pair<int, int>> self_intersecting_pairs(const MatX3d& V, const MatX3i& F,
                                                         const std::vector<int>* faces) {
  return SelfIntersectionTree(V, F, faces).pairs(V);
}

std::vector<std::pair<int, int>> self_intersecting_pairs_touching(const MatX3d& V, const MatX3i& F,
                                                                  const std::vector<int>* faces,
                                                                  const std::vector<char>& touching) {
  return SelfIntersectionTree(V, F, faces).pairs_touching(V, touching);
}

}  // namespace dgmesh
