// Thread count for the OpenMP loops (the add-on's preference); 0 means all cores.
#pragma once

namespace dgmesh {
void set_num_threads(int n);
int num_threads();
// This thread's index inside a parallel region (0 outside one): per-thread scratch slots.
int thread_index();
}  // namespace dgmesh
