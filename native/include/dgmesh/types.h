// Shared array types. Row-major so that a vertex (or face) is contiguous, matching numpy's
// C order: pybind11 maps (n, 3) float64 / int32 arrays onto these without a copy.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>

namespace dgmesh {

using MatX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using MatX3f = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;  // e.g. Blender's float buffers
using MatX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using MatX2i = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;
using Vec3 = Eigen::Vector3d;
using VecXd = Eigen::VectorXd;
using VecXi = Eigen::VectorXi;
using SpMat = Eigen::SparseMatrix<double>;
using SpMatR = Eigen::SparseMatrix<double, Eigen::RowMajor>;

inline Vec3 row3(const MatX3d& V, int i) { return V.row(i).transpose(); }

}  // namespace dgmesh
