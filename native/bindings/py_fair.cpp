// Bindings of fair.h: Willmore / bilaplacian / Laplacian-of-H fairing and tangential
// regularisation. Names, defaults and documentation live in addon/dgmesh/fair.py.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/fair.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

std::vector<char> to_mask(const std::optional<pb::array_t<bool, pb::array::c_style | pb::array::forcecast>>& a) {
  if (!a) return {};
  auto r = a->unchecked<1>();
  std::vector<char> out(r.shape(0));
  for (pb::ssize_t i = 0; i < r.shape(0); ++i) out[i] = r(i) ? 1 : 0;
  return out;
}

FairMethod method_from(const std::string& s) {
  if (s == "willmore") return FairMethod::Willmore;
  if (s == "bilaplacian") return FairMethod::Bilaplacian;
  if (s == "laplacian_of_h") return FairMethod::LaplacianOfH;
  throw MeshError("method must be 'willmore', 'bilaplacian' or 'laplacian_of_h', got '" + s + "'");
}

FairBoundary boundary_from(const std::string& s) {
  if (s == "fixed") return FairBoundary::Fixed;
  if (s == "sliding") return FairBoundary::Sliding;
  throw MeshError("boundary must be 'fixed' or 'sliding', got '" + s + "'");
}

FairScheme scheme_from(const std::string& s) {
  if (s == "explicit") return FairScheme::Explicit;
  if (s == "semi_implicit") return FairScheme::SemiImplicit;
  throw MeshError("scheme must be 'explicit' or 'semi_implicit', got '" + s + "'");
}

using Mask = std::optional<pb::array_t<bool, pb::array::c_style | pb::array::forcecast>>;

}  // namespace

void bind_fair(pb::module_& m) {
  m.def(
      "fair",
      [](InV Vin, InF Fin, const std::string& method, const std::string& scheme, const std::string& boundary,
         Mask mask, Mask face_mask, int subdivisions, double tolerance, int max_iterations, double max_seconds,
         bool tangential, double step_scale, const pb::object& progress, bool linear_start, bool refine, bool keep_size) {
        FairOptions o;
        o.keep_size = keep_size;
        o.linear_start = linear_start;
        o.refine = refine;
        o.method = method_from(method);
        o.scheme = scheme_from(scheme);
        o.boundary = boundary_from(boundary);
        o.vertex_mask = to_mask(mask);
        o.face_mask = to_mask(face_mask);
        o.subdivisions = subdivisions;
        o.tolerance = tolerance;
        o.max_iterations = max_iterations;
        o.max_seconds = max_seconds;
        o.tangential = tangential;
        o.step_scale = step_scale;
        const ProgressFn cb = progress_from(progress);
        FairResult r;
        {
          NativeScope nogil;
          r = fair(Vin, Fin, o, cb);
        }
        pb::dict d;
        d["vertices"] = std::move(r.V);
        d["faces"] = std::move(r.F);
        d["face_origin"] = std::move(r.face_origin);
        pb::array_t<bool> vm(r.vertex_mask.size());
        for (size_t i = 0; i < r.vertex_mask.size(); ++i) vm.mutable_at(i) = r.vertex_mask[i] != 0;
        d["vertex_mask"] = vm;
        d["energy"] = pb::array_t<double>(r.energy.size(), r.energy.data());
        d["level_iterations"] = r.level_iterations;
        d["iterations"] = r.iterations;
        d["converged"] = r.converged;
        d["lambda"] = r.lambda;
        d["linear_start"] = r.linear_start;
        d["energy_rose"] = r.energy_rose;
        return d;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("method"), pb::arg("scheme"), pb::arg("boundary"), pb::arg("mask"),
      pb::arg("face_mask"), pb::arg("subdivisions"), pb::arg("tolerance"), pb::arg("max_iterations"),
      pb::arg("max_seconds"), pb::arg("tangential"), pb::arg("step_scale"), pb::arg("progress"),
      pb::arg("linear_start") = true, pb::arg("refine") = false, pb::arg("keep_size") = true);

  m.def(
      "regularize",
      [](InV Vin, InF Fin, int iterations, Mask mask, const std::string& boundary, double step_scale,
         bool project, const pb::object& progress) {
        RegularizeOptions o;
        o.iterations = iterations;
        o.vertex_mask = to_mask(mask);
        o.boundary = boundary_from(boundary);
        o.step_scale = step_scale;
        o.project = project;
        const ProgressFn cb = progress_from(progress);
        MatX3d out;
        {
          NativeScope nogil;
          out = regularize(Vin, Fin, o, cb);
        }
        return out;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("iterations"), pb::arg("mask"), pb::arg("boundary"),
      pb::arg("step_scale"), pb::arg("project"), pb::arg("progress"));

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
