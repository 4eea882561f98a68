#include "dgmesh/parallel.h"

#include <atomic>

#include <dlfcn.h>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace dgmesh {
namespace {
std::atomic<int> g_threads{-1};  // -1: never set (OpenMP's default: OMP_NUM_THREADS or all cores)

// CHOLMOD's supernodal factorisation and UMFPACK's fronts run in the BLAS, which keeps a thread
// pool of its own (OpenBLAS: every core, whatever OpenMP is told). Looked up at run time, so any
// BLAS links; one without this entry point is left as it is.
#if defined(DGMESH_STATIC_OPENBLAS)
// The portable package (packaging/) links its own OpenBLAS, hidden: dlsym would find another
// process-wide one (Blender's) or none, so call ours directly.
extern "C" void openblas_set_num_threads(int);
void set_blas_threads(int n) { openblas_set_num_threads(n); }
#else
void set_blas_threads(int n) {
  using SetFn = void (*)(int);
  static const auto fn = reinterpret_cast<SetFn>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (fn) fn(n);
}
#endif
}  // namespace

void set_num_threads(int n) {
#ifdef _OPENMP
  g_threads = n > 0 ? n : omp_get_num_procs();
  set_blas_threads(g_threads);
  apply_num_threads();
#else
  (void)n;
#endif
}

void apply_num_threads() {
#ifdef _OPENMP
  const int n = g_threads;
  if (n > 0 && omp_get_max_threads() != n) omp_set_num_threads(n);
#endif
}

int num_threads() {
#ifdef _OPENMP
  const int n = g_threads;
  return n > 0 ? n : omp_get_max_threads();
#else
  return 1;
#endif
}

int thread_index() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

}  // namespace dgmesh
