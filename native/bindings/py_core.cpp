#include "common.h"
#include "dgmesh/geometry.h"
#include "dgmesh/io.h"
#include "dgmesh/parallel.h"
#include "dgmesh/shapes.h"
#include "dgmesh/subdivision.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

void bind_core(pb::module_& m) {
  m.def("set_num_threads", &set_num_threads, pb::arg("n"));
  m.def("num_threads", &num_threads);

  m.def(
      "validate",
      [](InV V, InF F, unsigned checks) {
        NativeScope nogil;
        validate(V, F, checks);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("checks") = static_cast<unsigned>(kSurface));
  m.attr("CHECK_SURFACE") = static_cast<unsigned>(kSurface);
  m.attr("CHECK_NO_LOOSE_VERTICES") = static_cast<unsigned>(kNoLooseVertices);

  Struct<Curvature>(m, "Curvature", "Result of curvature(): discrete curvatures per vertex (thesis 3.1)")
      .result("mean", &Curvature::mean, "(n,) mean curvature H (1/r on a sphere with outward normals)")
      .result("gaussian", &Curvature::gaussian, "(n,) Gaussian curvature K by angle deficit (1/r^2 on a sphere)")
      .result("normals", &Curvature::normals, "(n, 3) unit vertex normals (Max weights)")
      .result("area", &Curvature::area, "(n,) mixed Voronoi area")
      .result("laplace", &Curvature::laplace, "(n, 3) Laplace-Beltrami of the position (-2 H N)");
  m.def(
      "curvature",
      [](InV Vin, InF Fin) {
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        return curvature(mesh.V, mesh.F, mesh.topo);
      },
      pb::arg("V"), pb::arg("F"));

  Struct<Topology>(m, "Topology", "Result of topology(): edges, boundary loops and components of a valid mesh")
      .result("n_vertices", &Topology::n_vertices, "vertices")
      .result("n_faces", &Topology::n_faces, "faces")
      .result("edges", &Topology::edges, "(E, 2) unique undirected edges, v0 < v1")
      .result("face_edges", &Topology::face_edges, "(m, 3) edge from F[f, k] to F[f, (k + 1) % 3]")
      .result("edge_faces", &Topology::edge_faces, "(E, 2) the faces of each edge; -1 on the boundary")
      .result("boundary_loops", &Topology::boundary_loops, "vertex cycles (lists), oriented as the faces")
      .result("component", &Topology::component, "(n,) connected component of each vertex")
      .result("n_components", &Topology::n_components, "connected components (loose vertices count)");
  m.def(
      "topology",
      [](InV Vin, InF Fin) {
        NativeScope nogil;
        return validate(Vin, Fin, kSurface);
      },
      pb::arg("V"), pb::arg("F"));

  m.def(
      "read_mesh",
      [](const std::string& path) {
        MeshData md;
        {
          NativeScope nogil;
          md = read_mesh(path);
        }
        return pb::make_tuple(std::move(md.V), std::move(md.F), std::move(md.N));
      },
      pb::arg("path"));
  m.def(
      "write_mesh",
      [](const std::string& path, InV V, InF F, std::optional<MatX3d> N) {
        NativeScope nogil;
        write_mesh(path, V, F, N ? &*N : nullptr);
      },
      pb::arg("path"), pb::arg("V"), pb::arg("F"), pb::arg("N") = pb::none());

  // Surfaces with known answers.
  auto tuple = [](TriMesh t) { return pb::make_tuple(std::move(t.V), std::move(t.F)); };
  m.def(
      "icosphere", [tuple](int level, double r) { return tuple(icosphere(level, r)); }, pb::arg("level"),
      pb::arg("radius") = 1.0);
  m.def(
      "torus", [tuple](double R, double r, int nu, int nv) { return tuple(torus(R, r, nu, nv)); }, pb::arg("R"),
      pb::arg("r"), pb::arg("nu"), pb::arg("nv"));
  m.def(
      "grid", [tuple](int nx, int ny) { return tuple(grid(nx, ny)); }, pb::arg("nx"), pb::arg("ny"));
  m.def(
      "subdivide_linear", [tuple](InV V, InF F) { return tuple(subdivide_linear(V, F)); }, pb::arg("V"), pb::arg("F"));
  m.def(
      "loop_subdivide",
      [tuple](InV V, InF F, int levels) {
        TriMesh t;
        {
          NativeScope nogil;
          t = loop_subdivide(V, F, levels);
        }
        return tuple(std::move(t));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("levels"));
}

}  // namespace dgmesh::py
