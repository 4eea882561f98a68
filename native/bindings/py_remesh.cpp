// Remeshing by double parameterization (thesis 5.4). Names and defaults are documented in
// addon/dgmesh/remesh.py.
#include "common.h"
#include "dgmesh/errors.h"
#include "dgmesh/remesh.h"

namespace dgmesh::py {

void bind_remesh(pb::module_& m) {
  m.def(
      "remesh",
      [](InV V, InF F, int target_vertices, double adaptivity, int resolution, const std::string& mode,
         const std::string& boundary, const std::string& domain, double boundary_clearance, double curvature_clip,
         bool flip_3d, double eta, int uopt_steps, int lloyd_iterations, const std::string& relax_metric,
         double min_separation, int smooth_iterations,
         const pb::object& progress) {
        RemeshOptions o;
        o.target_vertices = target_vertices;
        o.adaptivity = adaptivity;
        o.resolution = resolution;
        if (mode == "double") o.mode = RemeshMode::Double;
        else if (mode == "single_u0") o.mode = RemeshMode::SingleU0;
        else if (mode == "single_uopt") o.mode = RemeshMode::SingleUopt;
        else throw MeshError("mode must be 'double', 'single_u0' or 'single_uopt', got '" + mode + "'");
        if (boundary == "keep") o.boundary = RemeshBoundary::Keep;
        else if (boundary == "resample") o.boundary = RemeshBoundary::Resample;
        else throw MeshError("boundary must be 'keep' or 'resample', got '" + boundary + "'");
        if (domain == "circle") o.domain = UvBoundary::Circle;
        else if (domain == "square") o.domain = UvBoundary::Square;
        else throw MeshError("domain must be 'circle' or 'square', got '" + domain + "'");
        o.boundary_clearance = boundary_clearance;
        o.curvature_clip = curvature_clip;
        o.flip_3d = flip_3d;
        o.eta = eta;
        o.uopt_steps = uopt_steps;
        o.lloyd_iterations = lloyd_iterations;
        o.min_separation = min_separation;
        o.smooth_iterations = smooth_iterations;
        if (relax_metric == "surface") o.relax_metric = RemeshRelaxMetric::Surface;
        else if (relax_metric == "map") o.relax_metric = RemeshRelaxMetric::Map;
        else throw MeshError("relax_metric must be 'surface' or 'map', got '" + relax_metric + "'");
        RemeshResult r;
        {
          NativeScope nogil;
          r = remesh(V, F, o, progress_from(progress));
        }
        pb::dict d;
        d["V"] = std::move(r.V);
        d["F"] = std::move(r.F);
        d["uv"] = std::move(r.uv);
        d["n_boundary"] = r.n_boundary;
        d["boundary_source"] = std::move(r.boundary_source);
        d["source_face"] = std::move(r.source_face);
        d["source_bary"] = std::move(r.source_bary);
        d["n_interior_target"] = r.n_interior_target;
        d["n_rejected"] = r.n_rejected;
        d["passes"] = r.passes;
        d["uopt_iterations"] = r.uopt_iterations;
        d["n_flips"] = r.n_flips;
        d["lloyd_iterations"] = r.lloyd_iterations;
        d["n_separated"] = r.n_separated;
        d["sampling_rounds"] = r.sampling_rounds;
        d["resolution"] = r.resolution;
        d["smooth_moves"] = r.smooth_moves;
        d["n_removed"] = r.n_removed;
        d["seconds_relax"] = r.seconds_relax;
        d["seconds_parameterize"] = r.seconds_parameterize;
        d["seconds_sample"] = r.seconds_sample;
        d["seconds_triangulate"] = r.seconds_triangulate;
        d["warnings"] = r.warnings;
        return d;
      },
      pb::arg("V"), pb::arg("F"), pb::arg("target_vertices"), pb::arg("adaptivity") = 0.0,
      pb::arg("resolution") = 256, pb::arg("mode") = "double", pb::arg("boundary") = "keep",
      pb::arg("domain") = "circle", pb::arg("boundary_clearance") = 0.5, pb::arg("curvature_clip") = 8.0,
      pb::arg("flip_3d") = true, pb::arg("eta") = 1.0, pb::arg("uopt_steps") = -1,
      pb::arg("lloyd_iterations") = 30, pb::arg("relax_metric") = "surface",
      pb::arg("min_separation") = 0.35, pb::arg("smooth_iterations") = 3, pb::arg("progress") = pb::none());

  m.def(
      "point_mesh_distance",
      [](InV P, InV V, InF F, int candidates) {
        NativeScope nogil;
        return point_mesh_distance(P, V, F, candidates);
      },
      pb::arg("P"), pb::arg("V"), pb::arg("F"), pb::arg("candidates") = 16);
}

}  // namespace dgmesh::py
