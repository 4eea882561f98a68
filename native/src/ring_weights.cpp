// Bone weights smoothed around the limbs; see ring_weights.h.
#include "dgmesh/ring_weights.h"

#include <algorithm>
#include <string>
#include <vector>

#include "dgmesh/errors.h"
#include "dgmesh/sparse_solver.h"

namespace dgmesh {

Eigen::MatrixXd ring_weights(const MatX3d& V, const MatX3i& F, const Eigen::MatrixXd& W, const MatX3d& bone_dirs,
                             const VecXd& radius, const RingWeightOptions& opt) {
  const int n = static_cast<int>(V.rows()), B = static_cast<int>(W.cols());
  if (W.rows() != n || radius.size() != n || bone_dirs.rows() != B)
    throw MeshError("ring_weights: W (" + std::to_string(W.rows()) + " rows), radius (" +
                    std::to_string(radius.size()) + ") and bone_dirs (" + std::to_string(bone_dirs.rows()) +
                    " rows, one per column of W) must match the mesh's " + std::to_string(n) + " vertices");
  if (n == 0 || B < 2) return W;
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
    throw MeshError("ring_weights: F has a vertex index out of range");
  if (!(opt.scale > 0) || !(opt.floor >= 0 && opt.floor < 1))
    throw MeshError("ring_weights: scale must be > 0 and floor in [0, 1)");
  MatX3d axis(B, 3);
  for (int j = 0; j < B; ++j) {
    const double len = bone_dirs.row(j).norm();
    axis.row(j) = len > 0 ? Eigen::RowVector3d(bone_dirs.row(j) / len) : Eigen::RowVector3d::Zero();
  }
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(F.rows()) * 9 + n);
  VecXd mass = VecXd::Zero(n);
  for (int f = 0; f < F.rows(); ++f) {
    const Vec3 p[3] = {V.row(F(f, 0)).transpose(), V.row(F(f, 1)).transpose(), V.row(F(f, 2)).transpose()};
    const Vec3 nrm = (p[1] - p[0]).cross(p[2] - p[0]);
    const double area2 = nrm.norm();
    if (!(area2 > 1e-300)) continue;
    const Vec3 nh = nrm / area2;
    int dom = 0;
    double best = -1;
    for (int j = 0; j < B; ++j) {
      const double s = W(F(f, 0), j) + W(F(f, 1), j) + W(F(f, 2), j);
      if (s > best) best = s, dom = j;
    }
    const Vec3 a = axis.row(dom).transpose();
    // grad of corner k's hat function: nh x (p_{k+2} - p_{k+1}) / (2 A); Pg its part off the axis.
    Vec3 g[3], Pg[3];
    for (int k = 0; k < 3; ++k) {
      g[k] = nh.cross(p[(k + 2) % 3] - p[(k + 1) % 3]) / area2;
      Pg[k] = g[k] - a.dot(g[k]) * a;
    }
    const double area = 0.5 * area2;
    for (int k = 0; k < 3; ++k) {
      mass[F(f, k)] += area / 3;
      for (int l = 0; l < 3; ++l) trip.emplace_back(F(f, k), F(f, l), area * Pg[k].dot(g[l]));
    }
  }
  const double rmax = radius.maxCoeff();
  if (!(rmax > 0)) throw MeshError("ring_weights: radius must have a positive value");
  VecXd fid(n);
  for (int i = 0; i < n; ++i) {
    const double l = opt.scale * std::max(radius[i], 1e-3 * rmax);
    // A vertex on no face keeps its weights (unit fidelity, no coupling).
    fid[i] = mass[i] > 0 ? mass[i] / (l * l) : 1.0;
    trip.emplace_back(i, i, fid[i]);
  }
  SpMat A(n, n);
  A.setFromTriplets(trip.begin(), trip.end());
  SparseSolver solver;
  solver.factor(A, SparseSolver::Kind::Cholesky);
  Eigen::MatrixXd Wr = solver.solve(fid.asDiagonal() * W);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < B; ++j)
      if (!(Wr(i, j) >= opt.floor)) Wr(i, j) = 0;
    const double s = Wr.row(i).sum();
    if (s > 0)
      Wr.row(i) /= s;
    else
      Wr.row(i) = W.row(i);
  }
  return Wr;
}

}  // namespace dgmesh
