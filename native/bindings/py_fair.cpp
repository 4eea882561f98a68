// Fairing (thesis ch. 3): the options, enums, results and functions of dgmesh/fair.h as they are.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/fair.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

using Mask = std::optional<pb::array_t<bool, pb::array::c_style | pb::array::forcecast>>;

std::vector<char> to_mask(const Mask& a) {
  if (!a) return {};
  auto r = a->unchecked<1>();
  std::vector<char> out(r.shape(0));
  for (pb::ssize_t i = 0; i < r.shape(0); ++i) out[i] = r(i) ? 1 : 0;
  return out;
}

}  // namespace

void bind_fair(pb::module_& m) {
  pb::enum_<FairMethod>(m, "FairMethod", "Curvature flow of fair()")
      .value("willmore", FairMethod::Willmore, "F = -Laplace_S(H) - 2H(H^2 - K) (eq. 3.5)")
      .value("bilaplacian", FairMethod::Bilaplacian, "P <- P - tau U0^2(P), uniform bi-umbrella (section 3.2)")
      .value("laplacian_of_h", FairMethod::LaplacianOfH, "F = -Laplace_S(H) (eq. 3.12)")
      .value("hinge", FairMethod::Hinge,
             "edge-based Willmore energy sum 3 theta^2 |e|^2 / A_e, Levenberg-Marquardt from U0^2 P = 0");
  pb::enum_<FairScheme>(m, "FairScheme", "Time stepping of fair()")
      .value("explicit", FairScheme::Explicit, "the thesis's forward Euler step (3.8), tau = A_min^2/150")
      .value("semi_implicit", FairScheme::SemiImplicit,
             "preconditioned by a linearised implicit bi-Laplacian step: same fixed points, far larger steps");
  pb::enum_<FairStall>(m, "FairStall", "Whether fair()'s flow changed the region (FairResult.stall)")
      .value("none", FairStall::None, "some level lowered the energy (bilaplacian: moved a vertex), or was restarted")
      .value("no_descent", FairStall::NoDescent, "no vertex moved: no step lowered the energy from the start")
      .value("no_change", FairStall::NoChange,
             "vertices moved, but no level lowered its energy by more than 10 x tolerance");
  pb::enum_<FairBoundary>(m, "FairBoundary", "Mesh-boundary vertices in fair() and regularize()")
      .value("fixed", FairBoundary::Fixed, "do not move")
      .value("sliding", FairBoundary::Sliding, "slide along the (original) boundary polyline");

  pb::enum_<FairStartWeights>(m, "FairStartWeights", "Weights of the linear start's bi-Laplacian")
      .value("uniform", FairStartWeights::Uniform, "uniform bi-umbrella U0^2 (section 3.2), connectivity only")
      .value("cotangent", FairStartWeights::Cotangent,
             "cotangent bi-Laplacian L M^-1 L on the input geometry (as CGAL's PMP::fair)");

  Struct<FairOptions>(m, "FairOptions", "Options of fair() (the masks are separate arguments)")
      .field("method", &FairOptions::method, "the flow")
      .field("scheme", &FairOptions::scheme, "the time stepping")
      .field("boundary", &FairOptions::boundary, "mesh-boundary vertices: fixed or sliding")
      .field("subdivisions", &FairOptions::subdivisions, "coarse-to-fine levels, 0..6 (fig. 3.5)")
      .field("tolerance", &FairOptions::tolerance, "relative energy change per unit of flow time that stops a level")
      .field("min_progress", &FairOptions::min_progress,
             "semi-implicit: stop a level when the energy fell over the last 8 accepted steps by less than this "
             "fraction of the smaller of its fall since the level's input and the energy left; 0 = off")
      .field("max_iterations", &FairOptions::max_iterations, "iterations per level")
      .field("max_seconds", &FairOptions::max_seconds, "wall-clock budget of the whole run; 0 = none")
      .field("tangential", &FairOptions::tangential, "add the tangential drift eps T (eq. 3.8)")
      .field("step_scale", &FairOptions::step_scale, "multiplies the explicit scheme's tau = A_min^2/150")
      .field("linear_start", &FairOptions::linear_start,
             "with fixed vertices, start from the linearised minimiser when that lowers the energy")
      .field("start_weights", &FairOptions::start_weights, "weights of the linear start's bi-Laplacian")
      .field("refine", &FairOptions::refine, "refine the region Liepa-style before the flow (hole fills)")
      .field("keep_size", &FairOptions::keep_size,
             "Willmore, Laplacian of H: a component without fixed vertices keeps its centroid and area");
  m.def("fair_defaults", &fair_defaults, pb::arg("scheme"),
        "The defaults of a scheme: FairOptions() for semi_implicit; 5000 iterations per level for explicit");

  Struct<FairResult>(m, "FairResult", "Result of fair()")
      .result("vertices", &FairResult::V, "(n', 3) the input's vertices first (same indices), then new ones")
      .result("faces", &FairResult::F, "(m', 3) row f < m holds a child of input face f, extra children follow")
      .result("face_origin", &FairResult::face_origin, "(m',) input face each output face comes from")
      .result("energy", &FairResult::energy, "Willmore energy after each iteration; energy[0] is the input's")
      .result("moved", &FairResult::vertex_mask, "(n',) bool: vertices that were free to move at the last level")
      .result("level_iterations", &FairResult::level_iterations, "iterations spent on each level")
      .result("iterations", &FairResult::iterations, "iterations of all levels")
      .result("converged", &FairResult::converged, "the last level met the tolerance")
      .result("lam", &FairResult::lambda, "last H rescaling factor (thesis 3.1), 1 when H^2 >= K everywhere")
      .result("linear_start", &FairResult::linear_start, "the flow started from the linearised minimiser")
      .result("energy_rose", &FairResult::energy_rose,
              "some level ended above its start energy and returned its lowest-energy state")
      .result("restarted", &FairResult::restarted,
              "the flow from the input stalled at a discrete minimum and was restarted from the linearised minimiser")
      .result("stall", &FairResult::stall, "none, or why the flow did not change the region (FairStall)")
      .result("start_fallback", &FairResult::start_fallback,
              "start_weights='cotangent' was asked for but the uniform start was used (a vertex near the region "
              "without area, a failed solve, or a part without fixed vertices)")
      .cls()
      .def_property_readonly(
          "subdivided",
          [](const FairResult& r) {
            if (r.F.rows() != r.face_origin.size()) return true;
            for (Eigen::Index f = 0; f < r.face_origin.size(); ++f)
              if (r.face_origin[f] != f) return true;
            return false;
          },
          "faces were added or replaced (subdivisions, refine)");

  m.def(
      "fair",
      [](InV V, InF F, const FairOptions& opt, Mask mask, Mask face_mask, const pb::object& progress) {
        FairOptions o = opt;
        o.vertex_mask = to_mask(mask);
        o.face_mask = to_mask(face_mask);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return fair(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("mask") = pb::none(), pb::arg("face_mask") = pb::none(),
      pb::arg("progress") = pb::none());

  Struct<RegularizeOptions>(m, "RegularizeOptions", "Options of regularize() (the mask is a separate argument)")
      .field("iterations", &RegularizeOptions::iterations, "drift steps")
      .field("boundary", &RegularizeOptions::boundary, "mesh-boundary vertices: fixed or sliding")
      .field("step_scale", &RegularizeOptions::step_scale,
             "multiplies the thesis's eps = 12 A_min (A_min within two rings of each vertex)")
      .field("project", &RegularizeOptions::project, "project moved vertices back onto the input surface each step");

  m.def(
      "regularize",
      [](InV V, InF F, const RegularizeOptions& opt, Mask mask, const pb::object& progress) {
        RegularizeOptions o = opt;
        o.vertex_mask = to_mask(mask);
        const ProgressFn cb = progress_from(progress);
        NativeScope nogil;
        return regularize(V, F, o, cb);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("mask") = pb::none(), pb::arg("progress") = pb::none());

  m.def(
      "willmore_energy",
      [](InV V, InF F) {
        NativeScope nogil;
        return willmore_energy(V, F);
      },
      pb::arg("V"), pb::arg("F"));

  m.def(
      "subdivide_region",
      [](InV V, InF F, Mask face_mask) {
        std::vector<char> fm = to_mask(face_mask);
        RegionSubdivision r;
        {
          NativeScope nogil;
          validate(V, F, kNonEmpty | kIndices);
          r = subdivide_region(V, F, fm);
        }
        return pb::make_tuple(std::move(r.V), std::move(r.F), std::move(r.face_origin));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("face_mask"));

  m.def(
      "refine_region",
      [](InV V, InF F, Mask face_mask, double density) {
        std::vector<char> fm = to_mask(face_mask);
        RegionSubdivision r;
        {
          NativeScope nogil;
          validate(V, F, kNonEmpty | kIndices | kFinite);
          r = refine_region(V, F, fm, density);
        }
        return pb::make_tuple(std::move(r.V), std::move(r.F), std::move(r.face_origin));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("face_mask"), pb::arg("density"));
}

}  // namespace dgmesh::py
