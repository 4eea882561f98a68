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

  m.def(
      "curvature",
      [](InV Vin, InF Fin) {
        Curvature c;
        {
          NativeScope nogil;
          const Mesh mesh = make_mesh(Vin, Fin, kSurface);
          c = curvature(mesh.V, mesh.F, mesh.topo);
        }
        pb::dict d;
        d["mean"] = std::move(c.mean);
        d["gaussian"] = std::move(c.gaussian);
        d["normals"] = std::move(c.normals);
        d["area"] = std::move(c.area);
        return d;
      },
      pb::arg("V"), pb::arg("F"));

  m.def(
      "topology",
      [](InV Vin, InF Fin) {
        Topology t;
        {
          NativeScope nogil;
          t = validate(Vin, Fin, kSurface);
        }
        pb::dict d;
        d["edges"] = std::move(t.edges);
        d["edge_faces"] = std::move(t.edge_faces);
        d["boundary_loops"] = t.boundary_loops;
        d["component"] = pb::array_t<int>(t.component.size(), t.component.data());
        d["n_components"] = t.n_components;
        return d;
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
  m.def("icosphere", [tuple](int level, double r) { return tuple(icosphere(level, r)); }, pb::arg("level"),
        pb::arg("radius") = 1.0);
  m.def("torus", [tuple](double R, double r, int nu, int nv) { return tuple(torus(R, r, nu, nv)); }, pb::arg("R"),
        pb::arg("r"), pb::arg("nu"), pb::arg("nv"));
  m.def("grid", [tuple](int nx, int ny) { return tuple(grid(nx, ny)); }, pb::arg("nx"), pb::arg("ny"));
  m.def("subdivide_linear", [tuple](InV V, InF F) { return tuple(subdivide_linear(V, F)); }, pb::arg("V"),
        pb::arg("F"));
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
