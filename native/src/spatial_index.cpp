#include "dgmesh/spatial_index.h"

#include <nanoflann.hpp>

namespace dgmesh {

namespace {
// nanoflann's dataset adaptor over the row-major point array.
struct Cloud {
  const MatX3d* p;
  size_t kdtree_get_point_count() const { return static_cast<size_t>(p->rows()); }
  double kdtree_get_pt(size_t i, size_t d) const {
    return (*p)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d));
  }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, int>;

// Unsorted, exact search. nanoflann 1.5 renamed SearchParams(checks, eps, sorted) to
// SearchParameters(eps, sorted) (bookworm ships 1.4, trixie 1.7, sid 1.12; 1.12 writes its
// version as 0x010C01, still above 0x150).
#if NANOFLANN_VERSION >= 0x150
const nanoflann::SearchParameters kUnsorted(0.0f, false);
#else
const nanoflann::SearchParams kUnsorted(32, 0.0f, false);
#endif

// A radius result set writing (index, squared distance) pairs; nanoflann's own changed its item
// type in 1.5 (std::pair -> ResultItem). The members are those findNeighbors calls.
struct RadiusPairs {
  using DistanceType = double;
  using IndexType = int;
  double radius2;
  std::vector<std::pair<int, double>>& out;
  size_t size() const { return out.size(); }
  bool empty() const { return out.empty(); }
  bool full() const { return true; }
  double worstDist() const { return radius2; }
  bool addPoint(double d, int i) {
    if (d < radius2) out.emplace_back(i, d);
    return true;
  }
  void sort() {}
};
}  // namespace

struct KdTree::Impl {
  Cloud cloud;
  Tree tree;
  Impl(const MatX3d* p, int leaf_size)
      : cloud{p}, tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<size_t>(leaf_size))) {
    tree.buildIndex();
  }
};

KdTree::KdTree(const MatX3d& points, int leaf_size)
    : points_(points), impl_(std::make_unique<Impl>(&points_, leaf_size)) {}
KdTree::~KdTree() = default;
// Moving an Eigen matrix keeps its heap buffer, but the adaptor points at the member: re-aim it.
KdTree::KdTree(KdTree&& o) noexcept : points_(std::move(o.points_)), impl_(std::move(o.impl_)) {
  if (impl_) impl_->cloud.p = &points_;
}
KdTree& KdTree::operator=(KdTree&& o) noexcept {
  points_ = std::move(o.points_);
  impl_ = std::move(o.impl_);
  if (impl_) impl_->cloud.p = &points_;
  return *this;
}

int KdTree::size() const { return static_cast<int>(points_.rows()); }

void KdTree::radius(const Vec3& q, double r, std::vector<std::pair<int, double>>& out) const {
  out.clear();
  if (points_.rows() == 0) return;
  RadiusPairs rs{r * r, out};  // nanoflann's L2 distances are squared
  impl_->tree.findNeighbors(rs, q.data(), kUnsorted);
}

int KdTree::knn(const Vec3& q, int k, std::vector<int>& idx, std::vector<double>& sq_dist) const {
  const int kk = std::min<int>(k, size());
  idx.resize(kk);
  sq_dist.resize(kk);
  if (kk <= 0) return 0;
  const size_t found = impl_->tree.knnSearch(q.data(), static_cast<size_t>(kk), idx.data(), sq_dist.data());
  idx.resize(found);
  sq_dist.resize(found);
  return static_cast<int>(found);
}

int KdTree::knn(const Vec3& q, int k, int* idx, double* sq_dist, double bound2) const {
  const size_t cap = static_cast<size_t>(std::min<int>(k, size()));
  if (cap == 0) return 0;
  nanoflann::KNNResultSet<double, int> rs(cap);
  rs.init(idx, sq_dist);
  sq_dist[cap - 1] = bound2;  // the result set's worst distance until it fills: nothing farther enters
  impl_->tree.findNeighbors(rs, q.data(), kUnsorted);
  return static_cast<int>(rs.size());
}

int KdTree::nearest(const Vec3& q, double* sq_dist) const {
  if (points_.rows() == 0) return -1;
  int i = -1;
  double d = 0;
  impl_->tree.knnSearch(q.data(), 1, &i, &d);
  if (sq_dist) *sq_dist = d;
  return i;
}

}  // namespace dgmesh
