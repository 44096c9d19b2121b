// The UDF mesher on the device, the GPU side of mesh_udf_cpu.cpp (extract.h, steps 1-7; udf.glsl):
// near children (udf_near), the gradient list (udf_gradient_count, refine_points, the field's
// gradient kernel), pseudo-signed marching cubes with the edge filter (udf_classify), then the
// shared emit_mesh with udf_vertices.comp. Three batches; the host reads two counts.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_udf(Device& device, DeviceNetwork& net, FinestLevel& finest, MeshData* mesh,
                    ExtractStats* stats) {
    const uint32_t k = finest.parents.kept;
    const Level& parents = finest.parents;
    LevelPush push = finest.push;
    push.threshold = udf_near_threshold(push.step);
    push.edge_limit = kUdfEdgeFactor * push.step;
    Classified c(*device.vk);
    NFD_TRY(c.make(k));

    // Near children and the points that need a gradient.
    Buffers list(*device.vk);
    Buffer *near, *owned, *counts, *offsets;
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &near));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &owned));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &counts));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &offsets));
    std::vector<Bind> near_bindings = level_bindings(parents);
    near_bindings.insert(near_bindings.end(), {{NFD_B_CORNERS, *parents.corners},
                                               {NFD_B_OWNED, *finest.grid.owned},
                                               {NFD_B_OFFSETS, *finest.grid.offsets},
                                               {NFD_B_VALUES, *finest.grid.values},
                                               {NFD_B_CHILD_GRIDS, *c.child_grids},
                                               {NFD_B_NEAR_MASKS, *near}});
    std::vector<Bind> count_bindings = level_bindings(parents);
    count_bindings.insert(count_bindings.end(), {{NFD_B_NEAR_MASKS, *near},
                                                 {NFD_B_GRADIENT_OWNED, *owned},
                                                 {NFD_B_COUNTS, *counts}});
    {
        Buffers scratch(*device.vk);
        NFD_TRY(device.vk->begin());
        NFD_TRY(device.vk->dispatch(device[Kernel::UdfNear], near_bindings, &push, k));
        NFD_TRY(device.vk->dispatch(device[Kernel::UdfGradientCount], count_bindings, &push, k));
        NFD_TRY(record_scan(device, scratch, *counts, *offsets, k, false));
        NFD_TRY(device.vk->submit());
    }
    // The child grids hold every value from here on (as in mesh_sdf).
    finest.buffers.release();
    device.vk->destroy(*finest.parents.corners);
    const uint32_t gradient_count = word(*offsets, k - 1) + word(*counts, k - 1);
    stats->gradients_evaluated = gradient_count;
    device.vk->destroy(*counts);

    // Gradients, then the pseudo-signed cases, the edge filter and the vertex edges.
    Buffer *points, *gradients;
    NFD_TRY(list.make(VkDeviceSize(gradient_count) * 12, &points));
    NFD_TRY(list.make(VkDeviceSize(gradient_count) * 16, &gradients));
    std::vector<Bind> classify = level_bindings(parents);
    const std::vector<Bind> gradient_bindings = {{NFD_B_GRADIENT_OWNED, *owned},
                                                 {NFD_B_GRADIENT_OFFSETS, *offsets},
                                                 {NFD_B_GRADIENTS, *gradients}};
    classify.insert(classify.end(), gradient_bindings.begin(), gradient_bindings.end());
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, device.mc_tables},
                                     {NFD_B_CHILD_GRIDS, *c.child_grids},
                                     {NFD_B_NEAR_MASKS, *near},
                                     {NFD_B_CASES, *c.cases},
                                     {NFD_B_EDGE_MASKS, *c.edge_masks},
                                     {NFD_B_TRIANGLE_COUNTS, *c.triangle_counts},
                                     {NFD_B_ACTIVE, *c.active}});
    {
        Buffers scratch(*device.vk);
        NFD_TRY(device.vk->begin());
        // refine_points lists any point list: here the gradient points, at child level 0.
        NFD_TRY(device.vk->dispatch(device[Kernel::RefinePoints],
                                    {{NFD_B_KEPT_CELLS, *parents.list},
                                     {NFD_B_OWNED, *owned},
                                     {NFD_B_OFFSETS, *offsets},
                                     {NFD_B_POINTS, *points}},
                                    &push, k));
        NFD_TRY(record_field(device, net, *points, *gradients, gradient_count, true));
        device.vk->fill(*c.edge_masks, 0);
        device.vk->fill(*c.active, 0);
        NFD_TRY(device.vk->dispatch(device[Kernel::UdfClassify], classify, &push, k));
        NFD_TRY(c.record_scans(device, scratch, k));
        NFD_TRY(device.vk->submit());
    }
    device.vk->destroy(*points);
    device.vk->destroy(*near);
    return emit_mesh(device, finest, c, Kernel::UdfVertices, gradient_bindings, mesh, stats);
}

}  // namespace nfd::gpu
