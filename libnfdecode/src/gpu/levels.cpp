// The sparse levels on the device, the GPU side of grid.cpp: the top level evaluated densely,
// then per level the child grids of the kept cells (refine_count/points.comp + the field), the
// keep rule on their children (refine_cells.comp), the child level's sorted kept list and corner
// values (bitmap_compact, gather_corners.comp). The host only sizes buffers between kernels from
// counts it reads back.
#include <cstring>

#include "../mc_tables.h"
#include "levels.h"

namespace nfd::gpu {
namespace {

// The top level, evaluated densely; its cells are tested on the host (a few thousand), with
// grid.h's own cell_may_contain_surface. With no refinement level (resolution < 64) every cell
// of level 1 is kept, so that the finest level is visited entirely, as on the CPU.
nfd_result top_level(Device& d, DeviceNetwork& net, uint32_t resolution, uint32_t top, bool test,
                     Level* level, uint64_t* evaluated) {
    const float step = 2.0f / float(resolution);
    const uint32_t n = cells_at_level(resolution, top), side = n + 1;
    const uint32_t count = side * side * side;
    Buffers scratch(*d.vk);
    Buffer *points, *values;
    NFD_TRY(scratch.make(VkDeviceSize(count) * 12, &points));
    NFD_TRY(scratch.make(VkDeviceSize(count) * 4, &values));
    float* p = points->as<float>();
    for (uint32_t z = 0; z < side; ++z)
        for (uint32_t y = 0; y < side; ++y)
            for (uint32_t x = 0; x < side; ++x) {
                *p++ = -1.0f + float(x << top) * step;
                *p++ = -1.0f + float(y << top) * step;
                *p++ = -1.0f + float(z << top) * step;
            }
    NFD_TRY(d.vk->begin());
    NFD_TRY(record_field(d, net, *points, *values, count, false));
    NFD_TRY(d.vk->submit());
    *evaluated += count;

    const float h = step * float(1u << top);
    const float* f = values->as<float>();
    std::vector<uint32_t> kept;
    std::vector<float> corners;
    for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) {
                float v[8];
                for (int c = 0; c < 8; ++c) {
                    const uint8_t* o = mc::kCornerOffset[c];
                    v[c] = f[((z + o[2]) * side + y + o[1]) * side + x + o[0]];
                }
                if (test && !cell_may_contain_surface(v, h)) continue;
                kept.push_back(x + n * (y + n * z));
                corners.insert(corners.end(), v, v + 8);
            }
    level->cells = n;
    level->kept = uint32_t(kept.size());
    const uint32_t words = level->words();
    NFD_TRY(level->buffers.make(VkDeviceSize(words) * 4, &level->bits));
    NFD_TRY(level->buffers.make(VkDeviceSize(words) * 4, &level->prefix));
    NFD_TRY(level->buffers.make(VkDeviceSize(kept.size()) * 4, &level->list));
    NFD_TRY(level->buffers.make(VkDeviceSize(corners.size()) * 4, &level->corners));
    uint32_t* bits = level->bits->as<uint32_t>();
    std::memset(bits, 0, size_t(words) * 4);
    for (uint32_t c : kept) bits[c >> 5] |= 1u << (c & 31);
    uint32_t total = 0;
    for (uint32_t w = 0; w < words; ++w) {
        level->prefix->as<uint32_t>()[w] = total;
        total += uint32_t(__builtin_popcount(bits[w]));
    }
    std::memcpy(level->list->data, kept.data(), kept.size() * 4);
    std::memcpy(level->corners->data, corners.data(), corners.size() * 4);
    return NFD_SUCCESS;
}

std::vector<Bind> with(std::vector<Bind> b, std::initializer_list<Bind> more) {
    b.insert(b.end(), more);
    return b;
}

// Evaluates the new points of the child grids of all kept cells of `parent` into `g` (its
// buffers from `buffers`, temporaries from `scratch`). Leaves the batch recording: the caller may
// add work, then submits.
nfd_result evaluate_child_grids(Device& d, DeviceNetwork& net, const Level& parent,
                                const LevelPush& push, Buffers& buffers, Buffers& scratch,
                                PointList* g) {
    Buffer* counts;
    NFD_TRY(buffers.make(VkDeviceSize(parent.kept) * 4, &g->owned));
    NFD_TRY(buffers.make(VkDeviceSize(parent.kept) * 4, &g->offsets));
    NFD_TRY(scratch.make(VkDeviceSize(parent.kept) * 4, &counts));
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d[Kernel::RefineCount],
                           with(level_bindings(parent), {{NFD_B_OWNED, *g->owned},
                                                         {NFD_B_COUNTS, *counts}}),
                           &push, parent.kept));
    NFD_TRY(record_scan(d, scratch, *counts, *g->offsets, parent.kept, false));
    NFD_TRY(d.vk->submit());
    g->count = word(*g->offsets, parent.kept - 1) + word(*counts, parent.kept - 1);
    NFD_TRY(buffers.make(VkDeviceSize(g->count) * 4, &g->values));
    NFD_TRY(d.vk->begin());
    return record_list(d, net, parent, *g, *g->values, false, push, scratch);
}

nfd_result refine_level(Device& d, DeviceNetwork& net, const Level& parent, const LevelPush& push,
                        Level* child, uint64_t* evaluated) {
    Buffers step_buffers(*d.vk), scratch(*d.vk);
    PointList g;
    NFD_TRY(evaluate_child_grids(d, net, parent, push, step_buffers, scratch, &g));
    *evaluated += g.count;
    child->cells = push.child_cells;
    const uint32_t words = child->words();
    NFD_TRY(child->buffers.make(VkDeviceSize(words) * 4, &child->bits));
    NFD_TRY(child->buffers.make(VkDeviceSize(words) * 4, &child->prefix));
    d.vk->fill(*child->bits, 0);
    NFD_TRY(d.vk->dispatch(d[Kernel::RefineCells],
                           with(child_grid_bindings(parent, g), {{NFD_B_CHILD_BITS, *child->bits}}),
                           &push, parent.kept));
    NFD_TRY(record_scan(d, scratch, *child->bits, *child->prefix, words, true));
    NFD_TRY(d.vk->submit());
    child->kept = word(*child->prefix, words - 1) +
                  uint32_t(__builtin_popcount(word(*child->bits, words - 1)));
    NFD_TRY(child->buffers.make(VkDeviceSize(child->kept) * 4, &child->list));
    NFD_TRY(child->buffers.make(VkDeviceSize(child->kept) * 32, &child->corners));
    if (child->kept == 0) return NFD_SUCCESS;
    LevelPush gather = push;
    gather.count = child->kept;
    NFD_TRY(d.vk->begin());
    NFD_TRY(d.vk->dispatch(d[Kernel::BitmapCompact],
                           {{NFD_B_KEPT_BITS, *child->bits},
                            {NFD_B_KEPT_PREFIX, *child->prefix},
                            {NFD_B_KEPT_CELLS, *child->list}},
                           &words, words));
    NFD_TRY(d.vk->dispatch(d[Kernel::GatherCorners],
                           with(child_grid_bindings(parent, g),
                                {{NFD_B_CHILD_CELLS, *child->list},
                                 {NFD_B_CHILD_CORNERS, *child->corners}}),
                           &gather, child->kept));
    return d.vk->submit();
}

}  // namespace

std::vector<Bind> level_bindings(const Level& level) {
    return {{NFD_B_KEPT_BITS, *level.bits},
            {NFD_B_KEPT_PREFIX, *level.prefix},
            {NFD_B_KEPT_CELLS, *level.list}};
}

nfd_result record_list(Device& device, DeviceNetwork& net, const Level& parents,
                       const PointList& list, const Buffer& results, bool gradient,
                       const LevelPush& push, Buffers& scratch) {
    // Chunks of parents whose points fill at most kListChunk: the points buffer (12 bytes a
    // point, 167 MB for the 14M new points of resolution 1024) stays at 12 MB.
    constexpr uint32_t kListChunk = 1u << 20, kChunksPerBatch = 64;
    if (list.count == 0) return NFD_SUCCESS;
    Buffer* points;
    NFD_TRY(scratch.make(VkDeviceSize(std::min(list.count, kListChunk)) * 12, &points));
    const uint32_t* offsets = list.offsets->as<uint32_t>();
    LevelPush chunk = push;
    uint32_t chunks = 0;
    for (uint32_t first = 0, end; first < parents.kept; first = end) {
        // A parent owns at most 27 points, so every chunk takes at least one.
        end = first + 1;
        while (end < parents.kept && offsets[end] - offsets[first] <= kListChunk - 27) ++end;
        const uint32_t last = end < parents.kept ? offsets[end] : list.count;
        chunk.first_parent = first;
        chunk.count = end - first;
        NFD_TRY(device.vk->dispatch(device[Kernel::RefinePoints],
                                    {{NFD_B_KEPT_CELLS, *parents.list},
                                     {NFD_B_OWNED, *list.owned},
                                     {NFD_B_OFFSETS, *list.offsets},
                                     {NFD_B_POINTS, *points}},
                                    &chunk, chunk.count));
        NFD_TRY(record_field(device, net, *points, results, last - offsets[first], gradient,
                             offsets[first]));
        // A batch holds a bounded number of dispatches (vk_context.cpp): run it, go on.
        if (++chunks % kChunksPerBatch == 0) {
            NFD_TRY(device.vk->submit());
            NFD_TRY(device.vk->begin());
        }
    }
    return NFD_SUCCESS;
}

std::vector<Bind> child_grid_bindings(const Level& parent, const PointList& g) {
    std::vector<Bind> b = level_bindings(parent);
    b.insert(b.end(), {{NFD_B_CORNERS, *parent.corners},
                       {NFD_B_OWNED, *g.owned},
                       {NFD_B_OFFSETS, *g.offsets},
                       {NFD_B_VALUES, *g.values}});
    return b;
}

nfd_result build_levels(Device& device, DeviceNetwork& net, const Geometry& geometry,
                        uint32_t resolution, FinestLevel* out) {
    const uint32_t levels = refinement_levels(resolution);
    const uint32_t top = std::max(levels, 1u);
    const float step = 2.0f / float(resolution);
    Level& level = out->parents;
    NFD_TRY(top_level(device, net, resolution, top, levels > 0, &level, &out->points_evaluated));

    LevelPush& push = out->push;
    push.step = step;
    push.scale = geometry.scale;
    for (int a = 0; a < 3; ++a) push.center[a] = geometry.center[a];
    for (uint32_t l = top; l-- > 1 && level.kept > 0;) {  // parent level l + 1, children l
        push.parent_cells = level.cells;
        push.child_cells = cells_at_level(resolution, l);
        push.child_level = l;
        push.count = level.kept;
        push.threshold = kLipschitzMargin * (step * float(1u << l)) * kHalfDiagonal;
        Level child(*device.vk);
        NFD_TRY(refine_level(device, net, level, push, &child, &out->points_evaluated));
        level = std::move(child);
    }
    // Level 1's kept cells are the parents of the finest cells: their child grids' values.
    push.parent_cells = level.cells;
    push.child_cells = resolution;
    push.child_level = 0;
    push.count = level.kept;
    push.threshold = 0;
    if (level.kept == 0) return NFD_SUCCESS;
    Buffers scratch(*device.vk);
    NFD_TRY(evaluate_child_grids(device, net, level, push, out->buffers, scratch, &out->grid));
    NFD_TRY(device.vk->submit());
    out->points_evaluated += out->grid.count;
    return NFD_SUCCESS;
}

}  // namespace nfd::gpu
