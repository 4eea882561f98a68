// Fold guard (fold_guard.h): a displacement that folds a flat grid over itself gets its turned faces
// smoothed away; one that turns no face leaves the positions exactly as they came.
#include <gtest/gtest.h>

#include <cmath>

#include "dgmesh/fold_guard.h"

using namespace dgmesh;

namespace {

struct Grid {
  MatX3d V;
  MatX3i F;
};

// n x n vertices on the unit square (z = 0), two triangles per cell, normals +z.
Grid grid(int n) {
  Grid g;
  g.V.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) g.V.row(i * n + j) << double(j) / (n - 1), double(i) / (n - 1), 0;
  g.F.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      g.F.row(f++) << a, b, d;
      g.F.row(f++) << a, d, c;
    }
  return g;
}

int turned_faces(const MatX3d& X, const MatX3d& ref, const MatX3i& F) {
  int k = 0;
  for (int f = 0; f < F.rows(); ++f) {
    const auto n = [&](const MatX3d& P) {
      const Vec3 a = row3(P, F(f, 0));
      return Vec3((row3(P, F(f, 1)) - a).cross(row3(P, F(f, 2)) - a));
    };
    k += n(X).dot(n(ref)) < 0;
  }
  return k;
}

}  // namespace

TEST(FoldGuard, SmoothsAFoldAwayAndLeavesTheRestAlone) {
  const Grid g = grid(41);
  const FoldGuard guard(g.F, static_cast<int>(g.V.rows()));
  // x -> x - 0.1 tanh((x - 0.5) / 0.02): slope 1 - 5 at x = 0.5, the middle columns fold over.
  MatX3d X = g.V;
  for (int i = 0; i < X.rows(); ++i) X(i, 0) -= 0.1 * std::tanh((g.V(i, 0) - 0.5) / 0.02);
  const MatX3d folded = X;
  ASSERT_GT(turned_faces(folded, g.V, g.F), 20);
  // The work bound stops it early; the default lets it finish.
  FoldGuardOptions o;
  o.iterations = 200, o.max_visits = 500;
  EXPECT_GT(guard.apply(X, g.V, o), 0);
  X = folded;
  o.max_visits = FoldGuardOptions().max_visits;
  EXPECT_EQ(guard.apply(X, g.V, o), 0);
  EXPECT_EQ(turned_faces(X, g.V, g.F), 0);
  // Only a band around the fold moved; the displacement is kept elsewhere.
  double far_moved = 0;
  for (int i = 0; i < X.rows(); ++i)
    if (std::abs(g.V(i, 0) - 0.5) > 0.3) far_moved = std::max(far_moved, (X.row(i) - folded.row(i)).norm());
  EXPECT_EQ(far_moved, 0);
  // A constraint sees every smoothed vertex: here x clamped to at most 0.55, and the vertices left of
  // x = 0.45 refused (they keep their position).
  MatX3d Y = folded;
  guard.apply(Y, g.V, o, nullptr, [&](int i, Vec3& x) {
    x[0] = std::min(x[0], 0.55);
    return g.V(i, 0) >= 0.45;
  });
  int changed = 0;
  for (int i = 0; i < Y.rows(); ++i)
    if (Y.row(i) != folded.row(i)) {
      ++changed;
      EXPECT_LE(Y(i, 0), 0.55);
      EXPECT_GE(g.V(i, 0), 0.45);
    }
  EXPECT_GT(changed, 0);
  // Faces whose reference is not trusted are left alone: none trusted, nothing moves; the left half
  // trusted, only vertices near the left half's turned faces move.
  MatX3d T = folded;
  EXPECT_EQ(guard.apply(T, g.V, o, nullptr, {}, nullptr, [](int) { return false; }), 0);
  EXPECT_EQ(T, folded);
  const auto left = [&](int f) {
    return g.V(g.F(f, 0), 0) < 0.5 && g.V(g.F(f, 1), 0) < 0.5 && g.V(g.F(f, 2), 0) < 0.5;
  };
  guard.apply(T, g.V, o, nullptr, {}, nullptr, left);
  int turned_left = 0, turned_right = 0;
  for (int f = 0; f < g.F.rows(); ++f) {
    const auto n = [&](const MatX3d& P) {
      const Vec3 a = row3(P, g.F(f, 0));
      return Vec3((row3(P, g.F(f, 1)) - a).cross(row3(P, g.F(f, 2)) - a));
    };
    if (n(T).dot(n(g.V)) < 0) (left(f) ? turned_left : turned_right) += 1;
  }
  EXPECT_EQ(turned_left, 0);
  EXPECT_GT(turned_right, 0);
  // Fixed vertices keep their displacement.
  std::vector<char> fixed(g.V.rows(), 1);
  MatX3d Z = folded;
  EXPECT_GT(guard.apply(Z, g.V, o, &fixed), 0);
  EXPECT_EQ(Z, folded);
}

TEST(FoldGuard, ADisplacementThatTurnsNoFaceIsKeptExactly) {
  const Grid g = grid(21);
  const FoldGuard guard(g.F, static_cast<int>(g.V.rows()));
  MatX3d X = g.V;
  for (int i = 0; i < X.rows(); ++i) X.row(i) += Vec3(0.02 * std::sin(7 * g.V(i, 1)), 0, 0.3 * g.V(i, 0)).transpose();
  const MatX3d before = X;
  EXPECT_EQ(guard.apply(X, g.V, {50}), 0);
  EXPECT_EQ(X, before);
  // Off (0 iterations): the turned faces are counted, nothing moves.
  for (int i = 0; i < X.rows(); ++i) X(i, 0) = 1 - X(i, 0);
  const MatX3d mirrored = X;
  EXPECT_EQ(guard.apply(X, g.V, {0}), static_cast<int>(g.F.rows()));
  EXPECT_EQ(X, mirrored);
}
