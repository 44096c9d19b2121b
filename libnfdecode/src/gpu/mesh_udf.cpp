// The UDF mesher on the device, the GPU side of mesh_udf_cpu.cpp (extract.h, steps 1-7; udf.glsl):
// near children (udf_near), the gradient list (udf_gradient_count, refine_points, the field's
// gradient kernel), pseudo-signed marching cubes with the edge filter (udf_classify), then the
// shared emit_mesh with udf_vertices.comp. Own jobs read the gradient count between batches and
// size the list exactly; a mesh left on the device takes the plan's capacity.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_udf(Job& job, DeviceNetwork& net, FinestLevel& finest, const Plan* plan,
                    MeshTarget target, ExtractStats* stats) {
    Context& vk = *job.device.vk;
    const uint32_t k = finest.parents.capacity;
    const Level& parents = finest.parents;
    LevelPush push = finest.push;
    push.threshold = udf_near_threshold(push.step);
    push.edge_limit = kUdfEdgeFactor * push.step;

    // Near children and the points that need a gradient.
    Buffers list(vk);
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
    PointList gradient_list;
    gradient_list.owned = owned;
    gradient_list.offsets = offsets;
    if (target.device) {
        gradient_list.slot = target.device->gradient_slot;
        gradient_list.capacity = plan->gradient_points;
    } else {
        NFD_TRY(job.new_slot(&gradient_list.slot));
        gradient_list.capacity = UINT32_MAX;  // sized below, once counted
    }
    {
        Buffers scratch(vk);
        NFD_TRY(job.begin());
        job.fill(*counts, 0);
        NFD_TRY(job.dispatch(Kernel::UdfNear, near_bindings, &push, parents.count()));
        NFD_TRY(job.dispatch(Kernel::UdfGradientCount, count_bindings, &push, parents.count()));
        NFD_TRY(record_scan(job, scratch, *counts, *offsets, k, false));
        NFD_TRY(job.total(*counts, *offsets, k, false, gradient_list.slot,
                          gradient_list.capacity));
        NFD_TRY(job.submit());
    }
    if (!target.device) gradient_list.capacity = job.counter(gradient_list.slot);
    if (job.own) stats->gradients_evaluated += job.counter(gradient_list.slot);
    vk.destroy(*counts);
    // From here on the list holds every value the mesher reads (udf.glsl): the child grids' sparse
    // storage goes (at resolution 1024, ~200 MB for ~2M parents).
    if (!finest.keep) {
        finest.buffers.release();
        vk.destroy(*finest.parents.corners);
    }

    // Values and gradients at the list's points (child level 0).
    Buffer* gradients;
    NFD_TRY(list.make(VkDeviceSize(gradient_list.capacity) * 16, &gradients));
    {
        Buffers scratch(vk);
        NFD_TRY(job.begin());
        NFD_TRY(record_list(job, net, parents, gradient_list, *gradients, true, push, scratch));
        NFD_TRY(job.submit());
    }

    // Pseudo-signed cases, the edge filter, the vertex edges.
    Classified c(vk);
    NFD_TRY(job.begin());
    NFD_TRY(c.make(job, k, target.device));
    const std::vector<Bind> gradient_bindings = {{NFD_B_GRADIENT_OWNED, *owned},
                                                 {NFD_B_GRADIENT_OFFSETS, *offsets},
                                                 {NFD_B_GRADIENTS, *gradients}};
    std::vector<Bind> classify = level_bindings(parents);
    classify.insert(classify.end(), gradient_bindings.begin(), gradient_bindings.end());
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, job.device.mc_tables},
                                     {NFD_B_NEAR_MASKS, *near},
                                     {NFD_B_CASES, *c.cases},
                                     {NFD_B_EDGE_MASKS, *c.edge_masks},
                                     {NFD_B_TRIANGLE_COUNTS, *c.triangle_counts},
                                     {NFD_B_ACTIVE, *c.active}});
    NFD_TRY(job.dispatch(Kernel::UdfClassify, classify, &push, parents.count()));
    std::vector<Bind> place = level_bindings(parents);
    place.insert(place.end(), gradient_bindings.begin(), gradient_bindings.end());
    // emit_mesh's first sync runs the classify batch; `near` goes with `list`.
    return emit_mesh(job, finest, c, Kernel::UdfVertices, place, list, target, stats);
}

}  // namespace nfd::gpu
