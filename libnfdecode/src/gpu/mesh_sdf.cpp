// SDF marching cubes on the device, the GPU side of mesh_sdf_cpu.cpp: mc_classify.comp per
// level-1 parent, then the shared emit_mesh with mc_vertices.comp.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_sdf(Device& device, FinestLevel& finest, MeshData* mesh, ExtractStats* stats) {
    const uint32_t k = finest.parents.kept;
    Classified c(*device.vk);
    NFD_TRY(c.make(k));
    Buffers scratch(*device.vk);
    std::vector<Bind> classify = child_grid_bindings(finest.parents, finest.grid);
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, device.mc_tables},
                                     {NFD_B_CASES, *c.cases},
                                     {NFD_B_EDGE_MASKS, *c.edge_masks},
                                     {NFD_B_TRIANGLE_COUNTS, *c.triangle_counts},
                                     {NFD_B_ACTIVE, *c.active}});
    NFD_TRY(device.vk->begin());
    device.vk->fill(*c.active, 0);
    NFD_TRY(device.vk->dispatch(device[Kernel::McClassify], classify, &finest.push, k));
    NFD_TRY(c.record_scans(device, scratch, k));
    NFD_TRY(device.vk->submit());
    return emit_mesh(device, finest, c, Kernel::McVertices,
                     child_grid_bindings(finest.parents, finest.grid), scratch, mesh, stats);
}

}  // namespace nfd::gpu
