// Tangential smoothing of the remesher's output; see remesh_smoothing.h.
#include "dgmesh/remesh_smoothing.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "dgmesh/parallel.h"
#include "dgmesh/remesh_flips.h"

namespace dgmesh::detail {

namespace {

// The smoothing's angle goal: no move may create a 3D angle below it, and stars still holding one
// get a pattern search; on sharp features the goal is kSmoothSharpMinAngle (see bench/notes/remesh.md).
constexpr double kSmoothMinAngle = 35 * kPi / 180;
constexpr double kSmoothSharpMinAngle = 33 * kPi / 180;  // the goal at vertices on sharp features
constexpr int kRepairRounds = 3;  // smoothing rounds after the closing pass, over stars below that goal
// Interior vertices of valence 3 or 4 whose star holds an angle under 20 degrees are removed.
const double kLowValenceCos = std::cos(20 * kPi / 180);
constexpr double kSmoothFeatureCos = 0.7;  // ~45 degrees between a triangle and its star's normal
constexpr int kMaxStar = 64;               // stars with more triangles are not smoothed

}  // namespace

bool locate_in_map(const MatX2d& U, const MatX3i& F, const Topology& topo, const Vec2& p, int f, Sample& out) {
  for (int step = 0; step < 256; ++step) {
    const Vec2 a = uv_row(U, F(f, 0)), b = uv_row(U, F(f, 1)), c = uv_row(U, F(f, 2));
    const double det = cross2(b - a, c - a);
    if (det == 0) return false;
    const double w0 = cross2(b - p, c - p) / det, w1 = cross2(c - p, a - p) / det;
    const double ww[3] = {w0, w1, 1 - w0 - w1};
    int kmin = 0;
    for (int k = 1; k < 3; ++k)
      if (ww[k] < ww[kmin]) kmin = k;
    if (ww[kmin] >= -1e-12) {
      out = Sample{f, std::max(0.0, ww[0]), std::max(0.0, ww[1]), std::max(0.0, ww[2])};
      const double sum = out.w0 + out.w1 + out.w2;
      out.w0 /= sum, out.w1 /= sum, out.w2 /= sum;
      return true;
    }
    const int e = topo.face_edges(f, (kmin + 1) % 3);  // the edge opposite corner kmin
    const int g = topo.edge_faces(e, 0) == f ? topo.edge_faces(e, 1) : topo.edge_faces(e, 0);
    if (g < 0) return false;
    f = g;
  }
  return false;
}

void vertex_triangles(const MatX3i& T, int nv, std::vector<int>& off, std::vector<int>& ring) {
  off.assign(nv + 1, 0);
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 3; ++k) ++off[T(t, k) + 1];
  for (int v = 0; v < nv; ++v) off[v + 1] += off[v];
  ring.resize(off[nv]);
  std::vector<int> fill(off.begin(), off.end() - 1);
  for (int t = 0; t < T.rows(); ++t)
    for (int k = 0; k < 3; ++k) ring[fill[T(t, k)]++] = t;
}

int remove_low_valence(MatX3i& T, MatX3d& X, MatX2d& P, std::vector<Sample>& S, VecXd& rho_out, int nb,
                       double orient_sign, double max_cos) {
  const int nv = int(X.rows()), nt = int(T.rows());
  std::vector<int> off, ring;
  vertex_triangles(T, nv, off, ring);
  auto tri_cos = [&](int a, int b, int c) { return min_angle_cos(row3(X, a), row3(X, b), row3(X, c)); };
  auto orient = [&](int a, int b, int c) {
    return orient_sign * cross2(uv_row(P, b) - uv_row(P, a), uv_row(P, c) - uv_row(P, a));
  };
  std::vector<char> touched(nv, 0), dead_t(nt, 0), dead_v(nv, 0);
  int removed = 0;
  for (int i = nb; i < nv; ++i) {
    const int deg = off[i + 1] - off[i];
    if ((deg != 3 && deg != 4) || touched[i]) continue;
    // The link, in order: triangle (i, a, b) gives the link edge a -> b.
    int nxt[2][4], m = 0;  // pairs (a, b)
    double before = -1;
    bool ok = true;
    for (int q = off[i]; q < off[i + 1]; ++q) {
      const int t = ring[q];
      int k = 0;
      while (T(t, k) != i) ++k;
      nxt[0][m] = T(t, (k + 1) % 3);
      nxt[1][m] = T(t, (k + 2) % 3);
      ++m;
      before = std::max(before, tri_cos(T(t, 0), T(t, 1), T(t, 2)));
      for (int j = 0; j < 3; ++j) ok = ok && !touched[T(t, j)];
    }
    if (!ok || before <= max_cos) continue;
    int cyc[4];
    cyc[0] = nxt[0][0];
    for (int s = 1; s < deg && ok; ++s) {
      int found = -1;
      for (int e = 0; e < deg; ++e)
        if (nxt[0][e] == cyc[s - 1]) found = nxt[1][e];
      ok = found >= 0;
      if (ok) cyc[s] = found;
    }
    if (!ok) continue;
    // Replacement triangles.
    int nt_new = 0, tri[2][3];
    double after = 2;
    if (deg == 3) {
      tri[0][0] = cyc[0], tri[0][1] = cyc[1], tri[0][2] = cyc[2];
      nt_new = 1;
      if (!(orient(cyc[0], cyc[1], cyc[2]) > 1e-14)) continue;
      after = tri_cos(cyc[0], cyc[1], cyc[2]);
    } else {
      double best = 2;
      for (int d = 0; d < 2; ++d) {  // diagonal cyc[d] - cyc[d + 2]
        const int a = cyc[d], b = cyc[d + 1], c = cyc[(d + 2) % 4], e = cyc[(d + 3) % 4];
        if (!(orient(a, b, c) > 1e-14) || !(orient(a, c, e) > 1e-14)) continue;
        const double w = std::max(tri_cos(a, b, c), tri_cos(a, c, e));
        if (w < best) {
          best = w;
          tri[0][0] = a, tri[0][1] = b, tri[0][2] = c;
          tri[1][0] = a, tri[1][1] = c, tri[1][2] = e;
        }
      }
      if (best > 1) continue;
      nt_new = 2;
      after = best;
      // The diagonal must not already be an edge (a valence-3 neighbour would make a duplicate face).
      const int a = tri[0][0], c = tri[0][2];
      for (int q = off[a]; q < off[a + 1] && ok; ++q)
        for (int j = 0; j < 3; ++j) ok = ok && !(T(ring[q], j) == c && !dead_t[ring[q]]);
      if (!ok) continue;
    }
    if (!(after < before)) continue;
    int w = 0;
    for (int q = off[i]; q < off[i + 1]; ++q) {
      const int t = ring[q];
      if (w < nt_new) {
        T.row(t) << tri[w][0], tri[w][1], tri[w][2];
        ++w;
      } else {
        dead_t[t] = 1;
      }
    }
    dead_v[i] = 1;
    touched[i] = 1;
    for (int s = 0; s < deg; ++s) touched[cyc[s]] = 1;
    ++removed;
  }
  if (removed == 0) return 0;
  std::vector<int> id(nv, -1);
  int n = 0;
  for (int v = 0; v < nv; ++v)
    if (!dead_v[v]) {
      id[v] = n;
      if (n != v) {
        X.row(n) = X.row(v);
        P.row(n) = P.row(v);
        S[n] = S[v];
        rho_out[n] = rho_out[v];
      }
      ++n;
    }
  X.conservativeResize(n, 3);
  P.conservativeResize(n, 2);
  S.resize(n);
  rho_out.conservativeResize(n);
  int m = 0;
  for (int t = 0; t < nt; ++t)
    if (!dead_t[t]) {
      for (int k = 0; k < 3; ++k) T(m, k) = id[T(t, k)];
      ++m;
    }
  T.conservativeResize(m, 3);
  return removed;
}

int smooth_in_map(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Ut, const VecXd& rho,
                  const std::vector<int>& ring_off, const std::vector<int>& ring, const std::vector<int>& groups,
                  const std::vector<int>& group_off, double orient_sign, const MatX3i& T, MatX3d& X, MatX2d& P,
                  std::vector<Sample>& S, VecXd& rho_out) {
  int moves = 0;
  // Cosine of the smallest 3D angle of the triangles around vertex i with i placed at xi (the
  // smallest angle of a triangle is opposite its shortest edge; law of cosines).
  auto star_max_cos = [&](int i, const Vec3& xi) {
    double m = -1;
    for (int q = ring_off[i]; q < ring_off[i + 1]; ++q) {
      const int t = ring[q];
      Vec3 p[3];
      for (int k = 0; k < 3; ++k) p[k] = T(t, k) == i ? xi : row3(X, T(t, k));
      m = std::max(m, min_angle_cos(p[0], p[1], p[2]));
    }
    return m;
  };
  const double cos_min = std::cos(kSmoothMinAngle), cos_sharp = std::cos(kSmoothSharpMinAngle);
  const int ngroups = int(group_off.size()) - 1;
  for (int c = 0; c < ngroups; ++c) {
    const int g0 = group_off[c], g1 = group_off[c + 1];
    const bool par = c + 1 < ngroups && g1 - g0 > kParallelMin / 4;  // heavy items: ~1 us each
#pragma omp parallel for schedule(static) reduction(+ : moves) if (par)
    for (int gi = g0; gi < g1; ++gi) {
      const int i = groups[gi];
      const int deg = ring_off[i + 1] - ring_off[i];
      if (deg == 0 || deg > kMaxStar) continue;
      Vec3 c = Vec3::Zero(), nsum = Vec3::Zero();
      double wsum = 0, len2 = 0;
      Vec3 nt[kMaxStar];
      for (int q = ring_off[i], m = 0; q < ring_off[i + 1]; ++q, ++m) {
        const int t = ring[q];
        const Vec3 a = row3(X, T(t, 0)), b = row3(X, T(t, 1)), d = row3(X, T(t, 2));
        nt[m] = (b - a).cross(d - a);
        nsum += nt[m];
        const double w = 0.5 * nt[m].norm() * (rho_out[T(t, 0)] + rho_out[T(t, 1)] + rho_out[T(t, 2)]);
        // Optimal Delaunay triangulation step (Chen & Xu 2004; Alliez et al. 2005, "Variational
        // tetrahedral meshing"): the weighted mean of the triangles' circumcentres, not centroids;
        // it equalizes shapes as well as sizes.
        const Vec3 ab = b - a, ad = d - a, n = nt[m];
        const double n2 = n.squaredNorm();
        const Vec3 cc = n2 > 0 ? Vec3(a + (ab.squaredNorm() * ad.cross(n) + ad.squaredNorm() * n.cross(ab)) / (2 * n2))
                               : Vec3((a + b + d) / 3.0);
        c += w * cc;
        wsum += w;
        len2 += (b - a).squaredNorm() + (d - b).squaredNorm() + (a - d).squaredNorm();
      }
      if (!(wsum > 0)) continue;
      const Vec3 disp = c / wsum - row3(X, i);
      const double before = star_max_cos(i, row3(X, i));
      // Converged here: a move below 2% of the mean edge length does not change the angles much.
      if (before <= cos_min && disp.squaredNorm() < 4e-4 * len2 / (3 * deg)) continue;
      // A vertex on a sharp feature (an incident triangle's normal more than ~45 degrees from the
      // star's mean normal) only moves to lift a bad angle: sliding it would cut the feature.
      bool sharp = false;
      {
        const Vec3 nm = nsum.normalized();
        for (int m = 0; !sharp && m < deg; ++m) {
          const double l = nt[m].norm();
          sharp = l > 0 && nt[m].dot(nm) < kSmoothFeatureCos * l;
        }
      }
      // On a feature the goal is lower (kSmoothSharpMinAngle): lifting angles there moves the feature.
      const double goal = sharp ? cos_sharp : cos_min;
      if (sharp && before <= goal) continue;
      const Sample& s0 = S[i];
      const int f = s0.face;
      // Jacobian of the input face's affine map from Ut to 3D: J = [x1-x0, x2-x0] [u1-u0, u2-u0]^-1.
      const Vec2 u0 = uv_row(Ut, F(f, 0)), e1 = uv_row(Ut, F(f, 1)) - u0, e2 = uv_row(Ut, F(f, 2)) - u0;
      const Vec3 x0 = row3(V, F(f, 0)), g1 = row3(V, F(f, 1)) - x0, g2 = row3(V, F(f, 2)) - x0;
      const double det = cross2(e1, e2);
      if (det == 0) continue;
      Eigen::Matrix2d Minv;
      Minv << e2.y(), -e2.x(), -e1.y(), e1.x();
      Minv /= det;
      Eigen::Matrix<double, 3, 2> G;
      G.col(0) = g1;
      G.col(1) = g2;
      const Eigen::Matrix<double, 3, 2> J = G * Minv;
      const Eigen::Matrix2d JtJ = J.transpose() * J;
      const double jd = JtJ.determinant();
      if (!(jd > 1e-300)) continue;
      Vec2 du = JtJ.inverse() * (J.transpose() * disp);
      if (!du.allFinite()) continue;
      const Vec2 ui = uv_row(P, i);
      // Moves i to `un` in the map if that keeps the star embedded and passes `accept(after)` on the
      // star's new largest angle cosine; the star's current one is `cur`.
      double cur = before;
      auto try_move = [&](const Vec2& un, auto accept) {
        for (int q = ring_off[i]; q < ring_off[i + 1]; ++q) {
          const int t = ring[q];
          Vec2 p[3];
          for (int k = 0; k < 3; ++k) p[k] = T(t, k) == i ? un : uv_row(P, T(t, k));
          if (!(orient_sign * cross2(p[1] - p[0], p[2] - p[0]) > 1e-14)) return false;
        }
        Sample sn;
        if (!locate_in_map(Ut, F, topo, un, S[i].face, sn)) return false;
        const Vec3 xn =
            sn.w0 * row3(V, F(sn.face, 0)) + sn.w1 * row3(V, F(sn.face, 1)) + sn.w2 * row3(V, F(sn.face, 2));
        const double after = star_max_cos(i, xn);  // cosines: larger is a smaller angle
        if (!accept(after)) return false;
        S[i] = sn;
        P.row(i) = un.transpose();
        X.row(i) = xn.transpose();
        rho_out[i] = sn.w0 * rho[F(sn.face, 0)] + sn.w1 * rho[F(sn.face, 1)] + sn.w2 * rho[F(sn.face, 2)];
        cur = after;
        return true;
      };
      // "Smart" smoothing (Freitag 1997): no move may push the star's smallest 3D angle down below
      // kSmoothMinAngle, so smoothing never creates the bad triangles it is meant to remove.
      auto smart = [&](double after) { return !(after > before && after > cos_min) && !(sharp && !(after < before)); };
      bool moved = false;
      for (int attempt = 0; attempt < 4 && !moved; ++attempt, du *= 0.5) moved = try_move(ui + du, smart);
      if (moved) ++moves;
      if (cur <= goal) continue;
      // A star still holding an angle below kSmoothMinAngle: a pattern search in the map (8
      // directions, halving steps from a quarter of the star's mean edge) for the position with the
      // largest smallest angle; the centroid is not where the worst angle is best.
      double h = 0;
      for (int q = ring_off[i]; q < ring_off[i + 1]; ++q)
        for (int k = 0; k < 3; ++k) h += (uv_row(P, T(ring[q], k)) - uv_row(P, i)).norm();
      h *= 0.25 / (2 * deg);
      for (int level = 0; level < 4; ++level, h *= 0.5) {
        bool better = true;
        for (int walk = 0; better && cur > goal && walk < 8; ++walk) {
          better = false;
          const Vec2 uc = uv_row(P, i);
          for (int dir = 0; dir < 8 && !better; ++dir) {
            const double a = dir * kPi / 4;
            better =
                try_move(uc + h * Vec2(std::cos(a), std::sin(a)), [&](double after) { return after < cur - 1e-9; });
          }
          if (better) ++moves;
        }
      }
    }
  }  // colours
  return moves;
}

void smooth_remeshed(const MatX3d& V, const MatX3i& F, const Topology& topo, const MatX2d& Ut, const VecXd& rho,
                     const RemeshOptions& o, int nb, double orient_sign, std::vector<Sample>& S, RemeshResult& res) {
  int nout = int(res.V.rows());
  VecXd rho_out = VecXd::Ones(nout);
  if (o.adaptivity > 0)
    for (int i = 0; i < nout; ++i) {
      const Sample& q = S[i];
      if (q.face >= 0) rho_out[i] = q.w0 * rho[F(q.face, 0)] + q.w1 * rho[F(q.face, 1)] + q.w2 * rho[F(q.face, 2)];
    }
  std::vector<int> ring_off(nout + 1), ring, colour(nout), groups, group_off;
  // A closing smoothing pass after the last sweep's flips and removals: they change stars after
  // those were smoothed, and an unfolding flip may leave a sliver nothing repairs (three_peaks,
  // targets 3800-6200: down to 4.4 degrees, at 3D folds across creases of the coarse input);
  // smoothing moves keep every angle above min(35 degrees, its value before).
  // An angle still below the sharp-feature goal after the closing pass: up to kRepairRounds rounds
  // of flips, removals and smoothing of only those triangles' vertices and their neighbours, as more
  // sweeps would do at the cost of the few stars concerned. Where the triangulation map is strongly
  // compressed its embedding refuses most of a sweep's moves: lion-head, single (U0) at 3000-6000:
  // worst angle 29.1-31.4 -> 33.0-33.1; three_peaks, double at 4000 / 5000: 25.6 / 28.0 -> 30.2 / 31.5.
  const double cos_sharp_goal = std::cos(kSmoothSharpMinAngle);
  // Marks the vertices of such triangles and their neighbours (the neighbours' moves free the
  // space that lifts the angle); false when there is none.
  // `worst`: the cosine of the mesh's smallest angle.
  auto bad_vertices = [&](std::vector<char>& mark, double& worst) {
    mark.assign(nout, 0);
    bool any = false;
    worst = -1;
    for (int t = 0; t < res.F.rows(); ++t) {
      const double c = min_angle_cos(row3(res.V, res.F(t, 0)), row3(res.V, res.F(t, 1)), row3(res.V, res.F(t, 2)));
      worst = std::max(worst, c);
      if (c > cos_sharp_goal) {
        for (int k = 0; k < 3; ++k) mark[res.F(t, k)] = 1;
        any = true;
      }
    }
    if (!any) return false;
    std::vector<char> seed = mark;
    for (int t = 0; t < res.F.rows(); ++t)
      if (seed[res.F(t, 0)] || seed[res.F(t, 1)] || seed[res.F(t, 2)])
        for (int k = 0; k < 3; ++k) mark[res.F(t, k)] = 1;
    return true;
  };
  std::vector<char> active;
  double worst = 1, worst_prev = 1;
  for (int it = 0;; ++it) {
    vertex_triangles(res.F, nout, ring_off, ring);  // rebuilt after flips and removals
    const bool repair = it > o.smooth_iterations;
    if (repair && !bad_vertices(active, worst)) {
      if (o.flip_3d) res.n_flips += delaunay_flips_3d(res.V, res.uv, res.F, orient_sign, true);
      break;
    }
    // Greedy colouring of the interior vertices (neighbours = vertices of the star's triangles);
    // colour 64 collects the few the 64 colours cannot place (processed serially).
    constexpr int kColours = 64;
    std::fill(colour.begin(), colour.end(), -1);
    std::vector<int> count(kColours + 2, 0);
    for (int i = nb; i < nout; ++i) {
      if (repair && !active[i]) continue;
      uint64_t used = 0;
      for (int q = ring_off[i]; q < ring_off[i + 1]; ++q)
        for (int k = 0; k < 3; ++k) {
          const int cj = colour[res.F(ring[q], k)];
          if (cj >= 0 && cj < kColours) used |= uint64_t(1) << cj;
        }
      int c = 0;
      while (c < kColours && (used >> c & 1)) ++c;
      colour[i] = c;
      ++count[c + 1];
    }
    int ncol = 0;
    for (int c = 0; c <= kColours; ++c)
      if (count[c + 1] > 0) ncol = c + 1;
    group_off.assign(ncol + 1, 0);
    for (int c = 0; c < ncol; ++c) group_off[c + 1] = group_off[c] + count[c + 1];
    if (ncol > 0 && ncol <= kColours) group_off.push_back(group_off.back());  // empty serial group
    groups.assign(group_off.back(), 0);
    {
      std::vector<int> fill(group_off.begin(), group_off.end() - 1);
      for (int i = nb; i < nout; ++i)
        if (colour[i] >= 0) groups[fill[colour[i]]++] = i;
    }
    res.smooth_moves += smooth_in_map(V, F, topo, Ut, rho, ring_off, ring, groups, group_off, orient_sign, res.F, res.V,
                                      res.uv, S, rho_out);
    // After the closing pass (it == smooth_iterations, on the final connectivity) and each repair
    // round: done unless an angle is still below the sharp-feature goal, or when the last round
    // did not lift the worst angle (at 100K vertices on lion-head the same few stars stayed stuck
    // through every round).
    bool more = false;
    if (it >= o.smooth_iterations) {
      more = it < o.smooth_iterations + kRepairRounds && bad_vertices(active, worst) &&
             (it == o.smooth_iterations || worst < worst_prev - 1e-9);
      worst_prev = worst;
    }
    if (it >= o.smooth_iterations && !more) {
      // The last pass moved vertices, so a flat pair may have stopped being Delaunay: flip those
      // where that lowers no angle (a planar disk's output is Delaunay).
      if (o.flip_3d) res.n_flips += delaunay_flips_3d(res.V, res.uv, res.F, orient_sign, true);
      break;
    }
    if (o.flip_3d) res.n_flips += delaunay_flips_3d(res.V, res.uv, res.F, orient_sign);
    {
      const int rem = remove_low_valence(res.F, res.V, res.uv, S, rho_out, nb, orient_sign, kLowValenceCos);
      res.n_removed += rem;
      if (rem > 0) {
        nout = int(res.V.rows());
        colour.resize(nout);
        if (o.flip_3d) res.n_flips += delaunay_flips_3d(res.V, res.uv, res.F, orient_sign);
      }
    }
  }
}

}  // namespace dgmesh::detail
