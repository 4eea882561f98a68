// Crest lines, feature-sensitive decimation and segmentation (thesis chapter 4): the options,
// results and functions of dgmesh/crest_lines.h, decimate.h and segment.h as they are.
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "common.h"
#include "dgmesh/crest_lines.h"
#include "dgmesh/decimate.h"
#include "dgmesh/segment.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

// Crest lines handed back from Python must index this mesh's vertices and faces.
void check_lines(const Mesh& mesh, const CrestLines& c) {
  if (static_cast<Eigen::Index>(c.segment_face.size()) != c.segments.rows())
    throw MeshError("segment_face must have one entry per segment");
  for (int s = 0; s < c.segments.rows(); ++s)
    for (int k = 0; k < 2; ++k)
      if (c.segments(s, k) < 0 || c.segments(s, k) >= c.point_edge.rows())
        throw MeshError("crest segment refers to a missing point");
  for (int p = 0; p < c.point_edge.rows(); ++p)
    for (int k = 0; k < 2; ++k)
      if (c.point_edge(p, k) < -1 || c.point_edge(p, k) >= mesh.V.rows())
        throw MeshError("crest point edge refers to a missing vertex (crest lines of another mesh?)");
  for (int f : c.segment_face)
    if (f < -1 || f >= mesh.F.rows()) throw MeshError("crest segment face out of range (crest lines of another mesh?)");
}

// F(d) of eq. 4.12 per face for a feature-guided application, on the caller's validated mesh (one
// validation and topology per call, thesis 4.8-4.9): from the given crest lines, or from crest
// lines detected here with `rings` and `threshold` (progress over [0, share]). Empty when eta is 0.
VecXd feature_values(const Mesh& mesh, const FeatureOptions& opt, const CrestLines* given, const ProgressFn& progress,
                     double share) {
  const double eta = opt.feature_weight;
  if (!(eta >= 0.0 && eta <= kMaxFeatureWeight))
    throw MeshError("feature_weight (eta) must be in [0, " + std::to_string(kMaxFeatureWeight) + "], got " +
                    std::to_string(eta));
  if (eta == 0.0) return {};
  CrestLines lines;
  if (given) {
    check_lines(mesh, *given);
  } else {
    if (!std::isfinite(opt.threshold)) throw MeshError("threshold must be finite");
    DerivativeOptions fit;
    fit.rings = opt.rings;
    CrestOptions detect;
    detect.threshold = opt.threshold;
    ProgressFn sub;
    if (progress) sub = [&progress, share](double f) { return progress(share * f); };
    lines = crest_lines(mesh, fit, detect, sub);
  }
  return feature_function(crest_face_distance(mesh, given ? *given : lines), eta);
}

ProgressFn tail_progress(const ProgressFn& progress, double start) {
  if (!progress || start == 0.0) return progress;
  return [progress, start](double f) { return progress(start + (1.0 - start) * f); };
}

}  // namespace

void bind_crest(pb::module_& m) {
  Struct<DerivativeOptions>(m, "DerivativeOptions", "Options of curvature_derivatives(): the cubic fit of thesis 4.5")
      .field("rings", &DerivativeOptions::rings, "k of the k-ring used for the fit (thesis 1..4; 1..8 accepted)")
      .field("jet", &DerivativeOptions::jet,
             "two-pass jet fit (heights + jet normals, degree 3 / 5); false (default): the thesis's cubic fit")
      .field("noise_adaptive", &DerivativeOptions::noise_adaptive,
             "with jet: fall back to the thesis fit when the mesh looks noisy (2-ring cubic / quartic residual ratio "
             "above kJetNoiseRatio)")
      .field("plateaus", &DerivativeOptions::plateaus,
             "crest lines with jet: traced on the thesis fit where the dominant curvature is constant to within the "
             "jet's error (flat regions, G1 blends), so a blend's crest line is its middle line")
      .field("smooth", &DerivativeOptions::smooth, "fit on M' (p' = mean of the centroids of the faces around p)")
      .field("use_normals", &DerivativeOptions::use_normals, "adjacent-normal equations in the fit (table 4.1)")
      .field("fit_tangent_plane", &DerivativeOptions::fit_tangent_plane,
             "fit the tangent plane too (linear terms; the Max normal as one more equation)")
      .field("transport_to_vertex", &DerivativeOptions::transport_to_vertex,
             "evaluate the fit at the foot of the original vertex p rather than at p'");

  Struct<CurvatureDerivatives>(m, "CurvatureDerivatives", "Result of curvature_derivatives(), per vertex")
      .result("k_max", &CurvatureDerivatives::k_max, "(n,) maximal principal curvature (positive on a sphere)")
      .result("k_min", &CurvatureDerivatives::k_min, "(n,) minimal principal curvature")
      .result("e_max", &CurvatureDerivatives::e_max, "(n,) extremality coefficient dk_max/dt_max (eq. 4.8-4.9)")
      .result("e_min", &CurvatureDerivatives::e_min, "(n,) extremality coefficient dk_min/dt_min")
      .result("t_max", &CurvatureDerivatives::t_max, "(n, 3) unit principal direction of k_max")
      .result("t_min", &CurvatureDerivatives::t_min, "(n, 3) unit principal direction of k_min")
      .result("normals", &CurvatureDerivatives::normals, "(n, 3) normals of the fitted surface")
      .result("noise_ratio", &CurvatureDerivatives::noise_ratio,
              "with jet: median 2-ring quartic / cubic residual ratio of the noise test (0: no evidence of noise)")
      .result("jet_used", &CurvatureDerivatives::jet_used, "the jet fit was used (not the thesis fit)")
      .result("e_max_error", &CurvatureDerivatives::e_max_error,
              "(n,) with the jet fit: standard error of e_max from the fit's residual (empty otherwise)")
      .result("e_min_error", &CurvatureDerivatives::e_min_error, "(n,) with the jet fit: standard error of e_min")
      .result("plateau_vertices", &CurvatureDerivatives::plateau_vertices,
              "crest lines with the jet fit: vertices traced on the thesis fit (DerivativeOptions.plateaus)");

  m.attr("JET_NOISE_RATIO") = kJetNoiseRatio;

  pb::enum_<CrestKind>(m, "CrestKind", "Kind of a crest line (CrestLines.line_kind)")
      .value("ridge", kRidge, "convex crest line")
      .value("valley", kValley, "concave crest line");

  Struct<CrestOptions>(m, "CrestOptions", "Options of crest_lines(): tracing and thresholding (thesis 4.6)")
      .field("ridges", &CrestOptions::ridges, "keep ridges (convex crest lines)")
      .field("valleys", &CrestOptions::valleys, "keep valleys (concave crest lines)")
      .field("join_gaps", &CrestOptions::join_gaps, "gap jumping of fig. 4.10")
      .field("skip_boundary", &CrestOptions::skip_boundary, "ignore edges touching the mesh boundary")
      .field("threshold", &CrestOptions::threshold,
             "keep lines with strength T >= threshold (eq. 4.10, dimensionless); 0 keeps every line");

  Struct<CrestLines>(m, "CrestLines", "Crest lines: points, segments between them, and lines as point lists")
      .result("points", &CrestLines::points, "(P, 3) crest points")
      .result("point_edge", &CrestLines::point_edge,
              "(P, 2) the mesh edge (v0, v1) of each point; (-1, -1) for a junction inside a triangle")
      .result("point_t", &CrestLines::point_t, "(P,) point = (1 - t) v0 + t v1")
      .result("point_cyclideness", &CrestLines::point_cyclideness, "(P,) cyclideness C of eq. 4.11")
      .result("segments", &CrestLines::segments, "(S, 2) point indices of each segment")
      .result("segment_line", &CrestLines::segment_line, "(S,) the line of each segment")
      .result("segment_face", &CrestLines::segment_face, "(S,) the triangle holding it (-1: a gap jump)")
      .result("line_offset", &CrestLines::line_offset, "(L + 1,) line l: line_points[line_offset[l]:line_offset[l+1]]")
      .result("line_points", &CrestLines::line_points, "point indices of the lines in order (closed: first repeated)")
      .result("line_kind", &CrestLines::line_kind, "(L,) CrestKind of each line (0 ridge, 1 valley)")
      .result("line_strength", &CrestLines::line_strength, "(L,) strength T of eq. 4.10 (dimensionless)")
      .result("line_length", &CrestLines::line_length, "(L,) length of each line");

  Struct<FeatureOptions>(m, "FeatureOptions", "Crest-line guidance of decimate() and segment(): F(d) of eq. 4.12")
      .field("feature_weight", &FeatureOptions::feature_weight, "eta of eq. 4.12; 0: not guided")
      .field("rings", &FeatureOptions::rings, "fitting rings of the detected crest lines")
      .field("threshold", &FeatureOptions::threshold, "strength threshold T of the detected crest lines");
  m.attr("MAX_FEATURE_WEIGHT") = kMaxFeatureWeight;
  m.def("decimate_feature_defaults", &decimate_feature_defaults, "Decimation's guidance: eta 6 (thesis fig. 4.19)");
  m.def("segment_feature_defaults", &segment_feature_defaults, "Segmentation's guidance: eta 2 (fig. 4.26-4.27)");

  Struct<DecimateOptions>(m, "DecimateOptions", "Options of decimate() (Garland-Heckbert quadric edge collapses)")
      .field("target_faces", &DecimateOptions::target_faces, "stop when at most this many faces are left")
      .field("max_error", &DecimateOptions::max_error, "stop earlier when the cheapest collapse costs more")
      .field("area_weighted", &DecimateOptions::area_weighted, "face quadrics scaled by the face area")
      .field("preserve_boundary", &DecimateOptions::preserve_boundary,
             "boundary vertices never move and are never removed")
      .field("boundary_weight", &DecimateOptions::boundary_weight,
             "weight of the boundary constraint planes when not preserving the boundary")
      .field("max_normal_angle", &DecimateOptions::max_normal_angle,
             "reject collapses turning a face normal by more than this (radians)")
      .field("min_quality", &DecimateOptions::min_quality, "reject collapses making worse slivers than this, in [0, 1)")
      .field("batched", &DecimateOptions::batched,
             "multiple-choice passes (true) or one global priority queue (false, the exact greedy order)");

  Struct<DecimateResult>(m, "DecimateResult", "Result of decimate()")
      .result("V", &DecimateResult::V, "(n', 3) decimated positions")
      .result("F", &DecimateResult::F, "(m', 3) triangles")
      .result("vertex_map", &DecimateResult::vertex_map, "(n,) output vertex of each input vertex (-1: loose)")
      .result("face_map", &DecimateResult::face_map, "(m',) input face each output face is")
      .result("source_vertex", &DecimateResult::source_vertex, "(n',) input vertex each output vertex is")
      .result("collapses", &DecimateResult::collapses, "edge collapses done");

  Struct<SegmentOptions>(m, "SegmentOptions", "Options of segment() (variational shape approximation, thesis 4.9)")
      .field("segments", &SegmentOptions::segments, "segments to make")
      .field("iterations", &SegmentOptions::iterations, "Lloyd iterations once every seed is placed");

  Struct<SegmentResult>(m, "SegmentResult", "Result of segment()")
      .result("labels", &SegmentResult::labels, "(m,) segment of each face, 0 .. n_segments-1")
      .result("proxy_normals", &SegmentResult::proxy_normals, "(n_segments, 3) unit normal of each segment")
      .result("n_segments", &SegmentResult::n_segments, "segments made (more only with more components)")
      .result("iterations", &SegmentResult::iterations, "Lloyd iterations run")
      .result("error", &SegmentResult::error, "total L^{2,1} distortion");

  m.def(
      "curvature_derivatives",
      [](InV Vin, InF Fin, const DerivativeOptions& fit, const pb::object& cb) {
        const ProgressFn progress = progress_from(cb);
        NativeScope nogil;
        return curvature_derivatives(make_mesh(Vin, Fin, kSurface), fit, progress);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("progress") = pb::none());

  // Fit and trace: (derivatives, lines).
  m.def(
      "crest_lines",
      [](InV Vin, InF Fin, const DerivativeOptions& fit, const CrestOptions& opt, const pb::object& cb) {
        const ProgressFn progress = progress_from(cb);
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        CurvatureDerivatives d = crest_fields(mesh, fit, progress);
        CrestLines c = trace_crest_lines(mesh, d, opt);
        return std::make_pair(std::move(d), std::move(c));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("fit"), pb::arg("options"), pb::arg("progress") = pb::none());

  m.def("filter_crest_lines", &filter_crest_lines, pb::arg("lines"), pb::arg("threshold"), pb::arg("ridges") = true,
        pb::arg("valleys") = true, "The lines with T >= threshold and of the requested kinds, re-indexed");

  // Geodesic distance from each face to the given crest lines (thesis 4.8).
  m.def(
      "crest_face_distance",
      [](InV Vin, InF Fin, const CrestLines& lines) {
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        check_lines(mesh, lines);
        return crest_face_distance(mesh, lines);
      },
      pb::arg("V"), pb::arg("F"), pb::arg("lines"));

  // The per-vertex locked and planes flags are input data, not options.
  m.def(
      "decimate",
      [](InV Vin, InF Fin, DecimateOptions opt, const FeatureOptions& features, const CrestLines* crest,
         std::optional<std::vector<int>> locked, std::optional<std::vector<int>> planes, const pb::object& cb) {
        if (locked) opt.locked.assign(locked->begin(), locked->end());
        if (planes) opt.planes.assign(planes->begin(), planes->end());
        const ProgressFn progress = progress_from(cb);
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        const double share = features.feature_weight > 0 && !crest ? 0.3 : 0.0;  // of the progress for the fit
        const VecXd Fd = feature_values(mesh, features, crest, progress, share);
        if (Fd.size()) {  // thesis 4.8: face quadrics weighted by 1 / F(d)
          if (opt.face_weights.size() == 0) opt.face_weights = VecXd::Ones(Fd.size());
          opt.face_weights.array() /= Fd.array();
        }
        return decimate(mesh, opt, tail_progress(progress, share));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("features"), pb::arg("crest") = pb::none(),
      pb::arg("locked") = pb::none(), pb::arg("planes") = pb::none(), pb::arg("progress") = pb::none());

  m.def(
      "segment",
      [](InV Vin, InF Fin, SegmentOptions opt, const FeatureOptions& features, const CrestLines* crest,
         const pb::object& cb) {
        const ProgressFn progress = progress_from(cb);
        NativeScope nogil;
        const Mesh mesh = make_mesh(Vin, Fin, kSurface);
        const double share = features.feature_weight > 0 && !crest ? 0.3 : 0.0;
        VecXd Fd = feature_values(mesh, features, crest, progress, share);
        if (Fd.size()) opt.face_feature = std::move(Fd);
        return segment(mesh, opt, tail_progress(progress, share));
      },
      pb::arg("V"), pb::arg("F"), pb::arg("options"), pb::arg("features"), pb::arg("crest") = pb::none(),
      pb::arg("progress") = pb::none());
}

}  // namespace dgmesh::py
