// SDF marching cubes on the device, the GPU side of mesh_sdf_cpu.cpp: mc_classify.comp per
// level-1 parent (unless the level's keep rule classified them), then the shared emit_mesh with
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
        classify.push_back({NFD_B_MC_TABLES, job.device.mc_tables});
        NFD_TRY(job.dispatch(Kernel::McClassify, classify, &finest.push, finest.parents.count()));
    }
    return emit_mesh(job, finest, finest.classified, Kernel::McVertices,
                     child_grid_bindings(finest.parents, finest.grid), scratch, target, stats);
}

}  // namespace nfd::gpu
