// Linear 1-to-4 subdivision of a region of faces, border edges kept (subdivide_region, declared in
// fair.h): the coarse-to-fine levels of the curvature flows (thesis fig. 3.5).
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "dgmesh/detail/edge_key.h"
#include "dgmesh/errors.h"
#include "dgmesh/fair.h"

namespace dgmesh {

using detail::edge_key;

RegionSubdivision subdivide_region(const MatX3d& V, const MatX3i& F, const std::vector<char>& face_mask) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if (face_mask.size() != static_cast<size_t>(m))
    throw MeshError("subdivide_region: face mask size differs from the face count");
  // Count, for each edge of a region face, its region faces and all its faces.
  std::unordered_map<long long, std::pair<int, int>> count;  // key -> (region, all)
  for (int f = 0; f < m; ++f)
    if (face_mask[f])
      for (int k = 0; k < 3; ++k) count[edge_key(F(f, k), F(f, (k + 1) % 3))].first++;
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      auto it = count.find(edge_key(F(f, k), F(f, (k + 1) % 3)));
      if (it != count.end()) it->second.second++;
    }
  RegionSubdivision out;
  std::unordered_map<long long, int> mid;
  auto midpoint = [&](int a, int b) -> int {
    const long long key = edge_key(a, b);
    const auto& c = count[key];
    if (c.first != c.second) return -1;  // border edge: keep it whole
    auto [it, inserted] = mid.try_emplace(key, n + static_cast<int>(out.edge_a.size()));
    if (inserted) out.edge_a.push_back(std::min(a, b)), out.edge_b.push_back(std::max(a, b));
    return it->second;
  };
  std::vector<Eigen::Vector3i> extra;
  std::vector<int> extra_origin;
  out.F = F;
  auto emit = [&](int f, bool& first, int a, int b, int c) {
    if (first) {
      out.F.row(f) << a, b, c;
      first = false;
    } else {
      extra.emplace_back(a, b, c);
      extra_origin.push_back(f);
    }
  };
  for (int f = 0; f < m; ++f) {
    if (!face_mask[f]) continue;
    const int v[3] = {F(f, 0), F(f, 1), F(f, 2)};
    int mids[3];
    int split = 0;
    for (int k = 0; k < 3; ++k) split += (mids[k] = midpoint(v[k], v[(k + 1) % 3])) >= 0;
    bool first = true;
    if (split == 3) {
      emit(f, first, mids[0], mids[1], mids[2]);
      emit(f, first, v[0], mids[0], mids[2]);
      emit(f, first, mids[0], v[1], mids[1]);
      emit(f, first, mids[2], mids[1], v[2]);
    } else if (split == 2) {
      int j = 0;  // the unsplit edge, rotated to (c, a)
      while (mids[j] >= 0) ++j;
      const int r = (j + 1) % 3;
      const int a = v[r], b = v[(r + 1) % 3], c = v[(r + 2) % 3];
      const int mab = mids[r], mbc = mids[(r + 1) % 3];
      emit(f, first, mab, b, mbc);
      auto pos = [&](int i) -> Vec3 {
        if (i < n) return V.row(i).transpose();
        const int e = i - n;
        return 0.5 * (V.row(out.edge_a[e]) + V.row(out.edge_b[e])).transpose();
      };
      if ((pos(a) - pos(mbc)).squaredNorm() <= (pos(mab) - pos(c)).squaredNorm()) {
        emit(f, first, a, mab, mbc);
        emit(f, first, a, mbc, c);
      } else {
        emit(f, first, a, mab, c);
        emit(f, first, mab, mbc, c);
      }
    } else if (split == 1) {
      int j = 0;
      while (mids[j] < 0) ++j;
      const int a = v[j], b = v[(j + 1) % 3], c = v[(j + 2) % 3];
      emit(f, first, a, mids[j], c);
      emit(f, first, mids[j], b, c);
    }
  }
  const int ne = static_cast<int>(out.edge_a.size()), nx = static_cast<int>(extra.size());
  out.V.resize(n + ne, 3);
  out.V.topRows(n) = V;
  for (int e = 0; e < ne; ++e) out.V.row(n + e) = 0.5 * (V.row(out.edge_a[e]) + V.row(out.edge_b[e]));
  out.F.conservativeResize(m + nx, 3);
  out.face_origin.resize(m + nx);
  std::iota(out.face_origin.data(), out.face_origin.data() + m, 0);
  for (int i = 0; i < nx; ++i) {
    out.F.row(m + i) = extra[i].transpose();
    out.face_origin[m + i] = extra_origin[i];
  }
  out.face_mask.assign(m + nx, 0);
  for (int i = 0; i < m + nx; ++i) out.face_mask[i] = face_mask[out.face_origin[i]];
  return out;
}

}  // namespace dgmesh
