// Progress reporting and cancellation for long runs. The callback gets the finished fraction in
// [0, 1] and returns false to cancel, which surfaces as CancelledError with nothing changed.
#pragma once
#include <chrono>
#include <functional>

#include "dgmesh/errors.h"

namespace dgmesh {

using ProgressFn = std::function<bool(double fraction)>;

class Progress {
 public:
  explicit Progress(ProgressFn fn = {}, double min_interval_s = 0.05) : fn_(std::move(fn)), interval_(min_interval_s) {}
  // Calls the callback at most every min_interval seconds (and always at 0 and 1); throws
  // CancelledError when it returns false. Call from one thread only.
  void operator()(double fraction) {
    if (!fn_) return;
    const auto now = std::chrono::steady_clock::now();
    if (fraction > 0 && fraction < 1 && now - last_ < std::chrono::duration<double>(interval_)) return;
    last_ = now;
    if (!fn_(fraction)) throw CancelledError();
  }

 private:
  ProgressFn fn_;
  double interval_;
  std::chrono::steady_clock::time_point last_{};
};

}  // namespace dgmesh
