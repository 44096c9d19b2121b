// The UDF mesher on the device, the GPU side of mesh_udf_cpu.cpp (extract.h, steps 1-7; udf.glsl):
// near children (udf_near), the gradient list (udf_gradient_count, refine_points, the field's
// gradient kernel), pseudo-signed marching cubes with the edge filter (udf_classify), then the
// shared emit_mesh with udf_vertices.comp. The host reads one count between batches.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_udf(Device& device, DeviceNetwork& net, FinestLevel& finest, MeshData* mesh,
                    ExtractStats* stats) {
    const uint32_t k = finest.parents.kept;
    const Level& parents = finest.parents;
    LevelPush push = finest.push;
    push.threshold = udf_near_threshold(push.step);
    push.edge_limit = kUdfEdgeFactor * push.step;

    // Near children and the points that need a gradient.
    Buffers list(*device.vk);
    Buffer *near, *owned, *counts, *offsets;
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &near));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &owned));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &counts));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &offsets));
    std::vector<Bind> near_bindings = child_grid_bindings(parents, finest.grid);
    near_bindings.push_back({NFD_B_NEAR_MASKS, *near});
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
    const uint32_t gradient_count = word(*offsets, k - 1) + word(*counts, k - 1);
    stats->gradients_evaluated += gradient_count;
    device.vk->destroy(*counts);
    // From here on the list holds every value the mesher reads (udf.glsl): the child grids' sparse
    // storage goes (at resolution 1024, ~200 MB for ~2M parents).
    if (!finest.keep) {
        finest.buffers.release();
        device.vk->destroy(*finest.parents.corners);
    }

    // Values and gradients at the list's points (child level 0).
    Buffer* gradients;
    NFD_TRY(list.make(VkDeviceSize(gradient_count) * 16, &gradients));
    PointList gradient_list;
    gradient_list.owned = owned;
    gradient_list.offsets = offsets;
    gradient_list.count = gradient_count;
    {
        Buffers scratch(*device.vk);
        NFD_TRY(device.vk->begin());
        NFD_TRY(record_list(device, net, parents, gradient_list, *gradients, true, push, scratch));
        NFD_TRY(device.vk->submit());
    }

    // Pseudo-signed cases, the edge filter, the vertex edges.
    Classified c(*device.vk);
    NFD_TRY(c.make(k));
    const std::vector<Bind> gradient_bindings = {{NFD_B_GRADIENT_OWNED, *owned},
                                                 {NFD_B_GRADIENT_OFFSETS, *offsets},
                                                 {NFD_B_GRADIENTS, *gradients}};
    std::vector<Bind> classify = level_bindings(parents);
    classify.insert(classify.end(), gradient_bindings.begin(), gradient_bindings.end());
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, device.mc_tables},
                                     {NFD_B_NEAR_MASKS, *near},
                                     {NFD_B_CASES, *c.cases},
                                     {NFD_B_EDGE_MASKS, *c.edge_masks},
                                     {NFD_B_TRIANGLE_COUNTS, *c.triangle_counts},
                                     {NFD_B_ACTIVE, *c.active}});
    {
        Buffers scratch(*device.vk);
        NFD_TRY(device.vk->begin());
        device.vk->fill(*c.edge_masks, 0);
        device.vk->fill(*c.active, 0);
        NFD_TRY(device.vk->dispatch(device[Kernel::UdfClassify], classify, &push, k));
        NFD_TRY(c.record_scans(device, scratch, k));
        NFD_TRY(device.vk->submit());
    }
    device.vk->destroy(*near);
    std::vector<Bind> place = level_bindings(parents);
    place.insert(place.end(), gradient_bindings.begin(), gradient_bindings.end());
    return emit_mesh(device, finest, c, Kernel::UdfVertices, place, list, mesh, stats);
}

}  // namespace nfd::gpu
