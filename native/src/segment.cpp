#include "dgmesh/segment.h"

#include <algorithm>
#include <limits>
#include <queue>
#include <string>
#include <tuple>

#include "dgmesh/errors.h"
#include "dgmesh/geometry.h"

namespace dgmesh {

namespace {

struct Vsa {
  const Topology& topo;
  const MatX3d& N;  // face normals
  const VecXd& A;   // face areas
  const VecXd& Fw;  // F(T) per face
  std::vector<int> labels;
  std::vector<Vec3> proxies;

  double error(int f, int k) const { return A[f] * (Vec3(N.row(f)) - proxies[k]).squaredNorm(); }

  int neighbour(int f, int k) const {
    const int e = topo.face_edges(f, k);
    return topo.edge_faces(e, 0) == f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
  }

  // Region growing from the seeds (CSAD04 sec. 3.3) with the thesis's weights.
  void partition(const std::vector<int>& seeds) {
    using Item = std::tuple<double, int, int>;  // priority, face, proxy
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    std::fill(labels.begin(), labels.end(), -1);
    for (size_t k = 0; k < seeds.size(); ++k) labels[seeds[k]] = static_cast<int>(k);
    auto push_neighbours = [&](int f) {
      const int k = labels[f];
      for (int j = 0; j < 3; ++j) {
        const int g = neighbour(f, j);
        if (g < 0 || labels[g] >= 0) continue;
        const double w = 2.0 / (Fw[f] + Fw[g]);
        heap.emplace(w * error(g, k), g, k);
      }
    };
    for (int s : seeds) push_neighbours(s);
    while (!heap.empty()) {
      const auto [e, f, k] = heap.top();
      heap.pop();
      if (labels[f] >= 0) continue;
      labels[f] = k;
      push_neighbours(f);
    }
  }

  // Proxy normals: area-weighted mean normal of each region (the L^{2,1} optimum).
  void fit(int n) {
    std::vector<Vec3> sum(n, Vec3::Zero());
    for (size_t f = 0; f < labels.size(); ++f)
      if (labels[f] >= 0) sum[labels[f]] += A[f] * Vec3(N.row(f));
    proxies.resize(n);
    for (int k = 0; k < n; ++k) {
      const double len = sum[k].norm();
      if (len > 0) proxies[k] = sum[k] / len;  // else keep the previous one
    }
  }
};

}  // namespace

SegmentResult segment(const Mesh& mesh, const SegmentOptions& opt, const ProgressFn& progress_fn) {
  const Topology& topo = mesh.topo;
  const int nf = topo.n_faces;
  if (opt.segments < 1) throw MeshError("segments must be at least 1, got " + std::to_string(opt.segments));
  if (opt.segments > nf)
    throw MeshError("cannot make " + std::to_string(opt.segments) + " segments from " + std::to_string(nf) + " faces");
  if (opt.iterations < 0) throw MeshError("iterations must be non-negative");
  if (opt.face_feature.size() != 0 && opt.face_feature.size() != nf)
    throw MeshError("face_feature has " + std::to_string(opt.face_feature.size()) + " values for " +
                    std::to_string(nf) + " faces");
  if (opt.face_feature.size() && !(opt.face_feature.array() > 0).all())
    throw MeshError("face_feature values must be positive");
  Progress progress(progress_fn);
  progress(0.0);

  const MatX3d N = face_normals(mesh.V, mesh.F);
  const VecXd A = face_areas(mesh.V, mesh.F);
  const VecXd Fw = opt.face_feature.size() ? opt.face_feature : VecXd::Ones(nf);
  Vsa vsa{topo, N, A, Fw, std::vector<int>(nf, -1), {}};

  // One seed per connected component of the face graph, so that every face is reached.
  std::vector<int> seeds;
  {
    std::vector<int> comp(nf, -1), stack;
    for (int f = 0; f < nf; ++f) {
      if (comp[f] >= 0) continue;
      seeds.push_back(f);
      comp[f] = f;
      stack.push_back(f);
      while (!stack.empty()) {
        const int g = stack.back();
        stack.pop_back();
        for (int j = 0; j < 3; ++j) {
          const int h = vsa.neighbour(g, j);
          if (h >= 0 && comp[h] < 0) comp[h] = f, stack.push_back(h);
        }
      }
    }
  }
  vsa.proxies.clear();
  for (int s : seeds) vsa.proxies.push_back(N.row(s).transpose());
  vsa.partition(seeds);
  vsa.fit(static_cast<int>(seeds.size()));
  const int target = std::max(opt.segments, static_cast<int>(seeds.size()));

  // Seeds for the remaining segments, one at a time (CSAD04 sec. 3.5): the worst face of the region
  // with the largest distortion, followed by a few Lloyd steps.
  auto lloyd_step = [&](std::vector<int>& sd) {
    const int n = static_cast<int>(sd.size());
    vsa.fit(n);
    // New seed of each region: its face closest to the proxy.
    std::vector<double> best(n, std::numeric_limits<double>::infinity());
    for (int f = 0; f < nf; ++f) {
      const int k = vsa.labels[f];
      const double e = vsa.error(f, k) / std::max(A[f], 1e-300);
      if (e < best[k]) best[k] = e, sd[k] = f;
    }
    vsa.partition(sd);
  };
  // The face of region k deviating most from its proxy; among (near) ties the one farthest from
  // the region's seed, so that symmetric regions (two sides of a cube) get split.
  auto worst_face = [&](int k, int seed) {
    double top = -1.0;
    for (int f = 0; f < nf; ++f)
      if (vsa.labels[f] == k && f != seed) top = std::max(top, vsa.error(f, k) / std::max(A[f], 1e-300));
    const Vec3 c0 = (mesh.V.row(mesh.F(seed, 0)) + mesh.V.row(mesh.F(seed, 1)) + mesh.V.row(mesh.F(seed, 2))) / 3.0;
    int best = -1;
    double best_d = -1.0;
    for (int f = 0; f < nf; ++f) {
      if (vsa.labels[f] != k || f == seed) continue;
      if (vsa.error(f, k) / std::max(A[f], 1e-300) < top * (1 - 1e-6) - 1e-15) continue;
      const Vec3 c = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
      const double d = (Vec3(c.transpose()) - Vec3(c0.transpose())).squaredNorm();
      if (d > best_d) best_d = d, best = f;
    }
    return best;
  };
  const int total_steps = (target - static_cast<int>(seeds.size())) + opt.iterations;
  int steps_done = 0;
  while (static_cast<int>(seeds.size()) < target) {
    const int n = static_cast<int>(seeds.size());
    std::vector<double> region_err(n, 0.0);
    for (int f = 0; f < nf; ++f) region_err[vsa.labels[f]] += vsa.error(f, vsa.labels[f]);
    const int worst = static_cast<int>(std::max_element(region_err.begin(), region_err.end()) - region_err.begin());
    const int far = worst_face(worst, seeds[worst]);
    if (far < 0) break;  // cannot happen while segments <= faces
    seeds.push_back(far);
    vsa.proxies.push_back(N.row(far).transpose());
    vsa.partition(seeds);
    for (int it = 0; it < 2; ++it) lloyd_step(seeds);
    progress(double(++steps_done) / std::max(1, total_steps));
  }
  const int n = static_cast<int>(seeds.size());
  SegmentResult r;
  std::vector<int> prev;
  for (int it = 0; it < opt.iterations; ++it) {
    prev = vsa.labels;
    lloyd_step(seeds);
    ++r.iterations;
    progress(double(++steps_done) / std::max(1, total_steps));
    if (prev == vsa.labels) break;
  }
  // Region teleportation (CSAD04 sec. 3.5): merge the adjacent pair that costs least and reseed
  // in the worst region, kept only when the total distortion drops. With A the area and S the
  // area-weighted normal sum of a region, its L^{2,1} error is 2 (A - |S|).
  auto total_error = [&] {
    double e = 0;
    for (int f = 0; f < nf; ++f) e += vsa.error(f, vsa.labels[f]);
    return e;
  };
  vsa.fit(n);
  double best_err = total_error();
  for (int attempt = 0; attempt < n && n > 1; ++attempt) {
    std::vector<double> area(n, 0.0), err(n, 0.0);
    std::vector<Vec3> sum(n, Vec3::Zero());
    for (int f = 0; f < nf; ++f) {
      const int k = vsa.labels[f];
      area[k] += A[f], sum[k] += A[f] * Vec3(N.row(f));
    }
    for (int k = 0; k < n; ++k) err[k] = 2 * (area[k] - sum[k].norm());
    double merge_cost = std::numeric_limits<double>::infinity();
    int mi = -1, mj = -1;
    for (int e = 0; e < topo.n_edges(); ++e) {
      const int f = topo.edge_faces(e, 0), g = topo.edge_faces(e, 1);
      if (f < 0 || g < 0) continue;
      const int a = vsa.labels[f], b = vsa.labels[g];
      if (a == b) continue;
      const double c = 2 * (area[a] + area[b] - (sum[a] + sum[b]).norm()) - err[a] - err[b];
      if (c < merge_cost) merge_cost = c, mi = std::min(a, b), mj = std::max(a, b);
    }
    const int worst = static_cast<int>(std::max_element(err.begin(), err.end()) - err.begin());
    if (mi < 0 || worst == mi || worst == mj || !(merge_cost < 0.5 * err[worst])) break;
    const std::vector<int> saved_labels = vsa.labels, saved_seeds = seeds;
    const std::vector<Vec3> saved_proxies = vsa.proxies;
    // Region mj goes to mi; its seed moves to the worst face of the worst region.
    const int far = worst_face(worst, seeds[worst]);
    if (far < 0) break;
    seeds[mj] = far;
    vsa.proxies[mj] = N.row(far).transpose();
    vsa.partition(seeds);
    for (int it = 0; it < opt.iterations; ++it) {
      prev = vsa.labels;
      lloyd_step(seeds);
      if (prev == vsa.labels) break;
    }
    vsa.fit(n);
    const double e = total_error();
    if (e < best_err - 1e-12 * (1 + best_err)) {
      best_err = e;
    } else {
      vsa.labels = saved_labels, seeds = saved_seeds, vsa.proxies = saved_proxies;
      break;
    }
  }
  r.labels = std::move(vsa.labels);
  r.n_segments = n;
  r.proxy_normals.resize(n, 3);
  for (int k = 0; k < n; ++k) r.proxy_normals.row(k) = vsa.proxies[k].transpose();
  for (int f = 0; f < nf; ++f) r.error += A[f] * (Vec3(N.row(f)) - vsa.proxies[r.labels[f]]).squaredNorm();
  progress(1.0);
  return r;
}

}  // namespace dgmesh
