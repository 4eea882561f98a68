// Low-stretch unwrapping and UV metrics (thesis chapter 5): the options, results and functions of
// dgmesh/unwrap.h as they are.
#include "common.h"
#include "dgmesh/charts.h"
#include "dgmesh/errors.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::py {

namespace {

using InUV = Eigen::Ref<const MatX2d>;

}  // namespace

void bind_unwrap(pb::module_& m) {
  pb::enum_<UvBoundary>(m, "UvBoundary", "Where unwrap() puts the chart's outer boundary")
      .value("square", UvBoundary::Square, "the unit square (the thesis), no triangle with all corners on one side")
      .value("circle", UvBoundary::Circle, "a circle, arc-length spaced")
      .value("free", UvBoundary::Free,
             "the natural boundary of the least-squares conformal map (a circle if it folds the map)");
  pb::enum_<UvWeights>(m, "UvWeights", "Weights of the convex-combination solves (eq. 5.2-5.3)")
      .value("floater", UvWeights::Floater, "Floater's shape-preserving weights (the thesis)")
      .value("mean_value", UvWeights::MeanValue, "mean-value weights")
      .value("cotangent", UvWeights::Cotangent, "harmonic weights; may be negative, so the map may fold")
      .value("uniform", UvWeights::Uniform, "Tutte's barycentric weights")
      .value("auto", UvWeights::Auto,
             "cotangent, and Floater's (mean-value with holes) from the start again where that map folds");
  pb::enum_<UvSolver>(m, "UvSolver", "Linear solver of unwrap()")
      .value("auto", UvSolver::Auto, "UMFPACK up to 1000 unknowns, multigrid above")
      .value("umfpack", UvSolver::Umfpack, "SuiteSparse UMFPACK LU")
      .value("sparselu", UvSolver::SparseLU, "Eigen SparseLU")
      .value("bicgstab", UvSolver::BiCGSTAB, "warm-started BiCGSTAB + ILUT")
      .value("multigrid", UvSolver::Multigrid, "warm-started BiCGSTAB with a smoothed-aggregation multigrid");

  Struct<UnwrapOptions>(m, "UnwrapOptions", "Options of unwrap() (thesis chapter 5)")
      .field("boundary", &UnwrapOptions::boundary, "the outer boundary's polygon")
      .field("weights", &UnwrapOptions::weights, "the weights of U0 and of the steps")
      .field("eta", &UnwrapOptions::eta, "strength of each equalization step, 0 < eta <= 1 (eq. 5.6)")
      .field("iterations", &UnwrapOptions::iterations,
             "-1: Uopt (stop when eq. 5.5 stops decreasing); k >= 0: exactly k steps")
      .field("max_iterations", &UnwrapOptions::max_iterations, "cap on Uopt's steps")
      .field("min_improvement", &UnwrapOptions::min_improvement,
             "Uopt also stops after a step lowering eq. 5.5 by less than this fraction")
      .field("solver", &UnwrapOptions::solver, "the linear solver")
      .field("tolerance", &UnwrapOptions::tolerance, "relative residual of the iterative solve of U0")
      .field("step_tolerance", &UnwrapOptions::step_tolerance,
             "relative residual of the iterative solves of the equalization steps")
      .field("zero_area_eps", &UnwrapOptions::zero_area_eps,
             "a UV triangle has zero area at |A(U)| <= this * sum |A(U)|")
      .field("stretch_cap", &UnwrapOptions::stretch_cap, "triangle stretches above this are clipped in eq. 5.1")
      .field("slide_boundary", &UnwrapOptions::slide_boundary,
             "every step also slides the outer boundary vertices along the polygon (beyond the thesis)")
      .field("stretch_iterations", &UnwrapOptions::stretch_iterations,
             "Newton steps of the final direct minimisation of eq. 5.5 with an injectivity barrier, 0 = off "
             "(beyond the thesis)")
      .field("stretch_tolerance", &UnwrapOptions::stretch_tolerance,
             "the minimisation stops after a step lowering eq. 5.5 by less than this fraction");
  m.def("unwrap_thesis_defaults", &unwrap_thesis_defaults,
        "The thesis's setting: the unit square, Floater's weights, eta 1, the boundary fixed");

  Struct<UvMetrics>(m, "UvMetrics", "Distortion of a parameterization (thesis 5.3)")
      .result("stretch_l2", &UvMetrics::stretch_l2, "eq. 5.5, Sander's normalisation (inf with a zero-area triangle)")
      .result("stretch_linf", &UvMetrics::stretch_linf, "largest singular value over the triangles")
      .result("stretch_l2_finite", &UvMetrics::stretch_l2_finite, "eq. 5.5 over the triangles of non-zero UV area")
      .result("edge", &UvMetrics::edge, "edge-length distortion")
      .result("angle", &UvMetrics::angle, "mean absolute angle error (radians)")
      .result("area", &UvMetrics::area, "area distortion")
      .result("flipped", &UvMetrics::flipped, "UV triangles oriented against the total orientation")
      .result("zero_area", &UvMetrics::zero_area, "UV triangles of zero area");

  Struct<UnwrapStep>(m, "UnwrapStep", "One map of unwrap(): U0 or an equalization step")
      .result("metrics", &UnwrapStep::metrics,
              "U0 and the returned map: all of thesis 5.3; other steps: edge and angle NaN (not computed)")
      .result("seconds", &UnwrapStep::seconds, "wall time of the step (solve and metrics)")
      .result("solver_iterations", &UnwrapStep::solver_iterations,
              "BiCGSTAB iterations (0 for direct solvers; Newton steps for the stretch minimisation)");

  Struct<UnwrapResult>(m, "UnwrapResult", "Result of unwrap()")
      .result("uv", &UnwrapResult::uv, "(n, 2) the returned map, in [0, 1]^2")
      .result("uv_initial", &UnwrapResult::uv_initial, "(n, 2) U0, the start of the equalization")
      .result("steps", &UnwrapResult::steps,
              "steps[h] is U^h (U0 first); for Uopt the last may be the rejected step; the stretch "
              "minimisation's map, when kept, is the last (stretch_step)")
      .result("chosen", &UnwrapResult::chosen, "index into steps of the returned map")
      .result("stretch_step", &UnwrapResult::stretch_step,
              "index into steps of the final stretch minimisation's map (the last); -1: off, not run or not kept")
      .result("boundary_used", &UnwrapResult::boundary_used, "the boundary used (see warnings for fallbacks)")
      .result("boundary_convex", &UnwrapResult::boundary_convex, "the fixed polygon is convex (then no flips)")
      .result("n_holes", &UnwrapResult::n_holes, "inner boundary loops, kept open")
      .result("corners", &UnwrapResult::corners, "vertices at the square's corners (0,0), (1,0), (1,1), (0,1)")
      .result("warnings", &UnwrapResult::warnings, "fallbacks and negative weights, for people")
      .result("solver", &UnwrapResult::solver, "the linear solver used")
      .cls()
      .def_property_readonly(
          "final", [](const UnwrapResult& r) { return r.steps.at(r.chosen).metrics; },
          "metrics of the returned map: steps[chosen].metrics")
      .def_property_readonly(
          "initial", [](const UnwrapResult& r) { return r.steps.at(0).metrics; }, "metrics of U0: steps[0].metrics");

  Struct<UnwrapChartsResult>(m, "UnwrapChartsResult", "Result of unwrap_charts()")
      .result("uv", &UnwrapChartsResult::uv, "(3m, 2) row 3f + k: corner k of triangle f in its chart's map")
      .result("charts", &UnwrapChartsResult::charts,
              "charts[c]: unwrap() of chart c (its vertices in increasing order of their index)");

  // UnwrapChartError: a MeshError that also says which chart (`chart`, from 0) and why (`reason`).
  static pb::handle chart_error;  // kept for the process's life, as register_exception does
  const pb::object mesh_error = m.attr("MeshError");
  chart_error = pb::exception<UnwrapChartError>(m, "UnwrapChartError", mesh_error).release();
  pb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const UnwrapChartError& e) {
      pb::object exc = pb::reinterpret_borrow<pb::object>(chart_error)(e.what());
      exc.attr("chart") = e.chart;
      exc.attr("reason") = e.reason;
      PyErr_SetObject(chart_error.ptr(), exc.ptr());
    }
  });

  m.def(
      "unwrap",
      [](InV V, InF F, const UnwrapOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return unwrap(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "unwrap_charts",
      [](InV V, InF F, const VecXi& labels, const UnwrapOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return unwrap_charts(V, F, labels, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("labels"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "uv_metrics",
      [](InV V, InF F, InUV UV, double eps) {
        NativeScope nogil;
        return uv_metrics(V, F, UV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps"));

  m.def(
      "uv_face_stretch",
      [](InV V, InF F, InUV UV, double eps) {
        NativeScope nogil;
        return uv_face_stretch(V, F, UV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps"));

  m.def(
      "uv_face_stretch_indexed",
      [](InV V, InF F, InUV UV, InF FUV, double eps) {
        NativeScope nogil;
        return uv_face_stretch(V, F, UV, FUV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("FUV"), pb::arg("zero_area_eps"));

  m.def(
      "uv_vertex_stretch",
      [](InV V, InF F, InUV UV, double eps) {
        NativeScope nogil;
        return uv_vertex_stretch(V, F, UV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps"));

  m.def(
      "connected_labels",
      [](int n, Eigen::Ref<const MatX2i> pairs) {
        NativeScope nogil;
        return connected_labels(n, pairs);
      },
      pb::arg("n"), pb::arg("pairs"));

  Struct<AutoUnwrapOptions>(m, "AutoUnwrapOptions", "Options of auto_unwrap() (dgmesh/charts.h)")
      .field("max_stretch", &AutoUnwrapOptions::max_stretch,
             "largest L2 stretch (eq. 5.5) a chart may keep; above it the chart is split; > 1, inf: no bound")
      .field("target_stretch", &AutoUnwrapOptions::target_stretch,
             "largest L2 stretch of the whole packed map; the worst chart is split until within it")
      .field("merge", &AutoUnwrapOptions::merge, "merge neighbouring charts while within both bounds")
      .field("charts", &AutoUnwrapOptions::charts, "initial charts (VSA segments), 0: automatic (8)")
      .field("max_charts", &AutoUnwrapOptions::max_charts, "no stretch split beyond this many charts")
      .field("margin", &AutoUnwrapOptions::margin, "gap between packed charts, fraction of the layout's side")
      .field("groups", &AutoUnwrapOptions::groups, "(m,) triangles of equal value stay in one chart; empty: none")
      .field("unwrap", &AutoUnwrapOptions::unwrap, "how each chart is unwrapped (UnwrapOptions)");

  Struct<AutoUnwrapResult>(m, "AutoUnwrapResult", "Result of auto_unwrap()")
      .result("uv", &AutoUnwrapResult::uv, "(3m, 2) row 3f + k: corner k of triangle f, packed in [0, 1]^2")
      .result("chart", &AutoUnwrapResult::chart, "(m,) chart of each triangle")
      .result("seams", &AutoUnwrapResult::seams, "(s, 2) vertex pairs of the edges between two charts")
      .result("chart_stretch", &AutoUnwrapResult::chart_stretch, "(n_charts,) L2 stretch of each chart's map")
      .result("metrics", &AutoUnwrapResult::metrics, "UvMetrics of the packed map")
      .result("n_charts", &AutoUnwrapResult::n_charts, "charts made")
      .result("initial_charts", &AutoUnwrapResult::initial_charts, "charts of the VSA segmentation")
      .result("topology_splits", &AutoUnwrapResult::topology_splits, "splits that made non-disk charts disks")
      .result("stretch_splits", &AutoUnwrapResult::stretch_splits, "splits of charts above max_stretch")
      .result("merges", &AutoUnwrapResult::merges, "pairs of charts merged")
      .result("path_cuts", &AutoUnwrapResult::path_cuts, "charts made disks by cutting between their boundary loops")
      .result("seam_length", &AutoUnwrapResult::seam_length, "total 3D length of the seams")
      .result("edge_length", &AutoUnwrapResult::edge_length, "total 3D length of all edges")
      .result("uv_area_used", &AutoUnwrapResult::uv_area_used, "sum of the UV triangle areas (at most 1)")
      .result("warnings", &AutoUnwrapResult::warnings, "for people");

  m.def(
      "auto_unwrap",
      [](InV V, InF F, const AutoUnwrapOptions& o, const pb::object& progress) {
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return auto_unwrap(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def(
      "chart_is_disk",
      [](InF F, const std::vector<int>& faces) {
        NativeScope nogil;
        return chart_is_disk(F, faces);
      },
      pb::arg("F"), pb::arg("faces"));
}

}  // namespace dgmesh::py
