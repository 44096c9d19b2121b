// The back half of both GPU meshers (levels.h, emit_mesh), as marching.h is on the CPU: welded
// vertices numbered by owner (mc.glsl), triangles per parent, children and table order within.
#include <new>

#include "levels.h"

namespace nfd::gpu {

nfd_result Classified::make(uint32_t parents) {
    const VkDeviceSize k = parents;
    NFD_TRY(buffers.make(k * 16, &cases));
    NFD_TRY(buffers.make(k * 8, &edge_masks));
    NFD_TRY(buffers.make(k * 8, &vertex_offsets));
    NFD_TRY(buffers.make(k * 4, &triangle_counts));
    NFD_TRY(buffers.make(k * 4, &triangle_offsets));
    return buffers.make(4, &active);
}

nfd_result Classified::record_scans(Device& device, Buffers& scratch, uint32_t parents) {
    NFD_TRY(record_scan(device, scratch, *edge_masks, *vertex_offsets, 2 * parents, true));
    return record_scan(device, scratch, *triangle_counts, *triangle_offsets, parents, false);
}

nfd_result emit_mesh(Device& device, FinestLevel& finest, Classified& c, Kernel vertices,
                     std::vector<Bind> inputs, Buffers& input_buffers, MeshData* mesh,
                     ExtractStats* stats) {
    const uint32_t k = finest.parents.kept;
    const uint32_t vertex_count = word(*c.vertex_offsets, 2 * k - 1) +
                                  uint32_t(__builtin_popcount(word(*c.edge_masks, 2 * k - 1)));
    const uint32_t triangles = word(*c.triangle_offsets, k - 1) + word(*c.triangle_counts, k - 1);
    stats->active_cells = word(*c.active, 0);
    device.vk->destroy(*c.triangle_counts);

    // Peak memory: each batch makes its outputs once the previous one's inputs are gone, and the
    // read-back frees each device buffer as soon as it is copied.
    Buffers out(*device.vk);
    Buffer *edges, *positions, *normals, *indices;
    NFD_TRY(out.make(VkDeviceSize(vertex_count) * 4, &edges));
    NFD_TRY(out.make(VkDeviceSize(triangles) * 12, &indices));
    std::vector<Bind> emit = level_bindings(finest.parents);
    emit.insert(emit.end(), {{NFD_B_MC_TABLES, device.mc_tables},
                             {NFD_B_CASES, *c.cases},
                             {NFD_B_EDGE_MASKS, *c.edge_masks},
                             {NFD_B_VERTEX_OFFSETS, *c.vertex_offsets},
                             {NFD_B_TRIANGLE_OFFSETS, *c.triangle_offsets},
                             {NFD_B_VERTEX_EDGES, *edges},
                             {NFD_B_INDICES, *indices}});
    NFD_TRY(device.vk->begin());
    NFD_TRY(device.vk->dispatch(device[Kernel::McEmit], emit, &finest.push, k));
    NFD_TRY(device.vk->submit());
    c.buffers.release();

    NFD_TRY(out.make(VkDeviceSize(vertex_count) * 12, &positions));
    NFD_TRY(out.make(VkDeviceSize(vertex_count) * 12, &normals));
    std::vector<Bind> place = std::move(inputs);
    place.insert(place.end(), {{NFD_B_VERTEX_EDGES, *edges},
                               {NFD_B_POSITIONS, *positions},
                               {NFD_B_NORMALS, *normals}});
    LevelPush per_vertex = finest.push;
    per_vertex.count = vertex_count;
    NFD_TRY(device.vk->begin());
    NFD_TRY(device.vk->dispatch(device[vertices], place, &per_vertex, vertex_count));
    NFD_TRY(device.vk->submit());
    input_buffers.release();
    if (!finest.keep) {
        finest.buffers.release();
        finest.parents.buffers.release();
    }
    device.vk->destroy(*edges);

    try {
        auto take = [&](Buffer* b, auto* begin, size_t count, auto* out_vector) {
            out_vector->assign(begin, begin + count);
            device.vk->destroy(*b);
        };
        take(indices, indices->as<uint32_t>(), 3 * size_t(triangles), &mesh->indices);
        take(positions, positions->as<float>(), 3 * size_t(vertex_count), &mesh->positions);
        take(normals, normals->as<float>(), 3 * size_t(vertex_count), &mesh->normals);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
