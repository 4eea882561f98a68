// Low-stretch unwrapping and UV metrics (thesis chapter 5). Names and defaults are documented in
// addon/dgmesh/unwrap.py.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/unwrap.h"

namespace dgmesh::py {

namespace {

using InUV = Eigen::Ref<const MatX2d>;

UvBoundary parse_boundary(const std::string& s) {
  if (s == "square") return UvBoundary::Square;
  if (s == "circle") return UvBoundary::Circle;
  if (s == "free") return UvBoundary::Free;
  throw MeshError("boundary must be 'square', 'circle' or 'free', got '" + s + "'");
}

UvWeights parse_weights(const std::string& s) {
  if (s == "floater") return UvWeights::Floater;
  if (s == "mean_value") return UvWeights::MeanValue;
  if (s == "cotangent") return UvWeights::Cotangent;
  if (s == "uniform") return UvWeights::Uniform;
  if (s == "auto") return UvWeights::Auto;
  throw MeshError("weights must be 'floater', 'mean_value', 'cotangent', 'uniform' or 'auto', got '" + s + "'");
}

UvSolver parse_solver(const std::string& s) {
  if (s == "auto") return UvSolver::Auto;
  if (s == "umfpack") return UvSolver::Umfpack;
  if (s == "sparselu") return UvSolver::SparseLU;
  if (s == "bicgstab") return UvSolver::BiCGSTAB;
  if (s == "multigrid") return UvSolver::Multigrid;
  throw MeshError("solver must be 'auto', 'umfpack', 'sparselu', 'bicgstab' or 'multigrid', got '" + s + "'");
}

const char* boundary_name(UvBoundary b) {
  switch (b) {
    case UvBoundary::Square: return "square";
    case UvBoundary::Circle: return "circle";
    case UvBoundary::Free: return "free";
  }
  return "?";
}

pb::dict metrics_dict(const UvMetrics& m) {
  pb::dict d;
  d["stretch_l2"] = m.stretch_l2;
  d["stretch_linf"] = m.stretch_linf;
  d["stretch_l2_finite"] = m.stretch_l2_finite;
  d["edge"] = m.edge;
  d["angle"] = m.angle;
  d["area"] = m.area;
  d["flipped"] = m.flipped;
  d["zero_area"] = m.zero_area;
  return d;
}

}  // namespace

void bind_unwrap(pb::module_& m) {
  m.def(
      "unwrap",
      [](InV V, InF F, const std::string& boundary, const std::string& weights, double eta, int iterations,
         int max_iterations, double min_improvement, const std::string& solver, double tolerance,
         double step_tolerance, double zero_area_eps, double stretch_cap, bool slide_boundary,
         const pb::object& progress) {
        UnwrapOptions o;
        o.boundary = parse_boundary(boundary);
        o.weights = parse_weights(weights);
        o.solver = parse_solver(solver);
        o.eta = eta;
        o.iterations = iterations;
        o.max_iterations = max_iterations;
        o.min_improvement = min_improvement;
        o.tolerance = tolerance;
        o.step_tolerance = step_tolerance;
        o.zero_area_eps = zero_area_eps;
        o.stretch_cap = stretch_cap;
        o.slide_boundary = slide_boundary;
        UnwrapResult r;
        {
          NativeScope nogil;
          r = unwrap(V, F, o, progress_from(progress));
        }
        pb::dict d;
        pb::list steps;
        for (const UnwrapStep& s : r.steps) {
          pb::dict sd = metrics_dict(s.metrics);
          sd["seconds"] = s.seconds;
          sd["solver_iterations"] = s.solver_iterations;
          steps.append(sd);
        }
        d["uv"] = std::move(r.uv);
        d["steps"] = steps;
        d["chosen"] = r.chosen;
        d["boundary"] = boundary_name(r.boundary_used);
        d["boundary_convex"] = r.boundary_convex;
        d["n_holes"] = r.n_holes;
        d["corners"] = r.corners;
        d["warnings"] = r.warnings;
        d["solver"] = r.solver;
        return d;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("boundary") = "square", pb::arg("weights") = "floater",
      pb::arg("eta") = 1.0, pb::arg("iterations") = -1, pb::arg("max_iterations") = 100,
      pb::arg("min_improvement") = 1e-3, pb::arg("solver") = "auto", pb::arg("tolerance") = 1e-6,
      pb::arg("step_tolerance") = 1e-4, pb::arg("zero_area_eps") = 1e-10, pb::arg("stretch_cap") = 1e3,
      pb::arg("slide_boundary") = false, pb::arg("progress") = pb::none());

  m.def(
      "uv_metrics",
      [](InV V, InF F, InUV UV, double eps) {
        UvMetrics r;
        {
          NativeScope nogil;
          r = uv_metrics(V, F, UV, eps);
        }
        return metrics_dict(r);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps") = 1e-10);

  m.def(
      "uv_face_stretch",
      [](InV V, InF F, InUV UV, double eps) {
        NativeScope nogil;
        return uv_face_stretch(V, F, UV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps") = 1e-10);

  m.def(
      "uv_face_stretch_indexed",
      [](InV V, InF F, InUV UV, InF FUV, double eps) {
        NativeScope nogil;
        return uv_face_stretch(V, F, UV, FUV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("FUV"), pb::arg("zero_area_eps") = 1e-10);

  m.def(
      "uv_vertex_stretch",
      [](InV V, InF F, InUV UV, double eps) {
        NativeScope nogil;
        return uv_vertex_stretch(V, F, UV, eps);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("UV"), pb::arg("zero_area_eps") = 1e-10);

  m.def(
      "connected_labels",
      [](int n, Eigen::Ref<const MatX2i> pairs) {
        NativeScope nogil;
        return connected_labels(n, pairs);
      },
      pb::arg("n"), pb::arg("pairs"));
}

}  // namespace dgmesh::py
