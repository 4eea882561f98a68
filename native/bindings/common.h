// Shared helpers of the pybind11 module: numpy <-> Eigen without copies where the layout allows,
// progress callbacks that take the GIL, and the per-capability bind functions.
#pragma once
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>

#include "dgmesh/parallel.h"
#include "dgmesh/progress.h"
#include "dgmesh/types.h"

namespace dgmesh::py {

namespace pb = pybind11;

// C-contiguous float64 (n,3) / int32 (m,3) arrays bind without a copy; anything else is converted.
using InV = Eigen::Ref<const MatX3d>;
using InF = Eigen::Ref<const MatX3i>;

// Wraps an optional Python callable(fraction) -> bool|None; None or a truthy result continues.
// Without one, the calls still check for signals, so Ctrl+C stops a long run (on the main thread,
// where Python handles signals) instead of waiting for its end.
inline ProgressFn progress_from(const pb::object& cb) {
  if (cb.is_none()) {
    return [](double) {
      pb::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) throw pb::error_already_set();
      return true;
    };
  }
  // The native side copies the std::function without the GIL (Progress, sub-ranges), and threads
  // may share one callable: hold it through a shared_ptr (atomic count), taken and released
  // under the GIL (some bindings call this inside their NativeScope). Capturing the pb::object by
  // value changed its reference count unlocked: a crash with a callback shared by threads.
  pb::gil_scoped_acquire gil;
  std::shared_ptr<pb::object> fn(new pb::object(cb), [](pb::object* o) {
    pb::gil_scoped_acquire gil;
    delete o;
  });
  return [fn](double fraction) {
    pb::gil_scoped_acquire gil;
    pb::object r = (*fn)(fraction);
    return r.is_none() || static_cast<bool>(pb::bool_(r));  // Python truthiness: False, 0, "" cancel
  };
}

// Native work: the GIL released, and this thread's OpenMP team size set from the process-wide
// count (omp_set_num_threads is per thread: a worker thread kept OpenMP's default).
struct NativeScope {
  pb::gil_scoped_release release;
  NativeScope() { apply_num_threads(); }
};

void bind_core(pb::module_& m);
void bind_crest(pb::module_& m);
void bind_fair(pb::module_& m);
void bind_unwrap(pb::module_& m);
void bind_denoise(pb::module_& m);
void bind_skeletal(pb::module_& m);
void bind_multires(pb::module_& m);
void bind_remesh(pb::module_& m);

}  // namespace dgmesh::py
