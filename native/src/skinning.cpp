// Bone weights and skeletal subspace deformation (linear blend and dual quaternion skinning, thesis
// eq. 6.2); see skeletal.h.
#include "dgmesh/skeletal.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dgmesh/detail/skeletal_util.h"
#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"
#include "dgmesh/parallel.h"
#include "dgmesh/spatial_index.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace detail {

bool dual_quaternion_motion(const Eigen::Vector4d& r, const Eigen::Vector4d& d, Mat3& R, Vec3& t) {
  const double len = r.norm();
  if (!(len > 1e-12)) return false;
  const Eigen::Quaterniond qr(r / len), qd(d / len);
  // translation t = 2 (d - (d.r) r) r^*, the part of d orthogonal to r (normalisation).
  const Eigen::Quaterniond qdo(qd.coeffs() - qd.coeffs().dot(qr.coeffs()) * qr.coeffs());
  R = qr.toRotationMatrix();
  t = 2.0 * (qdo * qr.conjugate()).vec();
  return true;
}

Mat3 blended_rotation(const Eigen::Ref<const Eigen::RowVectorXd>& w, const std::vector<Eigen::Quaterniond>& q) {
  Eigen::Vector4d acc = Eigen::Vector4d::Zero();
  Eigen::Index ref = -1;
  for (Eigen::Index j = 0; j < w.size(); ++j)
    if (w[j] != 0 && (ref < 0 || w[j] > w[ref])) ref = j;
  for (Eigen::Index j = 0; j < w.size(); ++j) {
    if (w[j] == 0) continue;
    const double sgn = q[j].coeffs().dot(q[ref].coeffs()) < 0 ? -1.0 : 1.0;
    acc += sgn * w[j] * q[j].coeffs();
  }
  return acc.norm() > 1e-12 ? Eigen::Quaterniond(acc / acc.norm()).toRotationMatrix() : Mat3::Identity();
}

Mat3 nearest_rotation(const Mat3& C) {
  if (!(C.squaredNorm() > 1e-300) || !C.allFinite()) return Mat3::Identity();
  {
    Mat3 R = C;
    const double scale = C.norm();
    bool ok = C.determinant() > 1e-6 * scale * scale * scale;
    for (int it = 0; ok && it < 30; ++it) {
      const double det = R.determinant();
      if (!(det > 0)) {
        ok = false;
        break;
      }
      const Mat3 Rit = R.inverse().transpose();
      const double g = std::sqrt(std::sqrt(Rit.squaredNorm() / R.squaredNorm()));
      const Mat3 Rn = 0.5 * (g * R + Rit / g);
      const double diff = (Rn - R).squaredNorm();
      R = Rn;
      if (diff < 1e-26) return R;
    }
    if (ok && (R.transpose() * R - Mat3::Identity()).squaredNorm() < 1e-20) return R;
  }
  Eigen::JacobiSVD<Mat3> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3 V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);
  return U * V.transpose();
}

Vec3 segment_closest(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

double segment_sq_dist(const Vec3& p, const Vec3& a, const Vec3& b) {
  return (segment_closest(p, a, b) - p).squaredNorm();
}

}  // namespace detail

using detail::blended_rotation;
using detail::dual_quaternion_motion;
using detail::Mat3;
using detail::MatX9d;
using detail::nearest_rotation;
using detail::segment_sq_dist;

Eigen::MatrixXd gaussian_bone_weights(const MatX3d& P, const MatX3d& heads, const MatX3d& tails, double sigma) {
  const int n = static_cast<int>(P.rows()), B = static_cast<int>(heads.rows());
  if (B == 0 || tails.rows() != B)
    throw MeshError("Gaussian weights need as many bone heads as tails (and at least one)");
  if (!(sigma > 0)) throw MeshError("Gaussian weights need sigma > 0");
  Eigen::MatrixXd W(n, B);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n; ++i) {
    double dmin = std::numeric_limits<double>::infinity();
    for (int j = 0; j < B; ++j) {
      W(i, j) = segment_sq_dist(row3(P, i), row3(heads, j), row3(tails, j));
      dmin = std::min(dmin, W(i, j));
    }
    double sum = 0;
    for (int j = 0; j < B; ++j) {  // the nearest bones get 1 even when sigma^2 underflows (0 / 0)
      const double x = W(i, j) - dmin;
      sum += (W(i, j) = x > 0 ? std::exp(-x / (2 * sigma * sigma)) : 1.0);
    }
    W.row(i) /= sum;
  }
  return W;
}

MatX3d skeletal_subspace_deform(const MatX3d& P, const Eigen::MatrixXd& W, const std::vector<Mat4>& rest,
                                const std::vector<Mat4>& pose, MatX9d* linear, bool dual_quaternion) {
  const int n = static_cast<int>(P.rows()), B = static_cast<int>(rest.size());
  if (static_cast<int>(pose.size()) != B || W.cols() != B || W.rows() != n)
    throw MeshError("SSD: expected " + std::to_string(B) + " pose matrices and an n x B weight matrix");
  // A_j = B_j^d B_j^-1 as one affine map per bone (eq. 6.2).
  std::vector<Eigen::Matrix<double, 3, 4>> A(B);
  for (int j = 0; j < B; ++j) {
    const Mat4 m = pose[j] * rest[j].inverse();
    if (!m.allFinite()) throw MeshError("SSD: bone " + std::to_string(j) + " has a singular rest matrix");
    A[j] = m.topRows<3>();
  }
  // Bone rotations as quaternions, for the blended frames (see below).
  std::vector<Eigen::Quaterniond> q(B);
  // Dual quaternions need rigid bone motions; a scaled or sheared pose keeps the linear blend
  // (the tolerance admits the float32 rounding of the matrices Blender hands over).
  bool dq = dual_quaternion;
  for (int j = 0; dq && j < B; ++j) {
    const Mat3 L = A[j].leftCols<3>();
    if ((L.transpose() * L - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-4 || !(L.determinant() > 0)) dq = false;
  }
  if (linear || dq)
    for (int j = 0; j < B; ++j) q[j] = Eigen::Quaterniond(nearest_rotation(A[j].leftCols<3>())).normalized();
  // Dual parts d_j = t_j q_j / 2 (t_j the translation as a pure quaternion).
  std::vector<Eigen::Vector4d> qd(dq ? B : 0);
  for (int j = 0; dq && j < B; ++j) {
    const Eigen::Quaterniond t(0, A[j](0, 3), A[j](1, 3), A[j](2, 3));
    qd[j] = 0.5 * (t * q[j]).coeffs();
  }
  MatX3d out(n, 3);
  if (linear) linear->resize(n, 9);
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int i = 0; i < n; ++i) {
    if (dq) {
      // Dual quaternion blending (Kavan et al. 2007): rigid per point, so the skeletal mesh does
      // not collapse towards a bone's axis under a twist the way the linear blend does (a point at
      // distance delta from the axis of a 180-degree twist keeps |w0 - w1| delta under eq. 6.2).
      int ref = 0;
      for (int j = 1; j < B; ++j)
        if (W(i, j) > W(i, ref)) ref = j;
      Eigen::Vector4d r = Eigen::Vector4d::Zero(), dd = Eigen::Vector4d::Zero();
      for (int j = 0; j < B; ++j) {
        const double w = W(i, j);
        if (w == 0) continue;
        const double sgn = q[j].coeffs().dot(q[ref].coeffs()) < 0 ? -1.0 : 1.0;
        r += sgn * w * q[j].coeffs();
        dd += sgn * w * qd[j];
      }
      Mat3 R;
      Vec3 t;
      if (dual_quaternion_motion(r, dd, R, t))
        out.row(i) = (R * row3(P, i) + t).transpose();
      else
        out.row(i) = P.row(i);
    } else {
      Eigen::Matrix<double, 3, 4> M = Eigen::Matrix<double, 3, 4>::Zero();
      for (int j = 0; j < B; ++j) {
        const double w = W(i, j);
        if (w != 0) M += w * A[j];
      }
      out.row(i) = (M.leftCols<3>() * row3(P, i) + M.col(3)).transpose();
    }
    if (linear) {
      // The rotation of the point's local frame: the bone rotations blended as quaternions.
      const Mat3 R = blended_rotation(W.row(i), q);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) (*linear)(i, 3 * r + c) = R(r, c);
    }
  }
  return out;
}

}  // namespace dgmesh
