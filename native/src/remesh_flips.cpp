// Edge flips of the remesher; see remesh_flips.h.
#include "dgmesh/remesh_flips.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_set>

#include "dgmesh/detail/edge_key.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/detail/remesh_map.h"
#include "dgmesh/parallel.h"

namespace dgmesh::detail {

namespace {

constexpr double kFlipCos = 0.94;  // cos 20 degrees
// A pair of triangles across a bent edge (the flips' near-flat rule refuses it) whose smaller
// angle is under 20 degrees is still flipped when that raises the pair's smallest angle and the new
// pair is within 90 degrees of coplanar: at creases of a coarse input the triangulation map is
// compressed and its Delaunay triangles lift to slivers across the crease.
const double kSliverCos = std::cos(20 * kPi / 180);
constexpr double kSliverDihedralCos = 0.0;

// Lawson's edge-flip loop (Lawson 1977) over twin half-edges `opp` (h = 3 f + k runs corner k to
// corner k + 1 of triangle f; -1 on the boundary, which never flips), from the half-edges on
// `stack`: the edge a -> b of f = (a, b, c), held b -> a by g = (b, a, d), flips when
// accept(a, b, c, d) says so; the pair becomes f = (a, d, c), g = (d, b, c) (set(f, g, ...)), the
// twins are relinked and the four outer half-edges pushed. At most max_flips; returns the count.
template <class Corner, class Set, class Accept>
int lawson_flips(std::vector<int>& opp, std::vector<int> stack, long max_flips, Corner corner, Set set, Accept accept) {
  auto link = [&](int x, int y) {
    opp[x] = y;
    if (y >= 0) opp[y] = x;
  };
  int flips = 0;
  while (!stack.empty() && flips < max_flips) {
    const int h = stack.back();
    stack.pop_back();
    const int o = opp[h];
    if (o < 0) continue;
    const int f = h / 3, k = h % 3, g = o / 3, l = o % 3;
    const int a = corner(f, k), b = corner(f, (k + 1) % 3), c = corner(f, (k + 2) % 3), d = corner(g, (l + 2) % 3);
    if (!accept(a, b, c, d)) continue;
    // New half-edges f0 a->d, f1 d->c, f2 c->a; g0 d->b, g1 b->c, g2 c->d.
    const int o_bc = opp[3 * f + (k + 1) % 3], o_ca = opp[3 * f + (k + 2) % 3];
    const int o_ad = opp[3 * g + (l + 1) % 3], o_db = opp[3 * g + (l + 2) % 3];
    set(f, g, a, b, c, d);
    link(3 * f + 0, o_ad);
    link(3 * f + 1, 3 * g + 2);
    link(3 * f + 2, o_ca);
    link(3 * g + 0, o_db);
    link(3 * g + 1, o_bc);
    ++flips;
    for (int x : {3 * f + 0, 3 * f + 2, 3 * g + 0, 3 * g + 1}) stack.push_back(x);
  }
  return flips;
}

}  // namespace

int delaunay_flips_3d(const MatX3d& X, const MatX2d& U, MatX3i& F, double orient_sign, bool closing) {
  const int nf = int(F.rows());
  std::vector<int> opp(3 * nf, -1);
  {
    // Half-edges by start vertex (counting sort), then the twin of a->b among those starting at b.
    const int nv = int(X.rows());
    std::vector<int> off(nv + 1, 0), he(3 * nf);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) ++off[F(f, k) + 1];
    for (int v = 0; v < nv; ++v) off[v + 1] += off[v];
    {
      std::vector<int> fill(off.begin(), off.end() - 1);
      for (int f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k) he[fill[F(f, k)]++] = 3 * f + k;
    }
#pragma omp parallel for schedule(static) if (nf > kParallelMin)
    for (int h = 0; h < 3 * nf; ++h) {
      const int f = h / 3, k = h % 3;
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      for (int q = off[b]; q < off[b + 1]; ++q) {
        const int g = he[q] / 3, l = he[q] % 3;
        if (F(g, (l + 1) % 3) == a) {
          opp[h] = he[q];
          break;
        }
      }
    }
  }
  // The Delaunay test: the angles at c (in a, b, c) and at d (in b, a, d) sum to more than pi, i.e.
  // sin(alpha + beta) = sin a cos b + cos a sin b < 0 (no atan2: this runs on every half-edge).
  auto opposite_angles_exceed_pi = [&](int c, int a, int b, int d) {
    const Vec3 u1 = row3(X, a) - row3(X, c), v1 = row3(X, b) - row3(X, c);
    const Vec3 u2 = row3(X, b) - row3(X, d), v2 = row3(X, a) - row3(X, d);
    const double s1 = u1.cross(v1).norm(), c1 = u1.dot(v1), s2 = u2.cross(v2).norm(), c2 = u2.dot(v2);
    const double scale = std::sqrt(u1.squaredNorm() * v1.squaredNorm() * u2.squaredNorm() * v2.squaredNorm());
    return s1 * c2 + c1 * s2 < -1e-10 * scale;
  };

  auto orient = [&](int a, int b, int c) {
    return orient_sign * cross2(uv_row(U, b) - uv_row(U, a), uv_row(U, c) - uv_row(U, a));
  };
  std::vector<int> stack(3 * nf);
  for (int h = 0; h < 3 * nf; ++h) stack[h] = h;
  return lawson_flips(
      opp, std::move(stack), 20L * nf, [&](int f, int k) { return F(f, k); },
      [&](int f, int g, int a, int b, int c, int d) {
        F.row(f) << a, d, c;
        F.row(g) << d, b, c;
      },
      [&](int a, int b, int c, int d) {
        if (!opposite_angles_exceed_pi(c, a, b, d)) return false;
        if (orient(a, d, c) <= 0 || orient(d, b, c) <= 0) return false;
        // Only where the four points are nearly coplanar: the edge before or after the flip has a
        // dihedral below ~20 degrees, so flips never cut across a crease or a thin feature and the
        // surface stays where the samples put it. (The new edge is tested too because a near-degenerate
        // obtuse triangle has an unreliable normal, so its old dihedral can look sharp on a flat piece.)
        {
          auto dihedral_cos = [&](int p, int q, int r, int s) {  // triangles (p, q, r) and (q, p, s)
            const Vec3 n1 = (row3(X, q) - row3(X, p)).cross(row3(X, r) - row3(X, p));
            const Vec3 n2 = (row3(X, p) - row3(X, q)).cross(row3(X, s) - row3(X, q));
            const double nn = n1.norm() * n2.norm();
            return nn > 0 ? n1.dot(n2) / nn : -1.0;
          };
          const double c_old = dihedral_cos(a, b, c, d), c_new = dihedral_cos(d, c, a, b);
          auto tri_max_cos = [&](int p, int q, int r) { return min_angle_cos(row3(X, p), row3(X, q), row3(X, r)); };
          if (closing)
            return c_old >= kFlipCos && c_new >= kFlipCos &&
                   std::max(tri_max_cos(a, d, c), tri_max_cos(d, b, c)) <=
                       std::max(tri_max_cos(a, b, c), tri_max_cos(b, a, d));
          // A flip that unfolds a fold (the new pair within 60 degrees of coplanar and much flatter
          // than the old one) is allowed too: such folds are the scan defects' needles and caps.
          // So is one that makes a moderately bent pair (within ~37 degrees) no sharper.
          const bool unfold = (c_new >= 0.5 && c_new - c_old >= 0.5) || (c_new >= 0.8 && c_new >= c_old);
          if (c_old < kFlipCos && c_new < kFlipCos && !unfold) {
            // A sliver across a bent edge (kSliverCos): flipped only if the pair's smallest angle grows.
            const double m_old = std::max(tri_max_cos(a, b, c), tri_max_cos(b, a, d));
            const double m_new = std::max(tri_max_cos(a, d, c), tri_max_cos(d, b, c));
            if (!(m_old > kSliverCos && m_new < m_old && c_new >= kSliverDihedralCos)) return false;
          }
        }
        return true;
      });
}

// Lawson flips (Lawson 1977) towards the Delaunay triangulation of the map P, starting from the
// edges in `seeds` and going on with the edges of the flipped triangles: an interior edge (a, b) of
// triangles (a, b, c) and (b, a, d) flips to (c, d) when d lies inside the circle through a, b and
// c, both new triangles keep the pair's orientation in the map and (c, d) is not an edge yet.

int delaunay_flips_map(const MatX2d& P, std::vector<std::array<int, 3>>& T,
                       const std::vector<std::pair<int, int>>& seeds) {
  const int nt = int(T.size());
  // Twin half-edges (h = 3 t + k runs T[t][k] -> T[t][k + 1]) by sorting the undirected keys.
  std::vector<std::pair<int64_t, int>> he(3 * nt);
  for (int t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) he[3 * t + k] = {edge_key(T[t][k], T[t][(k + 1) % 3]), 3 * t + k};
  std::sort(he.begin(), he.end());
  std::vector<int> opp(3 * nt, -1);
  for (size_t q = 0; q + 1 < he.size(); ++q)
    if (he[q].first == he[q + 1].first) {
      opp[he[q].second] = he[q + 1].second;
      opp[he[q + 1].second] = he[q].second;
    }
  std::unordered_set<int64_t> edges;
  edges.reserve(he.size());
  for (const auto& e : he) edges.insert(e.first);
  auto orient = [&](int a, int b, int c) { return cross2(uv_row(P, b) - uv_row(P, a), uv_row(P, c) - uv_row(P, a)); };
  // > 0 when d is inside the circle through a, b, c (counter-clockwise); relative to its magnitude.
  auto in_circle = [&](int a, int b, int c, int d) {
    const Vec2 pa = uv_row(P, a) - uv_row(P, d), pb = uv_row(P, b) - uv_row(P, d), pc = uv_row(P, c) - uv_row(P, d);
    const double la = pa.squaredNorm(), lb = pb.squaredNorm(), lc = pc.squaredNorm();
    const double t1 = la * cross2(pb, pc), t2 = lb * cross2(pc, pa), t3 = lc * cross2(pa, pb);
    const double det = t1 + t2 + t3, mag = std::abs(t1) + std::abs(t2) + std::abs(t3);
    return det > 1e-12 * mag ? 1 : det < -1e-12 * mag ? -1 : 0;
  };
  std::vector<int> stack;
  for (auto [a, b] : seeds) {
    const int64_t k = edge_key(a, b);
    auto it = std::lower_bound(he.begin(), he.end(), std::make_pair(k, -1));
    if (it != he.end() && it->first == k) stack.push_back(it->second);
  }
  return lawson_flips(
      opp, std::move(stack), 20L * nt + 100, [&](int f, int k) { return T[f][k]; },
      [&](int f, int g, int a, int b, int c, int d) {
        T[f] = {a, d, c};
        T[g] = {d, b, c};
        edges.erase(edge_key(a, b));
        edges.insert(edge_key(c, d));
      },
      [&](int a, int b, int c, int d) {
        const double s = orient(a, b, c);
        if (s == 0 || (s > 0 ? 1 : -1) * in_circle(a, b, c, d) <= 0) return false;
        return orient(a, d, c) * s > 0 && orient(d, b, c) * s > 0 && !edges.count(edge_key(c, d));
      });
}

// Point location in a parameter map U of the chart (V, F): walk from face f across the edge opposite

}  // namespace dgmesh::detail
