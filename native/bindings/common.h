// Shared helpers of the pybind11 module: numpy <-> Eigen without copies where the layout allows,
// progress callbacks that take the GIL, and the per-capability bind functions.
#pragma once
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

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

// A numpy view of an Eigen array or a std::vector of numbers held by a bound object: no copy,
// writable, and it keeps `owner` alive.
template <class Scalar, int Rows, int Cols, int Options>
pb::array array_view(Eigen::Matrix<Scalar, Rows, Cols, Options>& a, const pb::handle& owner) {
  if (Cols == 1) return pb::array_t<Scalar>({a.rows()}, {sizeof(Scalar)}, a.data(), owner);
  const auto r = static_cast<pb::ssize_t>(a.rowStride() * sizeof(Scalar));
  const auto c = static_cast<pb::ssize_t>(a.colStride() * sizeof(Scalar));
  return pb::array_t<Scalar>({a.rows(), a.cols()}, {r, c}, a.data(), owner);
}
template <class T, class = std::enable_if_t<std::is_arithmetic_v<T>>>
pb::array array_view(std::vector<T>& a, const pb::handle& owner) {
  return pb::array_t<T>({static_cast<pb::ssize_t>(a.size())}, {sizeof(T)}, a.data(), owner);
}

// std::vector<char> holds flags (masks): a numpy bool view.
inline pb::array array_view(std::vector<char>& a, const pb::handle& owner) {
  return pb::array_t<bool>({static_cast<pb::ssize_t>(a.size())}, {sizeof(char)}, reinterpret_cast<bool*>(a.data()),
                           owner);
}

// A field's value from Python (replace()): flags from anything numpy reads as bool, the rest by
// pybind11's casters (arrays converted to the field's type).
template <class M>
M from_python(const pb::handle& v) {
  if constexpr (std::is_same_v<M, std::vector<char>>) {
    const auto a = pb::array_t<bool, pb::array::c_style | pb::array::forcecast>::ensure(v);
    if (!a || a.ndim() != 1) throw pb::type_error("expected a one-dimensional array of booleans");
    return M(a.data(), a.data() + a.size());
  } else {
    return v.cast<M>();
  }
}

template <class M, class = void>
struct is_array_field : std::false_type {};
template <class M>
struct is_array_field<M, std::void_t<decltype(array_view(std::declval<M&>(), pb::handle()))>> : std::true_type {};

// Binds an options or result struct once, so Python sees the C++ contract itself: a default
// constructor (the C++ initialisers are the defaults), the fields in order in `__fields__`, a
// repr listing them, equality by fields, and `replace(**fields)`: a copy with some fields changed
// (as dataclasses.replace; how Python code derives a result from another). Options fields are
// read/write (a wrong type raises TypeError); result fields are read-only, arrays as writable
// numpy views without a copy.
//   Struct<DenoiseOptions>(m, "DenoiseOptions", "...").field("eta1", &DenoiseOptions::eta1, "...");
template <class T>
class Struct {
 public:
  Struct(pb::module_& m, const char* name, const char* doc) : cls_(m, name, doc) {
    cls_.def(pb::init<>());
    cls_.attr("__fields__") = names_;
    cls_.def("__repr__", [](const pb::object& self) {
      std::string s = pb::str(pb::type::handle_of(self).attr("__name__")).cast<std::string>() + "(";
      bool first = true;
      for (const auto& f : self.attr("__fields__")) {
        if (!first) s += ", ";
        first = false;
        const pb::object v = self.attr(f);
        s += f.cast<std::string>() + "=";
        if (pb::isinstance<pb::array>(v) && pb::array(v).size() > 8)  // arrays by shape and type
          s += "<" + pb::str(v.attr("dtype")).cast<std::string>() + " " + pb::str(v.attr("shape")).cast<std::string>() +
               ">";
        else
          s += pb::repr(v).cast<std::string>();
      }
      return s + ")";
    });
    cls_.def("__eq__", [](const pb::object& self, const pb::object& other) {
      if (!pb::type::handle_of(other).is(pb::type::handle_of(self))) return false;
      for (const auto& f : self.attr("__fields__"))
        if (!pb::module_::import("numpy").attr("array_equal")(self.attr(f), other.attr(f)).cast<bool>()) return false;
      return true;
    });
    cls_.attr("__hash__") = pb::none();
    cls_.def(
        "replace",
        [setters = setters_](const T& self, const pb::kwargs& changes) {
          T copy = self;
          for (const auto& item : changes) {
            const auto name = pb::cast<std::string>(item.first);
            const auto it = setters->find(name);
            if (it == setters->end()) throw pb::type_error("replace(): no field '" + name + "'");
            it->second(copy, item.second);
          }
          return copy;
        },
        "A copy with the given fields changed");
  }

  // A read/write field (options).
  template <class M>
  Struct& field(const char* name, M T::*pm, const char* doc) {
    add_setter(name, pm);
    if constexpr (is_array_field<M>::value) {
      cls_.def_property(
          name, [pm](const pb::object& self) { return array_view(self.cast<T&>().*pm, self); },
          [pm](T& t, const M& v) { t.*pm = v; }, doc);
    } else {
      cls_.def_readwrite(name, pm, doc);
    }
    names_.append(name);
    return *this;
  }

  // A read-only field (results): arrays are numpy views into the object.
  template <class M>
  Struct& result(const char* name, M T::*pm, const char* doc) {
    add_setter(name, pm);
    if constexpr (is_array_field<M>::value) {
      cls_.def_property_readonly(
          name, [pm](const pb::object& self) { return array_view(self.cast<T&>().*pm, self); }, doc);
    } else {
      cls_.def_readonly(name, pm, doc);
    }
    names_.append(name);
    return *this;
  }

  pb::class_<T>& cls() { return cls_; }

 private:
  using Setters = std::map<std::string, std::function<void(T&, const pb::handle&)>>;

  template <class M>
  void add_setter(const char* name, M T::*pm) {
    (*setters_)[name] = [pm](T& t, const pb::handle& v) { t.*pm = from_python<M>(v); };
  }

  pb::class_<T> cls_;
  pb::list names_;  // the same list object as __fields__
  std::shared_ptr<Setters> setters_ = std::make_shared<Setters>();
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
