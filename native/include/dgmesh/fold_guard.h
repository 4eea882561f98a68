// Fold guard: keeps a displacement of a surface from turning its faces over (issue 33: the
// skeletal deformation's thickness steps move each vertex towards its own deepest medial ball, and
// where neighbours head for different balls, in the concave corner of a bent joint's union of balls,
// faces turn over and the surface folds through itself).
#pragma once
#include <functional>
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

struct FoldGuardOptions {
  int iterations = 20;  // smoothing iterations at most (0 = off)
  int rings = 1;        // rings around a turned face's vertices that are smoothed with them
  double weight = 0.5;  // Jacobi weight of the one-ring mean
  // Work bound: the iterations stop once this many vertices have been smoothed, counted over all
  // iterations (a tight bend of a dense mesh turns thousands of faces: its cost is bounded, about
  // 20 ms for a 178K-vertex mesh, see bench/notes/skeletal.md).
  int max_visits = 100000;
};

// The adjacency of a triangle mesh that the guard walks, built once per mesh (a pose needs none).
class FoldGuard {
 public:
  FoldGuard() = default;
  FoldGuard(const MatX3i& F, int n_vertices);

  // X comes in as X_ref + D, X_ref the surface before the displacement D. A face is turned when its
  // normal in X points against its normal in X_ref. While some face is turned, the displacement of
  // its vertices and opt.rings rings around them is averaged with their one-ring's (D_i <-
  // (1 - weight) D_i + weight mean_j D_j, Jacobi), at most opt.iterations times; only the faces
  // around the smoothed vertices are checked again. A vertex with `fixed` set (optional, one entry
  // per vertex) is not moved. `faces` (optional): only these faces are checked first (the
  // others count as not turned, e.g. where D is known to be a rigid motion); the faces around the
  // smoothed vertices are all checked again. `trusted` (optional) is asked about each face found
  // turned: when it returns false the face is left alone (its orientation in X_ref itself is wrong,
  // e.g. X_ref folds there and D unfolds it). `constrain` (optional) gets each smoothed position (vertex i, x) and
  // may move x (e.g. out to a clearance); when it returns false the vertex keeps its position.
  // Returns the number of faces still turned (0 when D turns none: X is then unchanged). X and X_ref
  // must have the mesh's vertex count; single precision (the live update's buffer) is computed in
  // single precision. Safe to call from several threads at once.
  using Constrain = std::function<bool(int, Vec3&)>;
  using Trusted = std::function<bool(int)>;
  int apply(Eigen::Ref<MatX3d> X, const MatX3d& X_ref, const FoldGuardOptions& opt = {},
            const std::vector<char>* fixed = nullptr, const Constrain& constrain = {},
            const std::vector<int>* faces = nullptr, const Trusted& trusted = {}) const;
  int apply(Eigen::Ref<MatX3f> X, const MatX3f& X_ref, const FoldGuardOptions& opt = {},
            const std::vector<char>* fixed = nullptr, const Constrain& constrain = {},
            const std::vector<int>* faces = nullptr, const Trusted& trusted = {}) const;

  bool empty() const { return F_.rows() == 0; }

 private:
  template <class Mat>
  int apply_(Eigen::Ref<Mat> X, const Mat& X_ref, const FoldGuardOptions& opt, const std::vector<char>* fixed,
             const Constrain& constrain, const std::vector<int>* first, const Trusted& trusted) const;
  MatX3i F_;
  std::vector<int> vv_offset_, vv_index_, vf_offset_, vf_index_;
};

}  // namespace dgmesh
