/// \file
/// Boundaries of a UV chart (thesis 5.2): the convex polygon the outer loop is fixed on for the
/// convex-combination map U0 (Tutte, Floater: no triangle flips), placed by arc length on a circle or
/// a square whose corners avoid degenerate ears, or the natural boundary of the least-squares
/// conformal map; and the sliding of boundary vertices along that curve. Used by unwrap() (unwrap.h);
/// not part of the library's interface.
#pragma once
#include <cmath>
#include <utility>
#include <vector>

#include "dgmesh/detail/math.h"
#include "dgmesh/mesh.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::detail {

/// Normalised cumulative arc length along the closed loop: t[0] = 0, ..., t[nb] = 1.
std::vector<double> arc_length(const MatX3d& V, const std::vector<int>& loop);

/// Places loop vertex k on the circle of radius 1/2 around (1/2, 1/2) at angle 2 pi t[k].
void place_circle(const std::vector<int>& loop, const std::vector<double>& t, MatX2d& U);

/// Square corners: quarter arc-length spacing, rotated until no chord (an edge joining two outer
/// boundary vertices through the interior) has both ends on one closed side. Such a chord cuts off
/// a region that the convex-combination map flattens to zero area (degenerate ears).
bool square_corners(const std::vector<int>& loop, const std::vector<double>& t,
                    const std::vector<std::pair<int, int>>& chords, int (&c)[4]);

/// Places the loop on the unit square with vertex c[s] at corner s ((0,0), (1,0), (1,1), (0,1)),
/// each side by arc length.
void place_square(const std::vector<int>& loop, const std::vector<double>& t, const int (&c)[4], MatX2d& U);

/// Least-squares conformal map with two pinned boundary vertices (LSCM; its free boundary is the
/// natural boundary of Desbrun et al.'s discrete conformal map [DMA02]). The conformal energy is
/// E_D(u) + E_D(v) - A(u, v), with the cotangent Dirichlet energy and the signed area of the image,
/// whose boundary terms come from the boundary edges of the faces.
MatX2d lscm(const MatX3d& V, const MatX3i& F, const Topology& topo, int pin0, int pin1);

/// The closed convex curve the outer loop lies on, parameterised by arc length s in [0, period):
/// a circle, or a polygon (the square's corners, or the free boundary's points). Loop vertex k sits
/// at at(s[k]); anchors (the square's corners) never move.
struct BoundaryCurve {
  bool circle = false;
  std::vector<Vec2> P;    // polygon vertices
  std::vector<double> S;  // cumulative length at P[i], S.back() == period
  double period = 1;
  std::vector<double> s;  // parameter of each loop vertex, increasing from s[0]
  std::vector<int> anchors;

  void set_polygon(std::vector<Vec2> pts) {
    P = std::move(pts);
    S.assign(P.size() + 1, 0.0);
    for (size_t i = 0; i < P.size(); ++i) S[i + 1] = S[i] + (P[(i + 1) % P.size()] - P[i]).norm();
    period = S.back();
  }
  Vec2 at(double x) const {
    x -= period * std::floor(x / period);
    if (circle) {
      const double a = 2 * kPi * x / period;
      return Vec2(0.5 + 0.5 * std::cos(a), 0.5 + 0.5 * std::sin(a));
    }
    const size_t i =
        std::min(static_cast<size_t>(std::upper_bound(S.begin(), S.end(), x) - S.begin()), S.size() - 1) - 1;
    const double len = S[i + 1] - S[i];
    const double f = len > 0 ? (x - S[i]) / len : 0.0;
    return P[i] + f * (P[(i + 1) % P.size()] - P[i]);
  }
  void place(const std::vector<int>& loop, MatX2d& U) const {
    for (size_t k = 0; k < loop.size(); ++k) U.row(loop[k]) = at(s[k]).transpose();
  }
  /// One-dimensional stretch equalization along the curve (the boundary analogue of eq. 5.4): the
  /// UV length of boundary edge k grows by ((sigma_k + sigma_k+1) / 2)^eta, then every run
  /// between two anchors is rescaled to keep its anchors in place.
  void slide(const std::vector<int>& loop, const VecXd& sigma, double eta) {
    const int nb = static_cast<int>(loop.size());
    std::vector<double> su(nb + 1);
    for (int k = 0; k < nb; ++k) su[k] = s[k];
    su[nb] = s[0] + period;
    const int na = static_cast<int>(anchors.size());
    for (int a = 0; a < na; ++a) {
      const int k0 = anchors[a], k1 = a + 1 < na ? anchors[a + 1] : anchors[0] + nb;
      double total_new = 0;
      std::vector<double> d(k1 - k0);
      for (int k = k0; k < k1; ++k) {
        const double sg = 0.5 * (sigma[loop[k % nb]] + sigma[loop[(k + 1) % nb]]);
        d[k - k0] = (su[k + 1] - su[k]) * (eta == 1.0 ? sg : std::pow(sg, eta));
        total_new += d[k - k0];
      }
      if (!(total_new > 0) || !std::isfinite(total_new)) continue;
      const double scale = (su[k1] - su[k0]) / total_new;
      double x = su[k0];
      for (int k = k0 + 1; k < k1; ++k) {
        x += d[k - 1 - k0] * scale;
        s[k % nb] = k >= nb ? x - period : x;
      }
    }
    if (na == 1) {
      // One anchor (circle, free boundary) only fixes the curve's sliding gauge: shift the whole
      // loop so its mean move along the curve is zero instead of pinning the loop's first vertex,
      // which would make the map depend on the vertex order.
      double mean = 0;
      for (int k = 0; k < nb; ++k) mean += s[k] - su[k];
      mean /= nb;
      for (int k = 0; k < nb; ++k) s[k] -= mean;
      while (s[0] < 0)
        for (int k = 0; k < nb; ++k) s[k] += period;
    }
    // Keep s increasing from s[0] (wrap-around runs may have produced values below s[0]).
    for (int k = 1; k < nb; ++k)
      while (s[k] < s[0]) s[k] += period;
  }
};

/// Fits the points of `loop` into [0,1]^2 (uniform scale, centred).
void fit_unit_box(MatX2d& U, const std::vector<int>& rows);

/// Reflex vertices of the closed polygon loop (counter-clockwise).
int reflex_count(const MatX2d& U, const std::vector<int>& loop);

/// A diameter-like pair of loop vertices that does not depend on the vertex numbering: the farthest
/// from the lexicographically smallest position, then the farthest from that (ties likewise).
std::pair<int, int> diameter_pair(const MatX3d& V, const std::vector<int>& loop);

}  // namespace dgmesh::detail
