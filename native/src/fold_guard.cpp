// Fold guard (see fold_guard.h).
#include "dgmesh/fold_guard.h"

#include <algorithm>
#include <utility>

namespace dgmesh {

namespace {

Vec3 face_normal(const MatX3d& X, const MatX3i& F, int f) {
  const Vec3 a = row3(X, F(f, 0));
  return (row3(X, F(f, 1)) - a).cross(row3(X, F(f, 2)) - a);
}

bool turned(const MatX3d& X, const MatX3d& X_ref, const MatX3i& F, int f) {
  return face_normal(X, F, f).dot(face_normal(X_ref, F, f)) < 0;
}

// CSR from (key, value) pairs, keys in [0, n).
void to_csr(std::vector<std::pair<int, int>>& pairs, int n, std::vector<int>& offset, std::vector<int>& index) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  offset.assign(n + 1, 0);
  index.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) ++offset[pairs[k].first + 1], index[k] = pairs[k].second;
  for (int i = 0; i < n; ++i) offset[i + 1] += offset[i];
}

}  // namespace

FoldGuard::FoldGuard(const MatX3i& F, int n_vertices) : F_(F) {
  std::vector<std::pair<int, int>> vv, vf;
  vv.reserve(static_cast<size_t>(F.rows()) * 6);
  vf.reserve(static_cast<size_t>(F.rows()) * 3);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      vv.emplace_back(a, b), vv.emplace_back(b, a), vf.emplace_back(a, f);
    }
  to_csr(vv, n_vertices, vv_offset_, vv_index_);
  to_csr(vf, n_vertices, vf_offset_, vf_index_);
}

int FoldGuard::apply(MatX3d& X, const MatX3d& X_ref, const FoldGuardOptions& opt, const std::vector<char>* fixed,
                     const Constrain& constrain) const {
  const int nf = static_cast<int>(F_.rows());
  std::vector<int> faces;
  {
    std::vector<char> flag(nf, 0);
#pragma omp parallel for schedule(static) if (nf >= 20000)
    for (int f = 0; f < nf; ++f) flag[f] = turned(X, X_ref, F_, f);
    for (int f = 0; f < nf; ++f)
      if (flag[f]) faces.push_back(f);
  }
  const int n = static_cast<int>(X.rows());
  std::vector<int> vstamp(faces.empty() ? 0 : n, -1), fstamp(faces.empty() ? 0 : nf, -1), region, front, next;
  MatX3d D;
  for (int it = 0; it < opt.iterations && !faces.empty(); ++it) {
    front.clear();
    for (int f : faces)
      for (int c = 0; c < 3; ++c)
        if (vstamp[F_(f, c)] != it) vstamp[F_(f, c)] = it, front.push_back(F_(f, c));
    region = front;
    for (int r = 0; r < opt.rings; ++r) {
      next.clear();
      for (int i : front)
        for (int k = vv_offset_[i]; k < vv_offset_[i + 1]; ++k)
          if (const int j = vv_index_[k]; vstamp[j] != it) vstamp[j] = it, next.push_back(j);
      region.insert(region.end(), next.begin(), next.end());
      front.swap(next);
    }
    const int nr = static_cast<int>(region.size());
    D.resize(nr, 3);
    for (int k = 0; k < nr; ++k) {
      const int i = region[k], k0 = vv_offset_[i], k1 = vv_offset_[i + 1];
      Vec3 d = row3(X, i) - row3(X_ref, i);
      if (k1 > k0 && !(fixed && (*fixed)[i])) {
        Vec3 mean = Vec3::Zero();
        for (int q = k0; q < k1; ++q) mean += row3(X, vv_index_[q]) - row3(X_ref, vv_index_[q]);
        d += opt.weight * (mean / double(k1 - k0) - d);
      }
      D.row(k) = d.transpose();
    }
    for (int k = 0; k < nr; ++k) {
      Vec3 x = row3(X_ref, region[k]) + D.row(k).transpose();
      if (!constrain || constrain(region[k], x)) X.row(region[k]) = x.transpose();
    }
    faces.clear();
    for (int i : region)
      for (int k = vf_offset_[i]; k < vf_offset_[i + 1]; ++k)
        if (const int f = vf_index_[k]; fstamp[f] != it) {
          fstamp[f] = it;
          if (turned(X, X_ref, F_, f)) faces.push_back(f);
        }
  }
  return static_cast<int>(faces.size());
}

}  // namespace dgmesh
