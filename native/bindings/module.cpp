// The compiled module dgmesh._native. Python-facing names, defaults and documentation live in the
// package (addon/dgmesh/*.py); this module stays thin.
#include "common.h"
#include "dgmesh/errors.h"

PYBIND11_MODULE(_native, m) {
  namespace pb = pybind11;
  m.doc() = "dgmesh native core";
  // Base first: pybind11 tries translators newest first, so subclasses registered later win.
  // register_exception keeps each Python type for the process's life (pybind11 2.12+ never
  // destroys it, so nothing is released after the interpreter is gone).
  auto& error = pb::register_exception<dgmesh::Error>(m, "Error", PyExc_RuntimeError);
  // MeshError is an Error and a ValueError (bases given as a tuple, as PyErr_NewException takes).
  const pb::tuple mesh_bases = pb::make_tuple(error, pb::handle(PyExc_ValueError));
  auto& mesh_error = pb::register_exception<dgmesh::MeshError>(m, "MeshError", mesh_bases);
  pb::register_exception<dgmesh::IoError>(m, "MeshIOError", mesh_error.ptr());
  pb::register_exception<dgmesh::SolverError>(m, "SolverError", error.ptr());
  pb::register_exception<dgmesh::CancelledError>(m, "Cancelled", error.ptr());
  dgmesh::py::bind_core(m);
  dgmesh::py::bind_crest(m);
  dgmesh::py::bind_fair(m);
  dgmesh::py::bind_unwrap(m);
  dgmesh::py::bind_denoise(m);
  dgmesh::py::bind_skeletal(m);
  dgmesh::py::bind_multires(m);
  dgmesh::py::bind_remesh(m);
}
