// Self-intersecting triangle pairs through a uniform grid (see self_intersection.h).
#include "dgmesh/self_intersection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

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

// Every pair (p, q), p != q, of boxes that meet, once each, through a uniform grid whose cell is the
// boxes' mean largest extent; with `active`, only pairs with an active box.
template <class Visit>
void box_pairs(const std::vector<Vec3>& lo, const std::vector<Vec3>& hi, const std::vector<char>* active, Visit visit) {
  const int m = static_cast<int>(lo.size());
  if (m < 2) return;
  double ext = 0;
  Vec3 origin = Vec3::Constant(std::numeric_limits<double>::infinity());
  for (int k = 0; k < m; ++k) ext += (hi[k] - lo[k]).maxCoeff(), origin = origin.cwiseMin(lo[k]);
  const double cell = std::max(ext / m, 1e-12);
  if (!origin.allFinite()) return;
  // Cell ranges per box (coordinates clamped to 21 bits), and (cell key, box) entries sorted.
  std::vector<std::array<int, 6>> range(m);
  std::vector<std::pair<uint64_t, int>> entries;
  entries.reserve(static_cast<size_t>(m) * 4);
  const auto coord = [&](double x, double o) {
    return static_cast<int>(std::clamp(std::floor((x - o) / cell), 0.0, double((1 << 21) - 1)));
  };
  for (int k = 0; k < m; ++k) {
    auto& r = range[k];
    for (int d = 0; d < 3; ++d) r[d] = coord(lo[k][d], origin[d]), r[d + 3] = coord(hi[k][d], origin[d]);
    for (int x = r[0]; x <= r[3]; ++x)
      for (int y = r[1]; y <= r[4]; ++y)
        for (int z = r[2]; z <= r[5]; ++z)
          entries.emplace_back((uint64_t(x) << 42) | (uint64_t(y) << 21) | uint64_t(z), k);
  }
  std::sort(entries.begin(), entries.end());
  for (size_t a = 0; a < entries.size();) {
    size_t b = a;
    while (b < entries.size() && entries[b].first == entries[a].first) ++b;
    const uint64_t key = entries[a].first;
    const int cx = int(key >> 42), cy = int((key >> 21) & 0x1FFFFF), cz = int(key & 0x1FFFFF);
    for (size_t i = a; i < b; ++i)
      for (size_t j = i + 1; j < b; ++j) {
        const int p = entries[i].second, q = entries[j].second;
        if (active && !(*active)[p] && !(*active)[q]) continue;
        // Each pair once: in the first cell of the overlap of its two cell ranges.
        const auto &rp = range[p], &rq = range[q];
        if (cx != std::max(rp[0], rq[0]) || cy != std::max(rp[1], rq[1]) || cz != std::max(rp[2], rq[2])) continue;
        if (!boxes_meet(lo[p], hi[p], lo[q], hi[q])) continue;
        visit(p, q);
      }
    a = b;
  }
}

void face_box(const MatX3d& V, const MatX3i& F, int f, Vec3& lo, Vec3& hi) {
  lo = hi = V.row(F(f, 0)).transpose();
  for (int c = 1; c < 3; ++c) {
    lo = lo.cwiseMin(V.row(F(f, c)).transpose());
    hi = hi.cwiseMax(V.row(F(f, c)).transpose());
  }
}

// The crossing pairs among `list` (face indices), with `active` as in box_pairs.
std::vector<std::pair<int, int>> crossing_pairs(const MatX3d& V, const MatX3i& F, const std::vector<int>& list,
                                                const std::vector<char>* active) {
  const int m = static_cast<int>(list.size());
  std::vector<Vec3> lo(m), hi(m);
  for (int k = 0; k < m; ++k) face_box(V, F, list[k], lo[k], hi[k]);
  std::vector<std::pair<int, int>> pairs;
  box_pairs(lo, hi, active, [&](int p, int q) {
    const int fp = list[p], fq = list[q];
    bool share = false;
    for (int s = 0; s < 3; ++s)
      for (int t = 0; t < 3; ++t) share |= F(fp, s) == F(fq, t);
    if (share) return;
    const std::array<Vec3, 3> S{V.row(F(fp, 0)).transpose(), V.row(F(fp, 1)).transpose(), V.row(F(fp, 2)).transpose()};
    const std::array<Vec3, 3> T{V.row(F(fq, 0)).transpose(), V.row(F(fq, 1)).transpose(), V.row(F(fq, 2)).transpose()};
    if (triangles_cross(S, T)) pairs.emplace_back(std::min(fp, fq), std::max(fp, fq));
  });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace

std::vector<std::pair<int, int>> self_intersecting_pairs(const MatX3d& V, const MatX3i& F,
                                                         const std::vector<int>* faces) {
  if (faces) return crossing_pairs(V, F, *faces, nullptr);
  std::vector<int> all(F.rows());
  std::iota(all.begin(), all.end(), 0);
  return crossing_pairs(V, F, all, nullptr);
}

std::vector<std::pair<int, int>> self_intersecting_pairs_touching(const MatX3d& V, const MatX3i& F,
                                                                  const std::vector<int>* faces,
                                                                  const std::vector<char>& touching) {
  const int nf = faces ? static_cast<int>(faces->size()) : static_cast<int>(F.rows());
  const auto face_at = [&](int k) { return faces ? (*faces)[k] : k; };
  // The box of the flagged faces; then every face of `faces` meeting it, flagged ones first.
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo, a, b;
  std::vector<int> list;
  for (int k = 0; k < nf; ++k) {
    const int f = face_at(k);
    if (!touching[f]) continue;
    face_box(V, F, f, a, b);
    lo = lo.cwiseMin(a), hi = hi.cwiseMax(b);
    list.push_back(f);
  }
  if (list.empty()) return {};
  std::vector<char> active(list.size(), 1);
  for (int k = 0; k < nf; ++k) {
    const int f = face_at(k);
    if (touching[f]) continue;
    face_box(V, F, f, a, b);
    if (boxes_meet(a, b, lo, hi)) list.push_back(f), active.push_back(0);
  }
  return crossing_pairs(V, F, list, &active);
}

}  // namespace dgmesh
