// Self-intersecting triangle pairs of a triangle mesh (issue 33: the count the skeletal
// deformation's joint quality is measured by, and the fold detector of its untangling step), through
// a bounding-volume hierarchy over the faces that skips what cannot cross itself by the normal-cone
// test (Volino and Magnenat-Thalmann 1994): an edge-connected patch whose face normals all lie within
// less than 90 degrees of one axis, and whose boundary, projected onto the plane across that axis,
// does not cross itself, is a height field over that plane, so none of its faces crosses another;
// the same for the union of two edge-adjacent patches. Where a test cannot vouch (a boundary that
// touches itself, degenerate faces, an edge of more than two faces) the faces are searched.
#pragma once
#include <array>
#include <utility>
#include <vector>

#include "dgmesh/types.h"

namespace dgmesh {

// Pairs (i, j), i < j, of faces of (V, F) sharing no vertex where an edge of one crosses the other's
// interior (strict orientation tests: touching or coplanar pairs do not count), sorted. `faces`
// (optional): only pairs of these faces are tested. Faces with an index out of range are rejected
// by the caller (not checked here); degenerate (zero-area) faces cross nothing.
std::vector<std::pair<int, int>> self_intersecting_pairs(const MatX3d& V, const MatX3i& F,
                                                         const std::vector<int>* faces = nullptr);

// The same pairs restricted to those with at least one face flagged in `touching` (indexed by face,
// F.rows() entries): after moving some vertices, the pairs of the faces around them are the only
// ones that can have changed. Nodes without a flagged face are compared only with flagged ones.
std::vector<std::pair<int, int>> self_intersecting_pairs_touching(const MatX3d& V, const MatX3i& F,
                                                                  const std::vector<int>* faces,
                                                                  const std::vector<char>& touching);

// The hierarchy itself, for one mesh over many poses (the skeletal untangling searches every pose and
// every iteration of it): built once, at rest positions (median splits of the face centroids into
// compact patches of up to 16 faces), and refitted to each query's positions (boxes and normal cones,
// linear in the faces). Searching positions far from those it was built at stays exact, only slower.
class SelfIntersectionTree {
 public:
  SelfIntersectionTree() = default;
  // The faces of F (all, or `faces`), split at the rest positions V.
  SelfIntersectionTree(const MatX3d& V, const MatX3i& F, const std::vector<int>* faces = nullptr);

  // The pairs among the tree's faces at positions V (V.rows() as at construction), as
  // self_intersecting_pairs: i < j, sorted.
  std::vector<std::pair<int, int>> pairs(const MatX3d& V) const;
  // Those of them with a face flagged in `touching` (F.rows() entries), as
  // self_intersecting_pairs_touching.
  std::vector<std::pair<int, int>> pairs_touching(const MatX3d& V, const std::vector<char>& touching) const;

  const std::vector<int>& faces() const { return faces_; }
  bool empty() const { return faces_.empty(); }

 private:
  struct Node {
    int begin, end;  // the faces order_[begin, end)
    int left = -1, right = -1;
    bool connected = false;          // its faces are edge-connected
    int rim_begin = 0, rim_end = 0;  // rim_[rim_begin, rim_end): its slots with an edge leaving it
  };
  std::vector<std::pair<int, int>> search(const MatX3d& V, const std::vector<char>* touching) const;
  bool adjacent(const Node& a, const Node& b) const;
  // Whether the boundary of the faces of a (and b), projected along `axis`, crosses or touches itself.
  bool contour_crosses(const MatX3d& V, const Vec3& axis, const Node& a, const Node* b) const;
  MatX3i F_;
  std::vector<int> faces_, order_;          // the tree's faces; their order in the nodes
  std::vector<std::array<int, 3>> across_;  // per slot and corner c, the slot across edge (c, c + 1) (-1: none)
  std::vector<Node> nodes_;                 // preorder: children after their parent
  std::vector<int> rim_;
};

}  // namespace dgmesh
