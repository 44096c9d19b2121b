// The back half of both GPU meshers (levels.h, emit_mesh), as marching.h is on the CPU: welded
// vertices numbered by owner (mc.glsl), triangles per parent, children and table order within.
#include <algorithm>
#include <new>

#include "levels.h"

namespace nfd::gpu {

nfd_result DeviceMesh::make() {
    NFD_TRY(buffers.make(VkDeviceSize(vertex_capacity) * 12, &positions));
    NFD_TRY(buffers.make(VkDeviceSize(vertex_capacity) * 12, &normals));
    NFD_TRY(buffers.make(VkDeviceSize(triangle_capacity) * 12, &indices));
    return buffers.make(20, &draw);  // VkDrawIndexedIndirectCommand
}

nfd_result Classified::make(Job& job, uint32_t k, DeviceMesh* device) {
    parents = k;
    NFD_TRY(buffers.make(VkDeviceSize(k) * 16, &cases));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 8, &edge_masks));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 8, &vertex_offsets));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &triangle_counts));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &triangle_offsets));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &emitting));
    NFD_TRY(buffers.make(VkDeviceSize(k) * 4, &emitting_offsets));
    if (device) emitting_slot = device->emitting_slot;
    else NFD_TRY(job.new_slot(&emitting_slot));
    // The scans run over the capacity: what no parent writes must be zero.
    job.fill(*edge_masks, 0);
    job.fill(*triangle_counts, 0);
    job.fill(*emitting, 0);
    return NFD_SUCCESS;
}

std::vector<Bind> Classified::classify_bindings() const {
    return {{NFD_B_CASES, *cases},
            {NFD_B_EDGE_MASKS, *edge_masks},
            {NFD_B_TRIANGLE_COUNTS, *triangle_counts},
            {NFD_B_EMITTING, *emitting}};
}

nfd_result Classified::record_scans(Job& job, Buffers& scratch, uint32_t vertex_slot,
                                    uint32_t vertex_capacity, uint32_t triangle_slot,
                                    uint32_t triangle_capacity) {
    NFD_TRY(record_scan(job, scratch, *edge_masks, *vertex_offsets, 2 * parents, true));
    NFD_TRY(record_scan(job, scratch, *triangle_counts, *triangle_offsets, parents, false));
    NFD_TRY(record_scan(job, scratch, *emitting, *emitting_offsets, parents, true));
    NFD_TRY(job.total(*emitting, *emitting_offsets, parents, true, emitting_slot,
                      emitting_capacity(triangle_capacity)));
    NFD_TRY(job.total(*edge_masks, *vertex_offsets, 2 * parents, true, vertex_slot,
                      vertex_capacity));
    return job.total(*triangle_counts, *triangle_offsets, parents, false, triangle_slot,
                     triangle_capacity);
}

nfd_result emit_mesh(Job& job, FinestLevel& finest, Classified& c, Kernel vertices,
                     std::vector<Bind> inputs, Buffers& input_buffers, MeshTarget target,
                     ExtractStats* stats) {
    Context& vk = *job.device.vk;
    DeviceMesh* device = target.device;
    // Own jobs read the sizes here, between the classify and emit batches, and make exact
    // buffers (peak memory); a mesh left on the device has its capacities.
    uint32_t vertex_count, triangles, vertex_slot, triangle_slot;
    if (device) {
        vertex_count = device->vertex_capacity;
        triangles = device->triangle_capacity;
        vertex_slot = device->vertex_slot;
        triangle_slot = device->triangle_slot;
    } else {
        NFD_TRY(job.new_slot(&vertex_slot));
        NFD_TRY(job.new_slot(&triangle_slot));
    }
    Buffers scratch(vk);
    NFD_TRY(c.record_scans(job, scratch, vertex_slot, device ? vertex_count : UINT32_MAX,
                           triangle_slot, device ? triangles : UINT32_MAX));
    uint32_t emitting = device ? c.emitting_capacity(triangles) : 0;
    if (!device) {
        NFD_TRY(job.sync());
        vertex_count = job.counter(vertex_slot);
        triangles = job.counter(triangle_slot);
        emitting = job.counter(c.emitting_slot);
        stats->active_cells = emitting;  // the cells that emitted a triangle
    }
    scratch.release();
    vk.destroy(*c.triangle_counts);

    // Peak memory: each batch makes its outputs once the previous one's inputs are gone, and the
    // read-back frees each device buffer as soon as it is copied.
    Buffers out(vk);
    Buffer *edges, *positions, *normals, *indices, *cells;
    NFD_TRY(out.make(VkDeviceSize(vertex_count) * 4, &edges));
    NFD_TRY(out.make(VkDeviceSize(std::max(emitting, 1u)) * 4, &cells));
    if (device) indices = device->indices;
    else NFD_TRY(out.make(VkDeviceSize(triangles) * 12, &indices));
    const uint32_t words = c.parents;
    NFD_TRY(job.dispatch(Kernel::BitmapCompact,
                         {{NFD_B_KEPT_BITS, *c.emitting},
                          {NFD_B_KEPT_PREFIX, *c.emitting_offsets},
                          {NFD_B_KEPT_CELLS, *cells}},
                         &words, Count{words}));
    NFD_TRY(job.dispatch(Kernel::McVertexEdges,
                         {{NFD_B_EDGE_MASKS, *c.edge_masks},
                          {NFD_B_VERTEX_OFFSETS, *c.vertex_offsets},
                          {NFD_B_VERTEX_EDGES, *edges}},
                         &finest.push, finest.parents.count()));
    std::vector<Bind> emit = level_bindings(finest.parents);
    emit.insert(emit.end(), {{NFD_B_MC_TABLES, job.device.mc_tables},
                             {NFD_B_CASES, *c.cases},
                             {NFD_B_EDGE_MASKS, *c.edge_masks},
                             {NFD_B_VERTEX_OFFSETS, *c.vertex_offsets},
                             {NFD_B_TRIANGLE_OFFSETS, *c.triangle_offsets},
                             {NFD_B_NEAR_CELLS, *cells},
                             {NFD_B_INDICES, *indices}});
    LevelPush per_cell = finest.push;
    const Count cell_items{emitting, c.emitting_slot};
    per_cell.set(cell_items);
    NFD_TRY(job.dispatch(Kernel::McEmit, emit, &per_cell, cell_items));
    NFD_TRY(job.sync());
    vk.destroy(*cells);
    c.release();

    if (device) {
        positions = device->positions;
        normals = device->normals;
    } else {
        NFD_TRY(out.make(VkDeviceSize(vertex_count) * 12, &positions));
        NFD_TRY(out.make(VkDeviceSize(vertex_count) * 12, &normals));
    }
    std::vector<Bind> place = std::move(inputs);
    place.insert(place.end(), {{NFD_B_VERTEX_EDGES, *edges},
                               {NFD_B_POSITIONS, *positions},
                               {NFD_B_NORMALS, *normals}});
    LevelPush per_vertex = finest.push;
    const Count vertex_items{vertex_count, device ? vertex_slot : NFD_NO_COUNTER};
    per_vertex.set(vertex_items);
    NFD_TRY(job.dispatch(vertices, place, &per_vertex, vertex_items));
    if (device) {
        const uint32_t draw[2] = {triangle_slot, triangles};
        NFD_TRY(job.dispatch(Kernel::DrawArgs, {{NFD_B_ARGS, *device->draw}}, draw, Count{1}));
    }
    NFD_TRY(job.submit());
    input_buffers.release();
    if (!finest.keep) {
        finest.buffers.release();
        finest.top = HostTop();
        finest.parents.buffers.release();
    }
    vk.destroy(*edges);
    if (device) return NFD_SUCCESS;

    MeshData* mesh = target.host;
    auto take = [&](Buffer* b, size_t count, auto* out_vector) -> nfd_result {
        try {
            out_vector->resize(count);
        } catch (const std::bad_alloc&) {
            return NFD_ERROR_OUT_OF_MEMORY;
        }
        const nfd_result r = vk.download(*b, 0, out_vector->data(), count * 4);
        vk.destroy(*b);
        return r;
    };
    NFD_TRY(take(indices, 3 * size_t(triangles), &mesh->indices));
    NFD_TRY(take(positions, 3 * size_t(vertex_count), &mesh->positions));
    return take(normals, 3 * size_t(vertex_count), &mesh->normals);
}

}  // namespace nfd::gpu
