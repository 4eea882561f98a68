// Displaced-subdivision multiresolution layer (thesis 6.4): MultiresOptions, MultiresTimings and the
// Multires class of dgmesh/multires.h; addon/dgmesh/multires.py wraps the class for Python.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/multires.h"

namespace dgmesh::py {

namespace {

pb::tuple sparse_rows(const SpMatR& W) {
  const auto nnz = W.nonZeros();
  pb::array_t<int> indptr(W.rows() + 1), indices(nnz);
  pb::array_t<double> data(nnz);
  std::copy(W.outerIndexPtr(), W.outerIndexPtr() + W.rows() + 1, indptr.mutable_data());
  std::copy(W.innerIndexPtr(), W.innerIndexPtr() + nnz, indices.mutable_data());
  std::copy(W.valuePtr(), W.valuePtr() + nnz, data.mutable_data());
  return pb::make_tuple(data, indices, indptr, pb::make_tuple(W.rows(), W.cols()));
}

}  // namespace

void bind_multires(pb::module_& m) {
  using MatX2dR = MatX2d;
  Struct<MultiresOptions>(m, "MultiresOptions", "Options of Multires.build()")
      .field("control_faces", &MultiresOptions::control_faces, "target face count of the decimated control mesh")
      .field("level", &MultiresOptions::level,
             "1..5: adaptive isolation level of the limit patches and density of the closest-point seeds")
      .field("min_quality", &MultiresOptions::min_quality, "decimation sliver guard, triangle quality in [0, 1)")
      .field("fit_iterations", &MultiresOptions::fit_iterations,
             "least-squares fits of the control vertices, each followed by a re-bind; 0 = plain decimation")
      .field("fit_regularization", &MultiresOptions::fit_regularization,
             "Tikhonov weight of the fit towards the decimated positions (relative)")
      .field("projection_iterations", &MultiresOptions::projection_iterations,
             "Gauss-Newton steps of the closest-point projection");

  Struct<MultiresTimings>(m, "MultiresTimings", "Seconds spent in each stage of Multires.build()")
      .result("decimate", &MultiresTimings::decimate, "quadric decimation to the control mesh")
      .result("surface", &MultiresTimings::surface, "limit surface (OpenSubdiv patch table)")
      .result("bind", &MultiresTimings::bind, "closest-point binding of the dense vertices")
      .result("fit", &MultiresTimings::fit, "least-squares fits and re-binds")
      .result("stencils", &MultiresTimings::stencils, "precomputed reconstruction stencils");

  pb::class_<Multires>(m, "Multires")
      .def_static(
          "build",
          [](InV V, InF F, const MultiresOptions& o, const pb::object& progress) {
            const ProgressFn cb = progress_from(progress);
            NativeScope nogil;
            return Multires::build(V, F, o, cb);
          },
          pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none())
      .def_static(
          "bind",
          [](InV control_V, InF control_F, InV V, int level, int projection_iterations, const pb::object& progress) {
            const ProgressFn cb = progress_from(progress);
            NativeScope nogil;
            return Multires::bind(control_V, control_F, V, level, cb, projection_iterations);
          },
          pb::arg("control_V"), pb::arg("control_F"), pb::arg("V"), pb::arg("level"), pb::arg("projection_iterations"),
          pb::arg("progress") = pb::none())
      .def_static(
          "from_arrays",
          [](InV control_V, InF control_F, int level, const VecXi& face, const MatX2dR& st, InV disp) {
            MultiresData d;
            d.control_V = control_V;
            d.control_F = control_F;
            d.level = level;
            d.face = face;
            d.st = st;
            d.disp = disp;
            NativeScope nogil;
            return Multires::from_data(d);
          },
          pb::arg("control_V"), pb::arg("control_F"), pb::arg("level"), pb::arg("face"), pb::arg("st"), pb::arg("disp"))
      .def_property_readonly("n_dense", &Multires::n_dense)
      .def_property_readonly("n_control", &Multires::n_control)
      .def_property_readonly("level", &Multires::level)
      .def_property_readonly("control_vertices", [](const Multires& r) { return MatX3d(r.control_vertices()); })
      .def_property_readonly("control_faces", [](const Multires& r) { return MatX3i(r.control_faces()); })
      .def_property_readonly("base_face", [](const Multires& r) { return VecXi(r.base_face()); })
      .def_property_readonly("base_st", [](const Multires& r) { return MatX2dR(r.base_st()); })
      .def_property_readonly("displacement", [](const Multires& r) { return MatX3d(r.displacement()); })
      .def_property_readonly("n_patch_points", &Multires::n_patch_points)
      .def_property_readonly("memory_bytes", &Multires::memory_bytes)
      .def_property_readonly("timings", [](const Multires& r) { return r.timings(); })
      .def(
          "reconstruct",
          [](const Multires& r, InV X, const pb::object& out) -> pb::object {
            if (out.is_none()) {
              MatX3d res(r.n_dense(), 3);
              {
                NativeScope nogil;
                r.reconstruct(X, Eigen::Ref<MatX3d>(res));
              }
              return pb::cast(std::move(res));
            }
            // A caller-owned C-contiguous (n, 3) float64 or float32 array, written in place.
            if (pb::isinstance<pb::array>(out) && out.cast<pb::array>().dtype().is(pb::dtype::of<float>())) {
              auto ref = out.cast<Eigen::Ref<MatX3f>>();
              NativeScope nogil;
              r.reconstruct(X, ref);
            } else {
              auto ref = out.cast<Eigen::Ref<MatX3d>>();
              NativeScope nogil;
              r.reconstruct(X, ref);
            }
            return out;
          },
          pb::arg("control_V"), pb::arg("out") = pb::none())
      .def(
          "limit_points",
          [](const Multires& r, const MatX3d& X) {
            MatX3d P, N;
            {
              NativeScope nogil;
              r.limit_points(X, P, &N);
            }
            return pb::make_tuple(std::move(P), std::move(N));
          },
          pb::arg("control_V"))
      .def(
          "evaluate",
          [](const Multires& r, const MatX3d& X, const VecXi& face, const MatX2dR& st) {
            MatX3d P, Ds, Dt;
            {
              NativeScope nogil;
              r.evaluate(X, face, st, P, &Ds, &Dt);
            }
            return pb::make_tuple(std::move(P), std::move(Ds), std::move(Dt));
          },
          pb::arg("control_V"), pb::arg("face"), pb::arg("st"))
      .def("limit_matrix", [](const Multires& r) {
        SpMatR W;
        {
          NativeScope nogil;
          W = r.limit_matrix();
        }
        return sparse_rows(W);
      });
}

}  // namespace dgmesh::py
