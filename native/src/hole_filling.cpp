// Hole filling after Liepa (SGP 2003): minimum-weight triangulation and refinement of a fill; see
// hole_filling.h.
#include "dgmesh/hole_filling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "dgmesh/detail/edge_key.h"
#include "dgmesh/detail/math.h"
#include "dgmesh/errors.h"
#include "dgmesh/mesh.h"

namespace dgmesh {

using detail::edge_key;
using detail::half_edge_key;
using detail::kPi;

std::vector<Eigen::Vector3i> min_weight_triangulation(const std::vector<Vec3>& P, const std::vector<int>& loop,
                                                      const std::vector<Vec3>& outer_normal,
                                                      const std::function<bool(int, int)>& is_edge) {
  const int n = static_cast<int>(loop.size());
  if (n < 3) return {};
  // The largest dihedral angle is tracked as its cosine (smallest cosine = largest angle).
  // cosw(i, k), area(i, k): weight of the best triangulation of sub-polygon i..k (k - i >= 1; -inf:
  // none); apex(i, k) and normal(i, k): its triangle over edge (i, k). A polygon edge weighs nothing.
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  const size_t nn = static_cast<size_t>(n) * n;
  std::vector<double> cosw(nn, kNone), area(nn, 0.0);
  std::vector<int> apex(nn, -1);
  std::vector<Vec3> normal(nn, Vec3::Zero());
  auto at = [n](int i, int k) { return static_cast<size_t>(i) * n + k; };
  for (int i = 0; i + 1 < n; ++i) cosw[at(i, i + 1)] = 1.0;
  auto pt = [&](int i) -> const Vec3& { return P[loop[i]]; };
  // Cosine of the dihedral angle across edge (a, b) of a triangle with unit normal nt: against the
  // face outside the hole when (a, b) is a polygon edge (none on a mesh border), else against the
  // apex triangle of sub-polygon (a, b).
  auto across = [&](int a, int b, const Vec3& nt) {
    if (b == a + 1) return outer_normal[a].isZero() ? 1.0 : nt.dot(outer_normal[a]);
    return nt.dot(normal[at(a, b)]);
  };
  for (int d = 2; d < n; ++d)
    for (int i = 0; i + d < n; ++i) {
      const int k = i + d;
      // (0, n - 1) closes the polygon; any other (i, k) is a new edge and must not exist already.
      const bool closing = i == 0 && k == n - 1;
      if (!closing && is_edge(loop[i], loop[k])) continue;
      double best = kNone, best_area = 0;
      int best_m = -1;
      Vec3 best_n = Vec3::Zero();
      for (int m = i + 1; m < k; ++m) {
        const double c0 = std::min(cosw[at(i, m)], cosw[at(m, k)]);
        if (c0 == kNone || c0 < best - 1e-12) continue;
        Vec3 nt = (pt(m) - pt(i)).cross(pt(k) - pt(i));
        const double twice_area = nt.norm();
        if (twice_area > 0) nt /= twice_area;
        double c = std::min({c0, across(i, m, nt), across(m, k, nt)});
        if (closing && !outer_normal[n - 1].isZero()) c = std::min(c, nt.dot(outer_normal[n - 1]));
        if (c < best - 1e-12) continue;
        const double ar = area[at(i, m)] + area[at(m, k)] + 0.5 * twice_area;
        if (c > best + 1e-12 || ar < best_area) best = c, best_area = ar, best_m = m, best_n = nt;
      }
      cosw[at(i, k)] = best, area[at(i, k)] = best_area, apex[at(i, k)] = best_m, normal[at(i, k)] = best_n;
    }
  if (apex[at(0, n - 1)] < 0) return {};
  std::vector<Eigen::Vector3i> out;
  out.reserve(n - 2);
  std::vector<std::pair<int, int>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, k] = stack.back();
    stack.pop_back();
    if (k - i < 2) continue;
    const int m = apex[at(i, k)];
    out.emplace_back(loop[i], loop[m], loop[k]);
    stack.emplace_back(i, m);
    stack.emplace_back(m, k);
  }
  return out;
}

namespace {
// A new vertex of valence 3 (a centroid split the flips could not dissolve, e.g. next to the
// region's border, whose edges never flip) is removed and its three triangles merged back into
// one. Its uniform umbrella is degenerate: the linear start put such vertices on tiny-area
// spikes (angle deficit ~2.7 rad) whose curvature dominated the flow, and no step along the
// Willmore speed lowered the energy (the fan-plus-refine stall). Removed vertices are compacted
// away; faces are renumbered but stay in order (input rows first).
void remove_valence3(std::vector<Eigen::Vector3i>& T, std::vector<char>& reg, std::vector<int>& origin,
                     std::vector<Vec3>& P, int n, int m) {
  const int np = static_cast<int>(P.size());
  if (np == n) return;
  std::vector<char> drop_face(T.size(), 0), gone(np, 0), busy;
  std::vector<std::vector<int>> vf(np - n);
  int spare = 0, dropped_low = 0, removed_total = 0;  // appended region faces; refills needed
  for (size_t t = m; t < T.size(); ++t) spare += reg[t] != 0;
  // Each sweep removes valence-3 vertices whose faces no other removal of the sweep touched;
  // a removal lowers its neighbours' valences, so sweep until nothing changes.
  for (int sweep = 0; sweep < 64; ++sweep) {
    for (auto& l : vf) l.clear();
    for (int t = 0; t < static_cast<int>(T.size()); ++t) {
      if (drop_face[t]) continue;
      for (int k = 0; k < 3; ++k)
        if (T[t][k] >= n) vf[T[t][k] - n].push_back(t);
    }
    busy.assign(T.size(), 0);
    int removed = 0;
    for (int i = 0; i < np - n; ++i) {
      std::vector<int>& fs = vf[i];
      if (fs.size() != 3 || gone[n + i]) continue;
      bool ok = true;
      for (int t : fs) ok = ok && reg[t] && !busy[t];
      if (!ok) continue;
      std::sort(fs.begin(), fs.end());
      // The merged triangle takes the lowest row. A dropped input row (< m, a region face)
      // is refilled below by an appended region face, so every input row keeps its index.
      const int low = (fs[1] < m) + (fs[2] < m);
      if (low && dropped_low + low > spare - 2 * (removed_total + 1)) continue;
      dropped_low += low;
      ++removed_total;
      const int x = n + i, t0 = fs[0];
      int k = 0;
      while (T[t0][k] != x) ++k;
      const int a = T[t0][(k + 1) % 3], b = T[t0][(k + 2) % 3];
      int c = -1;
      for (int j = 0; j < 3; ++j)
        if (T[fs[1]][j] != x && T[fs[1]][j] != a && T[fs[1]][j] != b) c = T[fs[1]][j];
      if (c < 0) continue;
      T[t0] = Eigen::Vector3i(a, b, c);  // a, b follow x in t0: orientation kept
      drop_face[fs[1]] = drop_face[fs[2]] = 1;
      for (int t : fs) busy[t] = 1;
      gone[x] = 1;
      ++removed;
    }
    if (!removed) break;
  }
  // Refill dropped input rows with the last surviving appended faces.
  size_t tail = T.size();
  for (int r = 0; r < m; ++r) {
    if (!drop_face[r]) continue;
    while (tail > static_cast<size_t>(m) && drop_face[tail - 1]) --tail;
    if (tail <= static_cast<size_t>(m)) throw Error("refine_region: internal error (no face to refill a row)");
    --tail;
    T[r] = T[tail], origin[r] = origin[tail], reg[r] = reg[tail];
    drop_face[r] = 0, drop_face[tail] = 1;
  }
  std::vector<int> remap(np);
  int nv = 0;
  for (int v = 0; v < np; ++v) {
    remap[v] = gone[v] ? -1 : nv;
    if (!gone[v]) P[nv++] = P[v];
  }
  P.resize(nv);
  size_t w = 0;
  for (size_t t = 0; t < T.size(); ++t) {
    if (drop_face[t]) continue;
    T[w] = Eigen::Vector3i(remap[T[t][0]], remap[T[t][1]], remap[T[t][2]]);
    reg[w] = reg[t];
    origin[w] = origin[t];
    ++w;
  }
  T.resize(w);
  reg.resize(w);
  origin.resize(w);
}
}  // namespace

namespace {
// A region that is a hole's fill without inner vertices (one boundary loop through all its
// vertices, n - 2 triangles) gets Liepa's minimum-weight triangulation of that loop in its rows
// (see min_weight_triangulation); other regions, and loops over kMaxLoop vertices (O(n^3)), keep
// theirs.
void retriangulate_fill(const std::vector<Vec3>& P, const MatX3i& F, const std::vector<char>& face_mask,
                        const std::vector<char>& in_region, const std::unordered_map<long long, char>& fixed_edge,
                        std::vector<Eigen::Vector3i>& T) {
  constexpr int kMaxLoop = 600;
  const int m = static_cast<int>(F.rows());
  std::vector<int> rows;
  for (int f = 0; f < m; ++f)
    if (face_mask[f]) rows.push_back(f);
  const int nr = static_cast<int>(std::count(in_region.begin(), in_region.end(), 1));
  if (nr < 4 || nr > kMaxLoop || static_cast<int>(rows.size()) != nr - 2) return;
  // The region's boundary loop, in its faces' orientation, from its smallest vertex (so the result
  // depends on the loop only, not on the fill).
  MatX3i R(static_cast<Eigen::Index>(rows.size()), 3);
  for (size_t r = 0; r < rows.size(); ++r) R.row(static_cast<Eigen::Index>(r)) = F.row(rows[r]);
  Topology topo;
  try {
    topo = build_topology(R, static_cast<int>(P.size()));
  } catch (const MeshError&) {
    return;  // a pinched region (non-manifold)
  }
  if (topo.boundary_loops.size() != 1) return;
  const std::vector<int>& loop = topo.boundary_loops[0];
  if (static_cast<int>(loop.size()) != nr) return;  // an inner vertex
  // Normals of the faces outside along the loop (halfedge b -> a).
  std::unordered_map<long long, int> outside;
  for (int f = 0; f < m; ++f)
    if (!face_mask[f])
      for (int k = 0; k < 3; ++k) {
        const int a = F(f, k), b = F(f, (k + 1) % 3);
        if (in_region[a] && in_region[b]) outside.emplace(half_edge_key(a, b), f);
      }
  std::vector<Vec3> outer(nr, Vec3::Zero());
  for (int i = 0; i < nr; ++i) {
    const auto it = outside.find(half_edge_key(loop[(i + 1) % nr], loop[i]));
    if (it == outside.end()) continue;
    const int f = it->second;
    const Vec3 c = (P[F(f, 1)] - P[F(f, 0)]).cross(P[F(f, 2)] - P[F(f, 0)]);
    if (c.norm() > 0) outer[i] = c.normalized();
  }
  const auto tri =
      min_weight_triangulation(P, loop, outer, [&](int a, int b) { return fixed_edge.count(edge_key(a, b)) > 0; });
  if (tri.size() != rows.size()) return;
  for (size_t j = 0; j < rows.size(); ++j) T[rows[j]] = tri[j];
}
}  // namespace

RegionSubdivision refine_region(const MatX3d& V, const MatX3i& F, const std::vector<char>& face_mask, double density) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if (face_mask.size() != static_cast<size_t>(m))
    throw MeshError("refine_region: face mask size differs from the face count");
  if (!(density > 0)) throw MeshError("refine_region: density must be > 0");
  // Edges touched by a face outside the region are fixed (never flipped).
  std::unordered_map<long long, char> fixed_edge;
  std::vector<double> sig_sum(n, 0.0);
  std::vector<int> sig_cnt(n, 0);
  std::vector<char> in_region(n, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      if (face_mask[f]) {
        in_region[a] = 1;
        continue;
      }
      fixed_edge[edge_key(a, b)] = 1;
    }
  // sigma of a region vertex: mean length of its edges in faces outside the region (each edge
  // once per such face).
  for (int f = 0; f < m; ++f) {
    if (face_mask[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      if (!in_region[a] && !in_region[b]) continue;
      const double len = (V.row(a) - V.row(b)).norm();
      sig_sum[a] += len, sig_cnt[a]++;
      sig_sum[b] += len, sig_cnt[b]++;
    }
  }
  std::vector<Vec3> P(n);
  for (int v = 0; v < n; ++v) P[v] = V.row(v).transpose();
  std::vector<double> sig(n, 0.0);
  double rim_sum = 0, region_len = 0;
  int rim_cnt = 0, region_cnt = 0;
  for (int v = 0; v < n; ++v)
    if (in_region[v] && sig_cnt[v]) sig[v] = sig_sum[v] / sig_cnt[v], rim_sum += sig[v], ++rim_cnt;
  for (int f = 0; f < m; ++f)
    if (face_mask[f])
      for (int k = 0; k < 3; ++k) region_len += (V.row(F(f, k)) - V.row(F(f, (k + 1) % 3))).norm(), ++region_cnt;
  const double sig_inner = rim_cnt ? rim_sum / rim_cnt : (region_cnt ? region_len / region_cnt : 1.0);
  for (int v = 0; v < n; ++v)
    if (in_region[v] && !sig_cnt[v]) sig[v] = sig_inner;

  std::vector<Eigen::Vector3i> T(m);
  std::vector<int> origin(m);
  std::vector<char> reg(m);
  for (int f = 0; f < m; ++f) T[f] = F.row(f).transpose(), origin[f] = f, reg[f] = face_mask[f] != 0;
  retriangulate_fill(P, F, face_mask, in_region, fixed_edge, T);

  // Delaunay relaxation of the region-interior edges: flip a-b (faces a,b,c and b,a,d) to c-d
  // when the angles at c and d sum over pi, unless c-d exists or the flip folds the surface.
  auto angle_at = [&](int c, int a, int b) {
    const Vec3 u = P[a] - P[c], w = P[b] - P[c];
    return std::atan2(u.cross(w).norm(), u.dot(w));
  };
  std::unordered_map<long long, std::pair<int, int>> emap;  // edge -> region faces (second -1 if one)
  std::vector<char> touched;
  // The quad around region edge `key` shared by t1 and t2: t1 = (a, b, c), t2 holds b -> a with
  // third vertex d. False when the pair is degenerate.
  auto quad = [&](long long key, int t1, int t2, int& a, int& b, int& c, int& d) {
    int k1 = 0;
    while (edge_key(T[t1][k1], T[t1][(k1 + 1) % 3]) != key) ++k1;
    a = T[t1][k1], b = T[t1][(k1 + 1) % 3], c = T[t1][(k1 + 2) % 3];
    d = -1;
    for (int k = 0; k < 3; ++k)
      if (T[t2][k] != a && T[t2][k] != b) d = T[t2][k];
    return d >= 0 && c != d;
  };
  auto relax = [&]() {
    for (int pass = 0; pass < 100; ++pass) {
      emap.clear();
      const int mt = static_cast<int>(T.size());
      for (int t = 0; t < mt; ++t) {
        if (!reg[t]) continue;
        for (int k = 0; k < 3; ++k) {
          auto [it, fresh] = emap.try_emplace(edge_key(T[t][k], T[t][(k + 1) % 3]), t, -1);
          if (!fresh) it->second.second = t;
        }
      }
      touched.assign(mt, 0);
      int flips = 0;
      for (const auto& [key, ff] : emap) {
        const int t1 = ff.first, t2 = ff.second;
        if (t2 < 0 || touched[t1] || touched[t2] || fixed_edge.count(key)) continue;
        int a, b, c, d;
        if (!quad(key, t1, t2, a, b, c, d)) continue;
        if (angle_at(c, a, b) + angle_at(d, a, b) <= kPi + 1e-9) continue;
        const long long nk = edge_key(c, d);
        if (emap.count(nk) || fixed_edge.count(nk)) continue;
        const Vec3 n_old = (P[b] - P[a]).cross(P[c] - P[a]) + (P[a] - P[b]).cross(P[d] - P[b]);
        const Vec3 n1 = (P[d] - P[a]).cross(P[c] - P[a]), n2 = (P[b] - P[d]).cross(P[c] - P[d]);
        if (n1.dot(n_old) <= 0 || n2.dot(n_old) <= 0) continue;
        T[t1] = Eigen::Vector3i(a, d, c);
        T[t2] = Eigen::Vector3i(d, b, c);
        touched[t1] = touched[t2] = 1;
        emap[nk] = {t1, t2};  // blocks a second c-d within this pass
        ++flips;
      }
      if (!flips) break;
    }
  };

  // Delaunay flips leave centroid vertices of valence 3-4 whose uniform bi-umbrella start (the
  // flow's linear start) is badly shaped; flip region-interior edges that bring the four
  // vertices' valences closer to 6 (as isotropic remeshers do) when no triangle gets an angle
  // below the smaller of 15 degrees and the pair's current minimum.
  auto min_angle = [&](int a, int b, int c) {
    return std::min({angle_at(a, b, c), angle_at(b, c, a), angle_at(c, a, b)});
  };
  std::vector<int> valence;
  std::unordered_set<long long> edge_set;
  auto valence_flips = [&]() {
    for (int pass = 0; pass < 20; ++pass) {
      emap.clear();
      const int mt = static_cast<int>(T.size());
      valence.assign(P.size(), 0);
      edge_set.clear();
      for (int t = 0; t < mt; ++t)
        for (int k = 0; k < 3; ++k) {
          const int a = T[t][k], b = T[t][(k + 1) % 3];
          if (edge_set.insert(edge_key(a, b)).second) valence[a]++, valence[b]++;
          if (reg[t]) {
            auto [it, fresh] = emap.try_emplace(edge_key(a, b), t, -1);
            if (!fresh) it->second.second = t;
          }
        }
      touched.assign(mt, 0);
      int flips = 0;
      for (const auto& [key, ff] : emap) {
        const int t1 = ff.first, t2 = ff.second;
        if (t2 < 0 || touched[t1] || touched[t2] || fixed_edge.count(key)) continue;
        int a, b, c, d;
        if (!quad(key, t1, t2, a, b, c, d)) continue;
        auto dev = [](int x) { return (x - 6) * (x - 6); };
        const int before = dev(valence[a]) + dev(valence[b]) + dev(valence[c]) + dev(valence[d]);
        const int after = dev(valence[a] - 1) + dev(valence[b] - 1) + dev(valence[c] + 1) + dev(valence[d] + 1);
        if (after >= before || valence[a] <= 3 || valence[b] <= 3) continue;
        const long long nk = edge_key(c, d);
        if (emap.count(nk) || fixed_edge.count(nk)) continue;
        const Vec3 n_old = (P[b] - P[a]).cross(P[c] - P[a]) + (P[a] - P[b]).cross(P[d] - P[b]);
        const Vec3 n1 = (P[d] - P[a]).cross(P[c] - P[a]), n2 = (P[b] - P[d]).cross(P[c] - P[d]);
        if (n1.dot(n_old) <= 0 || n2.dot(n_old) <= 0) continue;
        const double floor = std::min(15.0 * kPi / 180.0, std::min(min_angle(a, b, c), min_angle(b, a, d)));
        if (std::min(min_angle(a, d, c), min_angle(d, b, c)) < floor) continue;
        T[t1] = Eigen::Vector3i(a, d, c);
        T[t2] = Eigen::Vector3i(d, b, c);
        touched[t1] = touched[t2] = 1;
        valence[a]--, valence[b]--, valence[c]++, valence[d]++;
        emap[nk] = {t1, t2};
        ++flips;
      }
      if (!flips) break;
    }
  };

  constexpr size_t kMaxVertices = size_t{1} << 26;
  for (int round = 0; round < 60; ++round) {
    int splits = 0;
    const int mt = static_cast<int>(T.size());
    for (int t = 0; t < mt; ++t) {
      if (!reg[t]) continue;
      const int a = T[t][0], b = T[t][1], c = T[t][2];
      const Vec3 pc = (P[a] + P[b] + P[c]) / 3.0;
      const double sc = (sig[a] + sig[b] + sig[c]) / 3.0;
      bool split = true;
      for (int v : {a, b, c}) {
        const double d = density * (pc - P[v]).norm();
        split = split && d > sc && d > sig[v];
      }
      if (!split) continue;
      if (P.size() >= kMaxVertices) throw MeshError("refine_region: refinement would exceed 67M vertices");
      const int x = static_cast<int>(P.size());
      P.push_back(pc);
      sig.push_back(sc);
      T[t] = Eigen::Vector3i(a, b, x);
      T.emplace_back(b, c, x), origin.push_back(origin[t]), reg.push_back(1);
      T.emplace_back(c, a, x), origin.push_back(origin[t]), reg.push_back(1);
      ++splits;
    }
    if (!splits) break;
    relax();
  }
  // Only for the new vertices' sake: without any, the flips would just undo the fill's min-weight
  // triangulation (retriangulate_fill) across a non-planar rim.
  if (static_cast<int>(P.size()) > n) valence_flips();
  remove_valence3(T, reg, origin, P, n, m);

  RegionSubdivision out;
  const int nv = static_cast<int>(P.size()), mt = static_cast<int>(T.size());
  out.V.resize(nv, 3);
  for (int v = 0; v < nv; ++v) out.V.row(v) = P[v].transpose();
  out.F.resize(mt, 3);
  out.face_origin.resize(mt);
  out.face_mask.assign(mt, 0);
  for (int t = 0; t < mt; ++t) {
    out.F.row(t) = T[t].transpose();
    out.face_origin[t] = origin[t];
    out.face_mask[t] = reg[t];
  }
  return out;
}
}  // namespace dgmesh
