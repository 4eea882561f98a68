// Bindings of skeletal.h and delaunay.h. Names, defaults and documentation live in
// addon/dgmesh/skeletal.py.
#include "common.h"
#include "dgmesh/delaunay.h"
#include "dgmesh/errors.h"
#include "dgmesh/skeletal.h"
#include "dgmesh/validate.h"

namespace dgmesh::py {

namespace {

using Mats = pb::array_t<double, pb::array::c_style | pb::array::forcecast>;

std::vector<Mat4> to_mats(const Mats& a, const char* what) {
  if (a.ndim() != 3 || a.shape(1) != 4 || a.shape(2) != 4)
    throw MeshError(std::string(what) + " must have shape (B, 4, 4)");
  auto r = a.unchecked<3>();
  std::vector<Mat4> out(r.shape(0));
  for (pb::ssize_t b = 0; b < r.shape(0); ++b)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) out[b](i, j) = r(b, i, j);
  return out;
}

pb::array_t<double> from_mats(const std::vector<Mat4>& m) {
  pb::array_t<double> a({static_cast<pb::ssize_t>(m.size()), pb::ssize_t(4), pb::ssize_t(4)});
  auto w = a.mutable_unchecked<3>();
  for (size_t b = 0; b < m.size(); ++b)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) w(b, i, j) = m[b](i, j);
  return a;
}

SkeletalMethod method_from(const std::string& s) {
  if (s == "variational") return SkeletalMethod::Variational;
  if (s == "basic") return SkeletalMethod::Basic;
  throw MeshError("method must be 'variational' or 'basic', got '" + s + "'");
}

SkeletalDeformOptions deform_options(const std::string& method, int fairing_steps, double fairing_step,
                                     int homotopy_steps, int fold_iterations, double projection = 1.0,
                                     bool dual_quaternion = true, double bone_clearance = -1) {
  SkeletalDeformOptions o;
  if (!(bone_clearance < 0)) o.bone_clearance = bone_clearance;  // negative: the default; NaN is refused
  o.projection = projection;
  o.dual_quaternion = dual_quaternion;
  o.method = method_from(method);
  o.fairing_steps = fairing_steps;
  o.fairing_step = fairing_step;
  o.homotopy_steps = homotopy_steps;
  o.fold_iterations = fold_iterations;
  return o;
}

template <class T>
T get(const pb::dict& d, const char* key) {
  if (!d.contains(key)) throw MeshError(std::string("skeletal data: missing '") + key + "'");
  return d[key].cast<T>();
}

}  // namespace

void bind_skeletal(pb::module_& m) {
  m.def(
      "delaunay_3d",
      [](InV P) {
        Delaunay3 d;
        {
          NativeScope nogil;
          d = delaunay_3d(P);
        }
        pb::dict out;
        out["tets"] = std::move(d.tets);
        out["circumcenters"] = std::move(d.circumcenters);
        out["circumradii"] = std::move(d.circumradii);
        out["point_offset"] = pb::array_t<int>(d.point_offset.size(), d.point_offset.data());
        out["point_tets"] = pb::array_t<int>(d.point_tets.size(), d.point_tets.data());
        return out;
      },
      pb::arg("points"));
  m.def(
      "delaunay_2d",
      [](Eigen::Ref<const MatX2d> P) {
        NativeScope nogil;
        return delaunay_2d(P);
      },
      pb::arg("points"));
  m.def(
      "skeletal_mesh",
      [](InV V, InF F, int pre, double pre_step, int post, double post_step, double spike, double angle) {
        SkeletonOptions o;
        o.presmooth_iterations = pre;
        o.presmooth_step = pre_step;
        o.postsmooth_iterations = post;
        o.postsmooth_step = post_step;
        o.spike_factor = spike;
        o.max_pole_angle = angle;
        SkeletalMesh s;
        {
          NativeScope nogil;
          s = skeletal_mesh(make_mesh(V, F, kSurface), o);
        }
        return pb::make_tuple(std::move(s.S), std::move(s.radii), s.n_fallback, s.n_postsmoothed);
      });
  m.def("union_of_balls_distance", [](InV X, InV C, const VecXd& r) {
    NativeScope nogil;
    if (!X.allFinite() || !C.allFinite() || !r.allFinite()) throw MeshError("union of balls: inputs must be finite");
    return union_of_balls_distance(X, C, r);
  });
  m.def("gaussian_bone_weights", [](InV P, InV heads, InV tails, double sigma) {
    NativeScope nogil;
    return gaussian_bone_weights(P, heads, tails, sigma);
  });
  m.def("skeletal_subspace_deform", [](InV P, const Eigen::MatrixXd& W, const Mats& rest, const Mats& pose,
                                       bool dual_quaternion) {
    const auto r = to_mats(rest, "bones_rest"), p = to_mats(pose, "bones_pose");
    NativeScope nogil;
    return skeletal_subspace_deform(P, W, r, p, nullptr, dual_quaternion);
  }, pb::arg("P"), pb::arg("W"), pb::arg("rest"), pb::arg("pose"), pb::arg("dual_quaternion") = false);

  pb::class_<SkeletalRig>(m, "SkeletalRig")
      .def_static(
          "bind",
          [](InV V, InF F, const Mats& rest, std::optional<Eigen::MatrixXd> weights, std::optional<MatX3d> heads,
             std::optional<MatX3d> tails, int control_faces, int level, int fit_iterations, double sigma,
             double frame_reg, int pre, int post, const pb::object& progress) {
            SkeletalRigOptions o;
            o.control_faces = control_faces;
            o.multires_level = level;
            o.multires_fit_iterations = fit_iterations;
            o.gaussian_sigma = sigma;
            o.frame_regularization = frame_reg;
            o.skeleton.presmooth_iterations = pre;
            o.skeleton.postsmooth_iterations = post;
            const auto r = to_mats(rest, "bones_rest");
            const ProgressFn cb = progress_from(progress);
            NativeScope nogil;
            return SkeletalRig::bind(V, F, r, weights ? *weights : Eigen::MatrixXd(),
                                     heads ? *heads : MatX3d(0, 3), tails ? *tails : MatX3d(0, 3), o, cb);
          },
          pb::arg("V"), pb::arg("F"), pb::arg("bones_rest"), pb::arg("weights"), pb::arg("heads"), pb::arg("tails"),
          pb::arg("control_faces"), pb::arg("level"), pb::arg("fit_iterations"), pb::arg("gaussian_sigma"),
          pb::arg("frame_regularization"), pb::arg("presmooth_iterations"), pb::arg("postsmooth_iterations"),
          pb::arg("progress"))
      .def(
          "deform",
          [](const SkeletalRig& rig, const Mats& pose, const std::string& method, int fs, double fstep, int hs, int fi,
             double proj, pb::object out, bool dq, double bc) -> pb::object {
            const auto p = to_mats(pose, "bones_pose");
            const SkeletalDeformOptions o = deform_options(method, fs, fstep, hs, fi, proj, dq, bc);
            if (out.is_none()) {
              MatX3d X;
              {
                NativeScope nogil;
                X = rig.deform(p, o);
              }
              return pb::cast(std::move(X));
            }
            // A C-contiguous float64 or float32 (n, 3) array is written in place (no copy, no
            // allocation of the dense result).
            if (pb::isinstance<pb::array>(out) && out.cast<pb::array>().dtype().is(pb::dtype::of<float>())) {
              auto ref = out.cast<Eigen::Ref<MatX3f>>();
              NativeScope nogil;
              rig.deform(p, o, ref);
            } else {
              auto ref = out.cast<Eigen::Ref<MatX3d>>();
              NativeScope nogil;
              rig.deform(p, o, ref);
            }
            return out;
          },
          pb::arg("pose"), pb::arg("method"), pb::arg("fairing_steps"), pb::arg("fairing_step"),
          pb::arg("homotopy_steps"), pb::arg("fold_iterations"), pb::arg("projection") = 1.0,
          pb::arg("out") = pb::none(), pb::arg("dual_quaternion") = true, pb::arg("bone_clearance") = -1.0)
      .def("deform_control",
           [](const SkeletalRig& rig, const Mats& pose, const std::string& method, int fs, double fstep, int hs,
              int fi, double proj, bool dq, double bc) {
             const auto p = to_mats(pose, "bones_pose");
             const SkeletalDeformOptions o = deform_options(method, fs, fstep, hs, fi, proj, dq, bc);
             MatX3d X, Sd;
             {
               NativeScope nogil;
               X = rig.deform_control(p, o, &Sd);
             }
             return pb::make_tuple(std::move(X), std::move(Sd));
           },
           pb::arg("pose"), pb::arg("method"), pb::arg("fairing_steps"), pb::arg("fairing_step"),
           pb::arg("homotopy_steps"), pb::arg("fold_iterations"), pb::arg("projection") = 1.0,
           pb::arg("dual_quaternion") = true, pb::arg("bone_clearance") = -1.0)
      .def("skeleton_pose",
           [](const SkeletalRig& rig, const Mats& pose) {
             const auto p = to_mats(pose, "bones_pose");
             NativeScope nogil;
             return rig.skeleton_pose(p);
           })
      .def_property_readonly("n_vertices", &SkeletalRig::n_vertices)
      .def_property_readonly("n_control", &SkeletalRig::n_control)
      .def_property_readonly("n_bones", &SkeletalRig::n_bones)
      .def_property_readonly("has_multires", &SkeletalRig::has_multires)
      .def_property_readonly("control_vertices", [](const SkeletalRig& r) { return MatX3d(r.control_vertices()); })
      .def_property_readonly("control_faces", [](const SkeletalRig& r) { return MatX3i(r.control_faces()); })
      .def_property_readonly("skeleton_vertices", [](const SkeletalRig& r) { return MatX3d(r.skeleton_vertices()); })
      .def_property_readonly("radii", [](const SkeletalRig& r) { return VecXd(r.radii()); })
      .def_property_readonly("weights", [](const SkeletalRig& r) { return Eigen::MatrixXd(r.weights()); })
      .def("data",
           [](const SkeletalRig& r) {
             const SkeletalRigData d = r.data();
             pb::dict o;
             o["control_V"] = d.control_V;
             o["control_F"] = d.control_F;
             o["S"] = d.S;
             o["weights"] = d.weights;
             o["bones_rest"] = from_mats(d.bones_rest);
             o["frame_regularization"] = d.frame_regularization;
             o["has_multires"] = d.has_multires;
             if (d.has_multires) {
               o["mr_control_V"] = d.multires.control_V;
               o["mr_control_F"] = d.multires.control_F;
               o["mr_level"] = d.multires.level;
               o["mr_face"] = d.multires.face;
               o["mr_st"] = d.multires.st;
               o["mr_disp"] = d.multires.disp;
             }
             return o;
           })
      .def_static("from_data", [](const pb::dict& o) {
        SkeletalRigData d;
        d.control_V = get<MatX3d>(o, "control_V");
        d.control_F = get<MatX3i>(o, "control_F");
        d.S = get<MatX3d>(o, "S");
        d.weights = get<Eigen::MatrixXd>(o, "weights");
        d.bones_rest = to_mats(get<Mats>(o, "bones_rest"), "bones_rest");
        d.frame_regularization = get<double>(o, "frame_regularization");
        d.has_multires = get<bool>(o, "has_multires");
        if (d.has_multires) {
          d.multires.control_V = get<MatX3d>(o, "mr_control_V");
          d.multires.control_F = get<MatX3i>(o, "mr_control_F");
          d.multires.level = get<int>(o, "mr_level");
          d.multires.face = get<VecXi>(o, "mr_face");
          d.multires.st = get<MatX2d>(o, "mr_st");
          d.multires.disp = get<MatX3d>(o, "mr_disp");
        }
        NativeScope nogil;
        return SkeletalRig::from_data(d);
      });
}

}  // namespace dgmesh::py
