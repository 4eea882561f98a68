// Denoising (thesis ch. 2): thin wrappers; defaults and documentation live in addon/dgmesh/denoise.py.
#include "common.h"
#include "dgmesh/denoise.h"
#include "dgmesh/errors.h"

namespace dgmesh::py {

namespace {

DenoiseOptions make_options(const std::string& method, double eta1, double eta2, double eta3, int iterations,
                            const pb::object& mask, bool reestimate_normals, int max_patch, int max_window) {
  DenoiseOptions o;
  if (method == "similarity") o.method = DenoiseMethod::Similarity;
  else if (method == "bilateral") o.method = DenoiseMethod::Bilateral;
  else throw MeshError("unknown method '" + method + "' (use 'similarity' or 'bilateral')");
  o.eta1 = eta1;
  o.eta2 = eta2;
  o.eta3 = eta3;
  o.iterations = iterations;
  o.reestimate_normals = reestimate_normals;
  o.max_patch = max_patch;
  o.max_window = max_window;
  if (!mask.is_none()) {
    auto a = pb::array_t<uint8_t, pb::array::c_style | pb::array::forcecast>::ensure(mask);
    if (!a || a.ndim() != 1) throw MeshError("mask must be a one-dimensional array of booleans");
    o.movable.assign(a.data(), a.data() + a.size());
  }
  return o;
}

pb::dict to_dict(DenoiseResult&& r) {
  pb::dict d;
  d["vertices"] = std::move(r.vertices);
  d["residual"] = std::move(r.residual);
  d["residual_entropy"] = r.residual_entropy;
  d["edge_length"] = r.edge_length;
  d["iterations"] = r.iterations;
  d["rbf_fallbacks"] = r.rbf_fallbacks;
  d["welded"] = r.welded;
  return d;
}

}  // namespace

void bind_denoise(pb::module_& m) {
  m.def(
      "denoise_mesh",
      [](InV V, InF F, const std::string& method, double eta1, double eta2, double eta3, int iterations,
         const pb::object& mask, const pb::object& progress, int max_patch, int max_window) {
        DenoiseOptions o = make_options(method, eta1, eta2, eta3, iterations, mask, true, max_patch, max_window);
        const ProgressFn cb = progress_from(progress);
        DenoiseResult r;
        {
          NativeScope nogil;
          r = denoise(V, F, o, cb);
        }
        return to_dict(std::move(r));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("method"), pb::arg("eta1"), pb::arg("eta2"), pb::arg("eta3"),
      pb::arg("iterations"), pb::arg("mask") = pb::none(), pb::arg("progress") = pb::none(),
      pb::arg("max_patch") = 0, pb::arg("max_window") = 0);

  m.def(
      "denoise_points",
      [](InV V, InV N, const std::string& method, double eta1, double eta2, double eta3, int iterations,
         const pb::object& mask, const pb::object& progress, bool reestimate_normals, int max_patch, int max_window) {
        DenoiseOptions o =
            make_options(method, eta1, eta2, eta3, iterations, mask, reestimate_normals, max_patch, max_window);
        const ProgressFn cb = progress_from(progress);
        DenoiseResult r;
        {
          NativeScope nogil;
          r = denoise_points(V, N, o, cb);
        }
        return to_dict(std::move(r));
      },
      pb::arg("V"), pb::arg("N"), pb::arg("method"), pb::arg("eta1"), pb::arg("eta2"), pb::arg("eta3"),
      pb::arg("iterations"), pb::arg("mask") = pb::none(), pb::arg("progress") = pb::none(),
      pb::arg("reestimate_normals") = true, pb::arg("max_patch") = 0, pb::arg("max_window") = 0);

  const auto similarity_options = [](double eta1, double eta3, bool shape_only) {
    SimilarityOptions o;
    o.eta1 = eta1;
    o.eta3 = eta3;
    o.shape_only = shape_only;
    return o;
  };
  m.def(
      "similarity_mesh",
      [similarity_options](InV V, InF F, int vertex, double eta1, double eta3, bool shape_only,
                           const pb::object& progress) {
        const SimilarityOptions o = similarity_options(eta1, eta3, shape_only);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return similarity(V, F, vertex, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("vertex"), pb::arg("eta1"), pb::arg("eta3"),
      pb::arg("shape_only"), pb::arg("progress") = pb::none());

  m.def(
      "similarity_points",
      [similarity_options](InV V, InV N, int vertex, double eta1, double eta3, bool shape_only,
                           const pb::object& progress) {
        const SimilarityOptions o = similarity_options(eta1, eta3, shape_only);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return similarity_points(V, N, vertex, o, cb);
      },
      pb::arg("V"), pb::arg("N"), pb::arg("vertex"), pb::arg("eta1"), pb::arg("eta3"),
      pb::arg("shape_only"), pb::arg("progress") = pb::none());

  m.def(
      "residual_entropy", [](const VecXd& r) { return residual_entropy(r); }, pb::arg("residual"));
}

}  // namespace dgmesh::py
