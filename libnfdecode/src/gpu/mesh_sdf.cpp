// SDF marching cubes on the device, the GPU side of mesh_sdf_cpu.cpp: mc_classify.comp per
// level-1 parent, then the shared emit_mesh with mc_vertices.comp.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_sdf(Job& job, FinestLevel& finest, MeshTarget target, ExtractStats* stats) {
    Classified c(*job.device.vk);
    NFD_TRY(job.begin());
    NFD_TRY(c.make(job, finest.parents.capacity, target.device));
    Buffers scratch(*job.device.vk);
    std::vector<Bind> classify = child_grid_bindings(finest.parents, finest.grid);
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, job.device.mc_tables},
                                     {NFD_B_CASES, *c.cases},
                                     {NFD_B_EDGE_MASKS, *c.edge_masks},
                                     {NFD_B_TRIANGLE_COUNTS, *c.triangle_counts},
                                     {NFD_B_ACTIVE, *c.active}});
    NFD_TRY(job.dispatch(Kernel::McClassify, classify, &finest.push, finest.parents.count()));
    return emit_mesh(job, finest, c, Kernel::McVertices,
                     child_grid_bindings(finest.parents, finest.grid), scratch, target, stats);
}

}  // namespace nfd::gpu
