// The UDF mesher on the device, the GPU side of mesh_udf_cpu.cpp (extract.h, steps 1-7; udf.glsl):
// near children (udf_near, or after surface following the flood's faces mode), the gradient list
// (udf_gradient_count, refine_points, the field's gradient kernel; udf_gradient_merge where the
// level above's list or the level's predicted list has some of its points),
// pseudo-signed marching cubes with the edge filter (udf_classify), then the
// shared emit_mesh with udf_vertices.comp. Own jobs read the gradient count between batches and
// size the list exactly; a mesh left on the device takes the plan's capacity.
#include "levels.h"

namespace nfd::gpu {

nfd_result mesh_udf(Job& job, DeviceNetwork& net, FinestLevel& finest, const Plan* plan,
                    MeshTarget target, ExtractStats* stats, GradientCarry carried) {
    Context& vk = *job.device.vk;
    const uint32_t k = finest.parents.capacity;
    const Level& parents = finest.parents;
    LevelPush push = finest.push;
    push.edge_limit = udf_edge_limit(push.step);
    const CarriedGradients* above =
        carried.above && carried.above->corners ? carried.above : nullptr;
    const PointList* predicted = finest.predicted.owned ? &finest.predicted : nullptr;
    // No such callers: recordings are one-shot and size nothing by read-backs.
    if ((above || predicted) && !job.own) return NFD_ERROR_INTERNAL;
    const bool copies = above || predicted;

    // Near children and the points that need a gradient; with `above`, those it lacks (`fresh`).
    Buffers list(vk);
    // The coarsest level: its gradients from the host, as its values (HostTop).
    Buffer* top_gradient_values = nullptr;
    if (finest.top.values)
        NFD_TRY(top_gradients(finest.top, push.step, list, &top_gradient_values));
    Buffers& kept = carried.carry ? carried.carry->buffers : list;
    Buffer *near, *owned, *offsets, *fresh_owned = nullptr, *fresh_offsets = nullptr;
    // The flood (the finest level) or the keep rule (a meshed level above it) found the near
    // children; otherwise udf_near below.
    near = finest.near;
    if (!near) NFD_TRY(list.make(VkDeviceSize(k) * 4, &near));
    NFD_TRY(kept.make(VkDeviceSize(k) * 4, &owned));
    NFD_TRY(kept.make(VkDeviceSize(k) * 4, &offsets));
    if (copies) {
        NFD_TRY(list.make(VkDeviceSize(k) * 4, &fresh_owned));
        NFD_TRY(list.make(VkDeviceSize(k) * 4, &fresh_offsets));
    }
    std::vector<Bind> near_bindings = child_grid_bindings(parents, finest.grid);
    near_bindings.insert(near_bindings.end(),
                         {{NFD_B_MC_TABLES, job.device.mc_tables}, {NFD_B_NEAR_MASKS, *near}});
    std::vector<Bind> predicted_bindings;
    if (predicted)
        predicted_bindings = {{NFD_B_PREDICTED_OWNED, *predicted->owned},
                              {NFD_B_PREDICTED_OFFSETS, *predicted->offsets},
                              {NFD_B_PREDICTED, *predicted->values}};
    // Above the finest level the predicted values are in the grid too (udf_predict.comp's join).
    const bool split = predicted && !finest.keep;
    if (split)
        near_bindings.insert(near_bindings.end(), predicted_bindings.begin(),
                             predicted_bindings.end());
    std::vector<Bind> count_bindings = level_bindings(parents);
    // Without `above` (no tally_slot) no corner index is read: that role is bound to the masks.
    count_bindings.insert(count_bindings.end(),
                          {{NFD_B_NEAR_MASKS, *near},
                           {NFD_B_GRADIENT_OWNED, *owned},
                           {NFD_B_OWNED, copies ? *fresh_owned : *owned},
                           {NFD_B_CORNER_GRADIENTS, above ? *above->corners : *owned}});
    if (predicted) count_bindings.push_back(predicted_bindings[0]);
    PointList gradient_list, fresh_list;
    gradient_list.owned = owned;
    gradient_list.offsets = offsets;
    fresh_list.owned = fresh_owned;
    fresh_list.offsets = fresh_offsets;
    if (target.device) {
        gradient_list.slot = target.device->gradient_slot;
        gradient_list.capacity = plan->gradient_points;
    } else {
        NFD_TRY(job.new_slot(&gradient_list.slot));
        gradient_list.capacity = UINT32_MAX;  // sized below, once counted
        if (copies) {
            NFD_TRY(job.new_slot(&fresh_list.slot));
            fresh_list.capacity = UINT32_MAX;
        }
        if (above) NFD_TRY(job.new_slot(&push.tally_slot));
    }
    // The near cells' list for udf_classify (one invocation per near cell), sized by the prefix
    // of the near masks' popcounts: own jobs read its total, recordings take 8 per parent.
    Buffer *near_prefix, *near_cells;
    uint32_t near_slot;
    NFD_TRY(job.new_slot(&near_slot));
    NFD_TRY(list.make(VkDeviceSize(k) * 4, &near_prefix));
    {
        Buffers scratch(vk);
        NFD_TRY(job.begin());
        job.fill(*owned, 0);  // the scans and totals run on the capacity
        if (copies) job.fill(*fresh_owned, 0);
        if (!finest.near) {
            job.fill(*near, 0);  // and so does the near cells' list
            NFD_TRY(job.dispatch(split ? Kernel::UdfNearPredicted : Kernel::UdfNear,
                                 near_bindings, &push, parents.count()));
        }
        NFD_TRY(job.dispatch(
            predicted ? Kernel::UdfGradientCountPredicted : Kernel::UdfGradientCount,
            count_bindings, &push, parents.count()));
        NFD_TRY(record_scan(job, scratch, *owned, *offsets, k, true));
        NFD_TRY(job.total(*owned, *offsets, k, true, gradient_list.slot, gradient_list.capacity));
        NFD_TRY(record_scan(job, scratch, *near, *near_prefix, k, true));
        NFD_TRY(job.total(*near, *near_prefix, k, true, near_slot, 8 * k));
        if (copies) {
            NFD_TRY(record_scan(job, scratch, *fresh_owned, *fresh_offsets, k, true));
            NFD_TRY(job.total(*fresh_owned, *fresh_offsets, k, true, fresh_list.slot,
                              fresh_list.capacity));
        }
        NFD_TRY(job.submit());
    }
    if (!target.device) gradient_list.capacity = job.counter(gradient_list.slot);
    const Count near_count{target.device ? 8 * k : job.counter(near_slot), near_slot};
    if (copies) fresh_list.capacity = job.counter(fresh_list.slot);
    // The points of the list not copied from the level above, as on the CPU (predicted ones
    // included: the finest level's value pass evaluated their gradients, and ~13% more).
    if (job.own)
        stats->gradients_evaluated +=
            gradient_list.capacity - (above ? job.counter(push.tally_slot) : 0u);
    // From here on the list holds every value the mesher reads (udf.glsl): the child grids' sparse
    // storage goes (at resolution 1024, ~200 MB for ~2M parents).
    if (!finest.keep) {
        finest.buffers.release();
        finest.top = HostTop();
        vk.destroy(*finest.parents.corners);
    }

    // Values and gradients at the list's points (child level 0): evaluated, or with `above`
    // evaluated where it lacks them and copied where it has them.
    Buffer* gradients;
    NFD_TRY(kept.make(VkDeviceSize(gradient_list.capacity) * 16, &gradients));
    {
        Buffers scratch(vk);
        NFD_TRY(job.begin());
        if (copies) {
            Buffer* fresh;
            NFD_TRY(scratch.make(VkDeviceSize(fresh_list.capacity) * 16, &fresh));
            NFD_TRY(record_list(job, net, parents, fresh_list, *fresh, true, push, scratch));
            // Without `above` its two roles are bound to other lists, unused.
            std::vector<Bind> merge = {{NFD_B_GRADIENT_OWNED, *owned},
                                       {NFD_B_GRADIENT_OFFSETS, *offsets},
                                       {NFD_B_GRADIENTS, *gradients},
                                       {NFD_B_OWNED, *fresh_owned},
                                       {NFD_B_OFFSETS, *fresh_offsets},
                                       {NFD_B_FRESH_GRADIENTS, *fresh},
                                       {NFD_B_CORNER_GRADIENTS, above ? *above->corners : *owned},
                                       {NFD_B_ABOVE_GRADIENTS, above ? *above->gradients : *fresh}};
            merge.insert(merge.end(), predicted_bindings.begin(), predicted_bindings.end());
            NFD_TRY(job.dispatch(
                predicted ? Kernel::UdfGradientMergePredicted : Kernel::UdfGradientMerge, merge,
                &push, parents.count()));
        } else {
            NFD_TRY(record_list(job, net, parents, gradient_list, *gradients, true, push, scratch,
                                top_gradient_values));
        }
        NFD_TRY(job.submit());
    }
    finest.predicted_buffers.release();
    finest.predicted = PointList();
    if (carried.carry) {
        CarriedGradients& c = *carried.carry;
        c.owned = owned;
        c.offsets = offsets;
        c.gradients = gradients;
    }

    // Pseudo-signed cases, the edge filter, the vertex edges.
    Classified c(vk);
    NFD_TRY(job.begin());
    NFD_TRY(c.make(job, k, target.device));
    const std::vector<Bind> gradient_bindings = {{NFD_B_GRADIENT_OWNED, *owned},
                                                 {NFD_B_GRADIENT_OFFSETS, *offsets},
                                                 {NFD_B_GRADIENTS, *gradients}};
    NFD_TRY(list.make(VkDeviceSize(std::max(near_count.capacity, 1u)) * 4, &near_cells));
    const uint32_t words = k;
    NFD_TRY(job.dispatch(Kernel::BitmapCompact,
                         {{NFD_B_KEPT_BITS, *near},
                          {NFD_B_KEPT_PREFIX, *near_prefix},
                          {NFD_B_KEPT_CELLS, *near_cells}},
                         &words, Count{words}));
    job.fill(*c.cases, 0);  // each near cell ors its bytes in; a parent's others stay 0
    std::vector<Bind> classify = level_bindings(parents);
    classify.insert(classify.end(), gradient_bindings.begin(), gradient_bindings.end());
    std::vector<Bind> written = c.classify_bindings();
    classify.insert(classify.end(), written.begin(), written.end());
    classify.insert(classify.end(), {{NFD_B_MC_TABLES, job.device.mc_tables},
                                     {NFD_B_NEAR_CELLS, *near_cells}});
    LevelPush per_cell = push;
    per_cell.set(near_count);
    NFD_TRY(job.dispatch(Kernel::UdfClassify, classify, &per_cell, near_count));
    std::vector<Bind> place = level_bindings(parents);
    place.insert(place.end(), gradient_bindings.begin(), gradient_bindings.end());
    // emit_mesh's first sync runs the classify batch; `near` goes with `list`.
    return emit_mesh(job, finest, c, Kernel::UdfVertices, place, list, target, stats);
}

}  // namespace nfd::gpu
