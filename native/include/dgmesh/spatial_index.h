// A static kd-tree over 3D points (nanoflann), for radius and k-nearest queries.
#pragma once
#include <memory>
#include <utility>
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

class KdTree {
 public:
  // Copies the points (the tree must not depend on the caller's array staying alive). Small
  // leaves suit trees rebuilt often and queried for few neighbours.
  explicit KdTree(const MatX3d& points, int leaf_size = 16);
  ~KdTree();
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;

  int size() const;
  const MatX3d& points() const { return points_; }

  // All points within distance r of q as (index, squared distance), unsorted. `out` is reused.
  void radius(const Vec3& q, double r, std::vector<std::pair<int, double>>& out) const;
  // The k nearest points, nearest first. Returns how many were found (min(k, size)).
  int knn(const Vec3& q, int k, std::vector<int>& idx, std::vector<double>& sq_dist) const;
  // Of the k nearest points, those closer than sqrt(bound2), into caller arrays of size k (no
  // allocation; the bound prunes the search from the start). Returns their count.
  int knn(const Vec3& q, int k, int* idx, double* sq_dist, double bound2) const;
  // Index of the nearest point, or -1 when empty.
  int nearest(const Vec3& q, double* sq_dist = nullptr) const;

 private:
  struct Impl;
  MatX3d points_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dgmesh
