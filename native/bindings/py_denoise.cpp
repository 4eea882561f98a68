// Denoising (thesis ch. 2): the options, results and functions of dgmesh/denoise.h as they are.
#include "common.h"
#include "dgmesh/denoise.h"
#include "dgmesh/errors.h"
#include "dgmesh/noise_estimate.h"

namespace dgmesh::py {

namespace {

// The mask is input data, not an option: a one-dimensional array of 0/1 flags or None.
DenoiseOptions with_mask(DenoiseOptions o, const pb::object& mask) {
  if (!mask.is_none()) {
    auto a = pb::array_t<uint8_t, pb::array::c_style | pb::array::forcecast>::ensure(mask);
    if (!a || a.ndim() != 1) throw MeshError("mask must be a one-dimensional array of booleans");
    o.movable.assign(a.data(), a.data() + a.size());
  }
  return o;
}

}  // namespace

void bind_denoise(pb::module_& m) {
  Struct<NoiseOptions>(m, "NoiseOptions", "Options of estimate_noise()")
      .field("neighbours", &NoiseOptions::neighbours,
             "points of each local cubic fit, the centre included (19 = a regular mesh's 2-ring); 12..64")
      .field("weld_tolerance", &NoiseOptions::weld_tolerance,
             "points closer than this (relative to the bounding-box diagonal) count once")
      .field("measure_detail", &NoiseOptions::measure_detail,
             "also run the wide fits that measure detail (a second, larger pass); false leaves detail 0");

  Struct<NoiseEstimate>(m, "NoiseEstimate", "Result of estimate_noise()")
      .result("sigma", &NoiseEstimate::sigma, "noise deviation in units of the mean edge length")
      .result("sigma_abs", &NoiseEstimate::sigma_abs, "noise deviation in model units")
      .result("edge_length", &NoiseEstimate::edge_length, "mean edge length (clouds: mean spacing to 6 nearest)")
      .result("curvature", &NoiseEstimate::curvature,
              "median of edge length times the largest absolute principal curvature of the local fits")
      .result("outliers", &NoiseEstimate::outliers,
              "fraction of points whose standardised residual exceeds 3 sigma (features, spikes)")
      .result("detail", &NoiseEstimate::detail,
              "sqrt(max(0, sigma of fits of wide_neighbours points^2 - sigma^2)), edge lengths: shape detail at the "
              "sampling scale")
      .result("samples", &NoiseEstimate::samples, "points that gave a residual");

  pb::enum_<DenoiseMethod>(m, "DenoiseMethod", "Denoising filter")
      .value("similarity", DenoiseMethod::Similarity, "non-local means with RBF patches (thesis eq. 2.3-2.9)")
      .value("bilateral", DenoiseMethod::Bilateral, "bilateral mesh denoising (Fleishman et al. 2003)");

  Struct<DenoiseOptions>(m, "DenoiseOptions", "Options of denoise(); sigma_i = eta_i * average edge length")
      .field("method", &DenoiseOptions::method, "the filter")
      .field("automatic", &DenoiseOptions::automatic,
             "estimate the noise and take eta1, iterations and quadratic_fit from auto_options()")
      .field("eta1", &DenoiseOptions::eta1, "similarity: kernel deviation (2.7); bilateral: height Gaussian")
      .field("eta2", &DenoiseOptions::eta2, "2*sigma2 = radius of the averaging domain (2.4)")
      .field("eta3", &DenoiseOptions::eta3, "similarity: 2*sigma3 = patch radius (2.8); bilateral: spatial Gaussian")
      .field("iterations", &DenoiseOptions::iterations, "filter passes")
      .field("quadratic_fit", &DenoiseOptions::quadratic_fit,
             "similarity: fit a weighted quadratic to the heights instead of averaging them (no shrinkage)")
      .field("smoothing_steps", &DenoiseOptions::smoothing_steps,
             "meshes: Taubin lambda|mu smoothing steps before the filter (0: none, the thesis setting)")
      .field("reestimate_normals", &DenoiseOptions::reestimate_normals,
             "point clouds: re-estimate normals by PCA after the first iteration")
      .field("weld_tolerance", &DenoiseOptions::weld_tolerance,
             "vertices closer than this (relative to the bounding-box diagonal) are welded")
      .field("max_patch", &DenoiseOptions::max_patch, "cap on RBF patch / compared points (0 = automatic)")
      .field("max_window", &DenoiseOptions::max_window, "cap on averaging-domain points (0 = automatic)");
  m.def("denoise_defaults", &denoise_defaults, pb::arg("method"),
        "The defaults of a method: the thesis's suggested setting (similarity), table 2.1's (bilateral)");

  Struct<DenoiseResult>(m, "DenoiseResult", "Result of denoise()")
      .result("vertices", &DenoiseResult::vertices, "(n, 3) denoised positions")
      .result("residual", &DenoiseResult::residual, "(n,) |x_noisy - x_smoothed| per vertex")
      .result("residual_entropy", &DenoiseResult::residual_entropy,
              "entropy in bits of the residual's distribution (see residual_entropy)")
      .result("edge_length", &DenoiseResult::edge_length, "average edge length e of the last iteration")
      .result("iterations", &DenoiseResult::iterations, "iterations run")
      .result("rbf_fallbacks", &DenoiseResult::rbf_fallbacks, "RBF patches solved by the plane fallback")
      .result("welded", &DenoiseResult::welded, "vertices merged into a coincident one for the computation")
      .result("noise", &DenoiseResult::noise, "automatic mode: the noise estimate of the input (zeros otherwise)")
      .result("options", &DenoiseResult::options, "the options the filter ran with (automatic: after auto_options)");
  m.def("auto_options", &auto_options, pb::arg("noise"), pb::arg("base"),
        "The automatic rule: eta1, iterations and quadratic_fit from a noise estimate, the rest from base");
  m.def("auto_smoothing_steps", &auto_smoothing_steps, pb::arg("noise"),
        "The automatic Taubin step count of a noise estimate");
  m.def("shows_features", &shows_features, pb::arg("noise"),
        "The automatic choice's feature test on the estimate of the filtered mesh");

  m.def(
      "denoise_mesh",
      [](InV V, InF F, const DenoiseOptions& opt, const pb::object& mask, const pb::object& progress) {
        const DenoiseOptions o = with_mask(opt, mask);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return denoise(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("mask") = pb::none(), pb::arg("progress") = pb::none());

  m.def(
      "denoise_points",
      [](InV V, InV N, const DenoiseOptions& opt, const pb::object& mask, const pb::object& progress) {
        const DenoiseOptions o = with_mask(opt, mask);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return denoise_points(V, N, o, cb);
      },
      pb::arg("V"), pb::arg("N"), pb::arg("options"), pb::arg("mask") = pb::none(), pb::arg("progress") = pb::none());

  Struct<SimilarityOptions>(m, "SimilarityOptions", "Options of similarity()")
      .field("eta1", &SimilarityOptions::eta1, "deviation of the similarity kernel (2.7)")
      .field("eta3", &SimilarityOptions::eta3, "2*sigma3 = radius of the compared patches (2.8, 2.9)")
      .field("shape_only", &SimilarityOptions::shape_only,
             "true: compare shapes in each vertex's own frame (fig. 2.1c); false: the filter's weights")
      .field("max_patch", &SimilarityOptions::max_patch, "as DenoiseOptions.max_patch");

  m.def(
      "similarity_mesh",
      [](InV V, InF F, int vertex, const SimilarityOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return similarity(V, F, vertex, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("vertex"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "similarity_points",
      [](InV V, InV N, int vertex, const SimilarityOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return similarity_points(V, N, vertex, o, cb);
      },
      pb::arg("V"), pb::arg("N"), pb::arg("vertex"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "estimate_noise_mesh",
      [](InV V, InF F, const NoiseOptions& opt, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return estimate_noise(V, F, opt, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "estimate_noise_points",
      [](InV V, const NoiseOptions& opt, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return estimate_noise_points(V, opt, cb);
      },
      pb::arg("V"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "residual_entropy", [](const VecXd& r) { return residual_entropy(r); }, pb::arg("residual"));
}

}  // namespace dgmesh::py
