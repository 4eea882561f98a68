// unwrap_charts(): every chart of a mesh in one call, each by unwrap() on its own.
#include <algorithm>
#include <string>
#include <vector>

#include "dgmesh/errors.h"
#include "dgmesh/unwrap.h"

namespace dgmesh {

UnwrapChartError::UnwrapChartError(int chart, int n_charts, int n_triangles, const std::string& reason)
    : MeshError("chart " + std::to_string(chart + 1) + " of " + std::to_string(n_charts) + " (" +
                std::to_string(n_triangles) + " triangles): " + reason),
      chart(chart),
      reason(reason) {}

UnwrapChartsResult unwrap_charts(const MatX3d& V, const MatX3i& F, const VecXi& labels, const UnwrapOptions& options,
                                 const ProgressFn& progress) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if (labels.size() != m)
    throw MeshError("unwrap_charts: one label per triangle (" + std::to_string(m) + "), got " +
                    std::to_string(labels.size()));
  if (m > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
    throw MeshError("unwrap_charts: face indices out of range [0, " + std::to_string(n) + ")");
  if (m > 0 && labels.minCoeff() < 0) throw MeshError("unwrap_charts: labels must be >= 0");
  const int k = m > 0 ? labels.maxCoeff() + 1 : 0;
  // The triangles of each chart, in the order of F.
  std::vector<std::vector<int>> faces(k);
  for (int f = 0; f < m; ++f) faces[labels[f]].push_back(f);
  for (int c = 0; c < k; ++c)
    if (faces[c].empty()) throw MeshError("unwrap_charts: label " + std::to_string(c) + " has no triangle");

  UnwrapChartsResult res;
  res.uv.setZero(3 * m, 2);
  res.charts.resize(k);
  std::vector<int> local(n, -1);
  double done = 0;
  for (int c = 0; c < k; ++c) {
    const std::vector<int>& fc = faces[c];
    // The chart's vertices in increasing order of their index in V.
    std::vector<int> verts;
    verts.reserve(3 * fc.size());
    for (int f : fc)
      for (int j = 0; j < 3; ++j) verts.push_back(F(f, j));
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    for (size_t i = 0; i < verts.size(); ++i) local[verts[i]] = static_cast<int>(i);
    MatX3d Vc(verts.size(), 3);
    for (size_t i = 0; i < verts.size(); ++i) Vc.row(i) = V.row(verts[i]);
    MatX3i Fc(fc.size(), 3);
    for (size_t i = 0; i < fc.size(); ++i)
      for (int j = 0; j < 3; ++j) Fc(i, j) = local[F(fc[i], j)];

    const double share = static_cast<double>(fc.size()) / m;
    ProgressFn sub;
    if (progress) sub = [&progress, done, share](double f) { return progress(done + f * share); };
    try {
      res.charts[c] = unwrap(Vc, Fc, options, sub);
    } catch (const MeshError& e) {
      throw UnwrapChartError(c, k, static_cast<int>(fc.size()), e.what());
    }
    const MatX2d& uv = res.charts[c].uv;
    for (size_t i = 0; i < fc.size(); ++i)
      for (int j = 0; j < 3; ++j) res.uv.row(3 * fc[i] + j) = uv.row(Fc(i, j));
    done += share;
  }
  return res;
}

}  // namespace dgmesh
