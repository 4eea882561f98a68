// Thread count for the OpenMP loops (the add-on's preference); 0 means all cores.
#pragma once

#include <algorithm>
#include <array>
#include <vector>

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

// Sums over i in [0, n) that do not depend on the thread count or on the order threads finish:
// add(i, acc) adds item i's terms into acc (K sums), fixed blocks of kSumBlock items are summed
// serially and the block sums then in order. An OpenMP reduction(+) splits the items by thread
// count, and with 3 or more threads libgomp adds the partial sums in finishing order, so a
// floating-point result (and any stopping test reading it) changed from run to run.
constexpr int kSumBlock = 4096;
template <int K, class Add>
std::array<double, K> ordered_sums(int n, bool parallel, Add&& add) {
  const int nb = (n + kSumBlock - 1) / kSumBlock;
  auto block = [&](int b) {
    std::array<double, K> s{};
    for (int i = b * kSumBlock, end = std::min(n, i + kSumBlock); i < end; ++i) add(i, s);
    return s;
  };
  std::array<double, K> total{};
  auto add_block = [&](const std::array<double, K>& s) {
    for (int k = 0; k < K; ++k) total[k] += s[k];
  };
  if (parallel && nb > 1) {
    std::vector<std::array<double, K>> part(nb);
#pragma omp parallel for schedule(static)
    for (int b = 0; b < nb; ++b) part[b] = block(b);
    for (const auto& s : part) add_block(s);
  } else {
    // Serial: the same block sums in the same order, without the buffer (the multigrid solver's dot
    // products call this several times an iteration).
    for (int b = 0; b < nb; ++b) add_block(block(b));
  }
  return total;
}
}  // namespace dgmesh
