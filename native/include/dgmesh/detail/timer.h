/// \file
/// Wall-clock timing of the algorithms' stages (reported seconds, time budgets) and an opt-in CPU
/// profile of a call's phases. Not part of the library's interface.
#pragma once
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

namespace dgmesh::detail {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Wall seconds since construction (seconds) or since the previous lap (lap).
class Stopwatch {
 public:
  double seconds() const { return seconds_since(t0_); }
  double lap() {
    const auto t = Clock::now();
    const double s = std::chrono::duration<double>(t - t0_).count();
    t0_ = t;
    return s;
  }

 private:
  Clock::time_point t0_ = Clock::now();
};

/// Process CPU seconds spent in the named phases of one call, summed per name and printed to stderr
/// when the call ends, if the environment variable `env` is set (how the speed work was measured).
/// mark(name) ends the phase `name` (it began at the previous mark).
class Profile {
 public:
  explicit Profile(const char* env) : on_(std::getenv(env) != nullptr) {}
  Profile(const Profile&) = delete;
  Profile& operator=(const Profile&) = delete;
  ~Profile() {
    if (!on_) return;
    for (auto& a : acc_) std::fprintf(stderr, "  %-14s %.3f\n", a.first.c_str(), a.second);
  }
  bool on() const { return on_; }
  void mark(const char* name) {
    if (!on_) return;
    const std::clock_t now = std::clock();
    const double s = double(now - t_) / CLOCKS_PER_SEC;
    t_ = now;
    for (auto& a : acc_)
      if (a.first == name) {
        a.second += s;
        return;
      }
    acc_.emplace_back(name, s);
  }

 private:
  bool on_;
  std::clock_t t_ = std::clock();
  std::vector<std::pair<std::string, double>> acc_;
};

/// The profile of the call running on this thread (null when profiling is off), so that helpers
/// deep in the call (a linear solver) can mark phases.
inline thread_local Profile* current_profile = nullptr;

inline void profile_mark(const char* name) {
  if (current_profile) current_profile->mark(name);
}

/// Profiles the enclosing call (a public entry point) on this thread.
class ProfileScope {
 public:
  explicit ProfileScope(const char* env) : prof_(env) { current_profile = prof_.on() ? &prof_ : nullptr; }
  ProfileScope(const ProfileScope&) = delete;
  ProfileScope& operator=(const ProfileScope&) = delete;
  ~ProfileScope() { current_profile = nullptr; }

 private:
  Profile prof_;
};

}  // namespace dgmesh::detail
