// Fold guard (see fold_guard.h).
#include "dgmesh/fold_guard.h"

#include <algorithm>
#include <utility>

namespace dgmesh {

namespace {

template <class Mat>
using Vec3Of = Eigen::Matrix<typename Mat::Scalar, 3, 1>;

template <class Mat>
Vec3Of<Mat> face_normal(const Mat& X, const MatX3i& F, int f) {
  const Vec3Of<Mat> a = X.row(F(f, 0)).transpose();
  return (X.row(F(f, 1)).transpose() - a).cross(X.row(F(f, 2)).transpose() - a);
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

// Per-thread scratch of apply, kept between calls: a pose of a 178K-vertex mesh allocated (and
// page-faulted) a few megabytes per call otherwise.
template <class Scalar>
struct Scratch {
  std::vector<int> vstamp, fstamp, region, front, next, faces;
  std::vector<char> flag;
  Eigen::Matrix<Scalar, Eigen::Dynamic, 3, Eigen::RowMajor> D;
};

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

int FoldGuard::apply(Eigen::Ref<MatX3d> X, const MatX3d& X_ref, const FoldGuardOptions& opt,
                     const std::vector<char>* fixed, const Constrain& constrain, const std::vector<int>* faces,
                     const Trusted& trusted) const {
  return apply_<MatX3d>(X, X_ref, opt, fixed, constrain, faces, trusted);
}

int FoldGuard::apply(Eigen::Ref<MatX3f> X, const MatX3f& X_ref, const FoldGuardOptions& opt,
                     const std::vector<char>* fixed, const Constrain& constrain, const std::vector<int>* faces,
                     const Trusted& trusted) const {
  return apply_<MatX3f>(X, X_ref, opt, fixed, constrain, faces, trusted);
}

template <class Mat>
int FoldGuard::apply_(Eigen::Ref<Mat> X, const Mat& X_ref, const FoldGuardOptions& opt, const std::vector<char>* fixed,
                      const Constrain& constrain, const std::vector<int>* first, const Trusted& trusted) const {
  using Scalar = typename Mat::Scalar;
  using V3 = Vec3Of<Mat>;
  static thread_local Scratch<Scalar> s;
  const int nf = static_cast<int>(F_.rows()), n = static_cast<int>(X.rows());
  s.flag.assign(nf, 0);
  char* flag = s.flag.data();  // (the OpenMP threads have scratch of their own)
  const int m = first ? static_cast<int>(first->size()) : nf;
#pragma omp parallel for schedule(static) if (m >= 20000)
  for (int k = 0; k < m; ++k) {
    const int f = first ? (*first)[k] : k;
    flag[f] = face_normal(X, F_, f).dot(face_normal(X_ref, F_, f)) < 0;
  }
  auto& faces = s.faces;
  faces.clear();
  for (int f = 0; f < nf; ++f)
    if (flag[f] && (!trusted || trusted(f))) faces.push_back(f);
  if (faces.empty() || opt.iterations <= 0) return static_cast<int>(faces.size());
  s.vstamp.assign(n, -1), s.fstamp.assign(nf, -1);
  auto &vstamp = s.vstamp, &fstamp = s.fstamp, &region = s.region, &front = s.front, &next = s.next;
  auto& D = s.D;
  long long visits = 0;
  for (int it = 0; it < opt.iterations && !faces.empty() && visits < opt.max_visits; ++it) {
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
    visits += nr;
    D.resize(nr, 3);
    for (int k = 0; k < nr; ++k) {
      const int i = region[k], k0 = vv_offset_[i], k1 = vv_offset_[i + 1];
      V3 d = (X.row(i) - X_ref.row(i)).transpose();
      if (k1 > k0 && !(fixed && (*fixed)[i])) {
        V3 mean = V3::Zero();
        for (int q = k0; q < k1; ++q) mean += (X.row(vv_index_[q]) - X_ref.row(vv_index_[q])).transpose();
        d += Scalar(opt.weight) * (mean / Scalar(k1 - k0) - d);
      }
      D.row(k) = d.transpose();
    }
    for (int k = 0; k < nr; ++k) {
      Vec3 x = (X_ref.row(region[k]) + D.row(k)).transpose().template cast<double>();
      if (!constrain || constrain(region[k], x)) X.row(region[k]) = x.transpose().template cast<Scalar>();
    }
    faces.clear();
    for (int i : region)
      for (int k = vf_offset_[i]; k < vf_offset_[i + 1]; ++k)
        if (const int f = vf_index_[k]; fstamp[f] != it) {
          fstamp[f] = it;
          if (face_normal(X, F_, f).dot(face_normal(X_ref, F_, f)) < 0 && (!trusted || trusted(f))) faces.push_back(f);
        }
  }
  return static_cast<int>(faces.size());
}

}  // namespace dgmesh
