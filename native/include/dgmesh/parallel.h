// Thread count for the OpenMP loops (the add-on's preference); 0 means all cores.
#pragma once

namespace dgmesh {
void set_num_threads(int n);
int num_threads();
}  // namespace dgmesh
