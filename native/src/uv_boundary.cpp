// Boundaries of a UV chart; see uv_boundary.h.
#include "dgmesh/uv_boundary.h"

#include <algorithm>
#include <limits>

#include "dgmesh/detail/timer.h"
#include "dgmesh/sparse_solver.h"

namespace dgmesh::detail {

std::vector<double> arc_length(const MatX3d& V, const std::vector<int>& loop) {
  const size_t nb = loop.size();
  std::vector<double> t(nb + 1, 0.0);
  for (size_t k = 0; k < nb; ++k) t[k + 1] = t[k] + (V.row(loop[(k + 1) % nb]) - V.row(loop[k])).norm();
  const double total = t[nb] > 0 ? t[nb] : 1.0;
  for (double& x : t) x /= total;
  return t;  // t[nb] == 1
}

void place_circle(const std::vector<int>& loop, const std::vector<double>& t, MatX2d& U) {
  for (size_t k = 0; k < loop.size(); ++k) {
    const double a = 2 * kPi * t[k];
    U.row(loop[k]) << 0.5 + 0.5 * std::cos(a), 0.5 + 0.5 * std::sin(a);
  }
}

bool square_corners(const std::vector<int>& loop, const std::vector<double>& t,
                    const std::vector<std::pair<int, int>>& chords, int (&c)[4]) {
  const int nb = static_cast<int>(loop.size());
  if (nb < 4) return false;
  auto nearest = [&](double x) {
    x -= std::floor(x);
    const int hi = static_cast<int>(std::lower_bound(t.begin(), t.begin() + nb + 1, x) - t.begin());
    const int lo = std::max(hi - 1, 0);
    const int k = (hi <= nb && std::abs(t[hi] - x) < std::abs(x - t[lo])) ? hi : lo;
    return k % nb;
  };
  for (int r = 0; r < nb; ++r) {
    int d[5];
    d[0] = 0;
    bool ok = true;
    for (int s = 1; s < 4 && ok; ++s) {
      d[s] = (nearest(t[r] + 0.25 * s) - r + nb) % nb;
      ok = d[s] > d[s - 1];
    }
    if (!ok) continue;
    d[4] = nb;
    auto sides = [&](int o) {  // bit mask of the closed sides holding loop offset o
      unsigned m = 0;
      for (int s = 0; s < 4; ++s)
        if (d[s] <= o && o <= d[s + 1]) m |= 1u << s;
      if (o == 0) m |= 1u << 3;
      return m;
    };
    for (const auto& ch : chords) {
      if (sides((ch.first - r + nb) % nb) & sides((ch.second - r + nb) % nb)) {
        ok = false;
        break;
      }
    }
    if (!ok) continue;
    for (int s = 0; s < 4; ++s) c[s] = (r + d[s]) % nb;
    return true;
  }
  return false;
}

void place_square(const std::vector<int>& loop, const std::vector<double>& t, const int (&c)[4], MatX2d& U) {
  const int nb = static_cast<int>(loop.size());
  const Vec2 P[5] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}};
  for (int s = 0; s < 4; ++s) {
    const int a = c[s], b = c[(s + 1) % 4];
    const int n = (b - a + nb) % nb;
    auto tt = [&](int k) {  // arc length from the loop start, unwrapped past a
      const int idx = (a + k) % nb;
      return t[idx] + (idx < a ? 1.0 : 0.0);
    };
    const double ta = tt(0), len = tt(n) + ((a + n) % nb == a ? 1.0 : 0.0) - ta;
    for (int k = 0; k < n; ++k) {
      const double f = len > 0 ? (tt(k) - ta) / len : double(k) / n;
      U.row(loop[(a + k) % nb]) = P[s] + f * (P[s + 1] - P[s]);
    }
  }
}

MatX2d lscm(const MatX3d& V, const MatX3i& F, const Topology& topo, int pin0, int pin1) {
  const int n = static_cast<int>(V.rows());
  const int m = static_cast<int>(F.rows());
  // Unknowns: u and v of every vertex but the pins, interleaved (each vertex's 2x2 block together:
  // on lion-head the LDL^T factorisation takes half the time of u-block-then-v-block); the pins'
  // values move to the right-hand side.
  std::vector<int> idx(2 * n, -1);
  int nf = 0;
  for (int v = 0; v < n; ++v) {
    if (v != pin0 && v != pin1) idx[v] = nf++, idx[v + n] = nf++;
  }
  Eigen::VectorXd xp = Eigen::VectorXd::Zero(2 * n);
  xp[pin1] = 1;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nf);
  // One pass straight into the reduced system's lower triangle (SimplicialLDLT reads only that).
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(m) * 12 + topo.n_vertices * 4);
  auto add = [&](int r, int c, double x) {
    const int ir = idx[r], ic = idx[c];
    if (ir < 0) return;
    if (ic < 0) {
      rhs[ir] -= x * xp[c];
    } else if (ic <= ir) {
      trip.emplace_back(ir, ic, x);
    }
  };
  // E_D(u) + E_D(v) with the cotangent Dirichlet energy E_D(u) = 1/4 sum_edges (cot a + cot b) (u_i - u_j)^2.
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = F(f, (k + 1) % 3), j = F(f, (k + 2) % 3);
      const Vec3 ab = V.row(i) - V.row(F(f, k)), ac = V.row(j) - V.row(F(f, k));
      const double w = 0.5 * ab.dot(ac) / std::max(ab.cross(ac).norm(), 1e-300);  // cot / 2
      for (int o = 0; o <= n; o += n) {
        add(i + o, i + o, w), add(j + o, j + o, w);
        add(i + o, j + o, -w), add(j + o, i + o, -w);
      }
    }
  // -A(u,v) = -1/2 sum over boundary half-edges a->b of (u_a v_b - u_b v_a), as 1/2 x^T M x.
  for (int e = 0; e < topo.n_edges(); ++e) {
    if (topo.edge_faces(e, 1) >= 0) continue;
    const int f = topo.edge_faces(e, 0);
    int a = -1, b = -1;
    for (int k = 0; k < 3; ++k) {
      if (topo.face_edges(f, k) == e) a = F(f, k), b = F(f, (k + 1) % 3);
    }
    add(a, b + n, -0.5), add(b + n, a, -0.5);
    add(b, a + n, 0.5), add(a + n, b, 0.5);
  }
  SpMat Qf(nf, nf);
  Qf.setFromTriplets(trip.begin(), trip.end());
  profile_mark("lscm_build");
  SparseSolver solver;
  solver.factor(Qf, SparseSolver::Kind::Cholesky);
  profile_mark("lscm_factor");
  const Eigen::VectorXd x = solver.solve(rhs);
  MatX2d U(n, 2);
  for (int v = 0; v < n; ++v) {
    U(v, 0) = idx[v] >= 0 ? x[idx[v]] : xp[v];
    U(v, 1) = idx[v + n] >= 0 ? x[idx[v + n]] : xp[v + n];
  }
  return U;
}

void fit_unit_box(MatX2d& U, const std::vector<int>& rows) {
  Vec2 lo(kInf, kInf), hi(-kInf, -kInf);
  for (int v : rows) lo = lo.cwiseMin(U.row(v).transpose()), hi = hi.cwiseMax(U.row(v).transpose());
  const double s = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  const Vec2 off = 0.5 * (Vec2(1, 1) - (hi - lo) / s);
  for (int v : rows) U.row(v) = ((U.row(v).transpose() - lo) / s + off).transpose();
}

int reflex_count(const MatX2d& U, const std::vector<int>& loop) {
  const int nb = static_cast<int>(loop.size());
  int reflex = 0;
  for (int k = 0; k < nb; ++k) {
    const Vec2 a = U.row(loop[(k + nb - 1) % nb]), b = U.row(loop[k]), c = U.row(loop[(k + 1) % nb]);
    const Vec2 e0 = b - a, e1 = c - b;
    if (cross2(e0, e1) < -1e-12 * e0.norm() * e1.norm()) ++reflex;
  }
  return reflex;
}

std::pair<int, int> diameter_pair(const MatX3d& V, const std::vector<int>& loop) {
  auto less = [&](int a, int b) {
    for (int c = 0; c < 3; ++c)
      if (V(a, c) != V(b, c)) return V(a, c) < V(b, c);
    return false;
  };
  auto farthest = [&](int from) {
    int best = loop[0];
    double bd = -1;
    for (int v : loop) {
      const double d = (V.row(v) - V.row(from)).squaredNorm();
      if (d > bd || (d == bd && less(v, best))) bd = d, best = v;
    }
    return best;
  };
  const int start = *std::min_element(loop.begin(), loop.end(), less);
  const int p0 = farthest(start);
  return {p0, farthest(p0)};
}

}  // namespace dgmesh::detail
