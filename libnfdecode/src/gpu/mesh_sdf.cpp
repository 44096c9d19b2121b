// SDF marching cubes on the device, the GPU side of mesh_sdf_cpu.cpp: the mc_classify kernel per
// level-1 parent (unless the level's refinement ran it), then the shared emit_mesh with
// mc_vertices.comp.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_sdf(Job& job, FinestLevel& finest, MeshTarget target, ExtractStats* stats) {
    Buffers scratch(*job.device.vk);
    NFD_TRY(job.begin());
    if (finest.classified.parents == 0) {  // else the level's keep rule classified its parents
        NFD_TRY(finest.classified.make(job, finest.parents.capacity, target.device));
        std::vector<Bind> classify = child_grid_bindings(finest.parents, finest.grid);
        std::vector<Bind> written = finest.classified.classify_bindings();
        classify.insert(classify.end(), written.begin(), written.end());
        // The finest level keeps no children (child level 0): the kernel's keep rule, and the
        // child bitmap it would write, are unused; any buffer fills the binding.
        classify.insert(classify.end(), {{NFD_B_MC_TABLES, job.device.mc_tables},
                                         {NFD_B_CHILD_BITS, job.device.mc_tables}});
        NFD_TRY(job.dispatch(Kernel::McClassify, classify, &finest.push, finest.parents.count()));
    }
    return emit_mesh(job, finest, finest.classified, Kernel::McVertices,
                     child_grid_bindings(finest.parents, finest.grid), scratch, target, stats);
}

}  // namespace nfd::gpu
