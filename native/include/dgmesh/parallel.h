// Thread count for the OpenMP loops (the add-on's preference); 0 means all cores.
#pragma once

namespace dgmesh {
// The count is process-wide; OpenMP's own setting is per thread, so entry points running native
// work call apply_num_threads() on their thread (the Python bindings do, in NativeScope).
void set_num_threads(int n);
int num_threads();
void apply_num_threads();
// This thread's index inside a parallel region (0 outside one): per-thread scratch slots.
int thread_index();
// Loops over fewer items than this run serially (`#pragma omp parallel for if (n >= kParallelMin)`):
// for light per-item work on a busy 2-core machine, waking OpenMP threads and libgomp's
// spin-waiting cost more than the loop (measured: 20-25 ms of an 8K-vertex unwrap call).
constexpr int kParallelMin = 16384;
}  // namespace dgmesh
