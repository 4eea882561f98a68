#include "dgmesh/subdivision.h"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <memory>
#include <string>
#include <vector>

#include "dgmesh/errors.h"
#include "dgmesh/validate.h"

namespace dgmesh {

namespace {
namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

// The vertex type OpenSubdiv's PrimvarRefiner interpolates.
struct Point {
  double p[3];
  void Clear() { p[0] = p[1] = p[2] = 0; }
  void AddWithWeight(const Point& s, float w) {
    p[0] += w * s.p[0];
    p[1] += w * s.p[1];
    p[2] += w * s.p[2];
  }
};
}  // namespace

TriMesh loop_subdivide(const MatX3d& V, const MatX3i& F, int levels) {
  // OpenSubdiv keeps a refinement level in 4 bits: 16 levels would silently wrap to 0.
  if (levels < 0 || levels > 15)
    throw MeshError("loop_subdivide: levels must be in 0..15, got " + std::to_string(levels));
  validate(V, F, kSurface);
  if (levels == 0) return {V, F};

  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  std::vector<int> counts(m, 3);
  Far::TopologyDescriptor desc;
  desc.numVertices = n;
  desc.numFaces = m;
  desc.numVertsPerFace = counts.data();
  desc.vertIndicesPerFace = F.data();  // row-major (m, 3): exactly OpenSubdiv's face-vertex list

  Sdc::Options options;
  options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
  std::unique_ptr<Far::TopologyRefiner> refiner(Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Create(
      desc, Far::TopologyRefinerFactory<Far::TopologyDescriptor>::Options(Sdc::SCHEME_LOOP, options)));
  if (!refiner) throw MeshError("OpenSubdiv could not build the Loop topology of this mesh");
  refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));

  // Interpolate level by level into one buffer holding every level's vertices.
  std::vector<Point> buf(refiner->GetNumVerticesTotal());
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) buf[i].p[d] = V(i, d);
  Far::PrimvarRefiner primvar(*refiner);
  Point* src = buf.data();
  for (int level = 1; level <= levels; ++level) {
    Point* dst = src + refiner->GetLevel(level - 1).GetNumVertices();
    primvar.Interpolate(level, src, dst);
    src = dst;
  }

  const Far::TopologyLevel& last = refiner->GetLevel(levels);
  TriMesh out;
  out.V.resize(last.GetNumVertices(), 3);
  for (int i = 0; i < last.GetNumVertices(); ++i)
    for (int d = 0; d < 3; ++d) out.V(i, d) = src[i].p[d];
  out.F.resize(last.GetNumFaces(), 3);
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    const Far::ConstIndexArray fv = last.GetFaceVertices(f);
    out.F.row(f) << fv[0], fv[1], fv[2];
  }
  return out;
}

}  // namespace dgmesh
