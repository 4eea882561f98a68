// The compiled module dgmesh._native. Python-facing names, defaults and documentation live in the
// package (addon/dgmesh/*.py); this module stays thin.
#include "common.h"
#include "dgmesh/errors.h"

PYBIND11_MODULE(_native, m) {
  namespace pb = pybind11;
  m.doc() = "dgmesh native core";
  // Base first: pybind11 tries translators newest first, so subclasses registered later win.
  static pb::exception<dgmesh::Error> error(m, "Error", PyExc_RuntimeError);
  static pb::exception<dgmesh::MeshError> mesh_error(m, "MeshError", PyExc_ValueError);
  static pb::exception<dgmesh::IoError> io_error(m, "MeshIOError", mesh_error.ptr());
  static pb::exception<dgmesh::SolverError> solver_error(m, "SolverError", error.ptr());
  static pb::exception<dgmesh::CancelledError> cancelled(m, "Cancelled", error.ptr());
  pb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const dgmesh::CancelledError& e) {
      cancelled(e.what());
    } catch (const dgmesh::SolverError& e) {
      solver_error(e.what());
    } catch (const dgmesh::IoError& e) {
      io_error(e.what());
    } catch (const dgmesh::MeshError& e) {
      mesh_error(e.what());
    } catch (const dgmesh::Error& e) {
      error(e.what());
    }
  });
  dgmesh::py::bind_core(m);
  dgmesh::py::bind_crest(m);
  dgmesh::py::bind_fair(m);
  dgmesh::py::bind_unwrap(m);
  dgmesh::py::bind_denoise(m);
  dgmesh::py::bind_skeletal(m);
  dgmesh::py::bind_multires(m);
  dgmesh::py::bind_remesh(m);
}
