// The sparse levels on the device, the GPU side of grid.cpp, one level per LevelBuilder::step:
// the level above the coarsest evaluated densely, then per level the child grids of the kept
// cells (refine_count/points.comp + the field), the keep rule on their children
// (refine_cells.comp), the child level's sorted kept list and corner values (bitmap_compact,
// gather_corners.comp). The host only sizes buffers between kernels from counts it reads back.
#include <algorithm>
#include <cstring>

#include "../mc_tables.h"
#include "levels.h"

namespace nfd::gpu {
namespace {

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

LevelBuilder::LevelBuilder(Device& device, DeviceNetwork& net, const Geometry& geometry,
                           uint32_t resolution)
    : device_(device), net_(net), resolution_(resolution), top_(refinement_levels(resolution)),
      step_(2.0f / float(resolution)), current_(top_), level_(*device.vk), kept_(*device.vk) {
    base_.step = step_;
    base_.scale = geometry.scale;
    for (int a = 0; a < 3; ++a) base_.center[a] = geometry.center[a];
}

LevelPush LevelBuilder::refine_push(uint32_t child_level, uint32_t parent_cells,
                                    uint32_t count) const {
    LevelPush push = base_;
    push.parent_cells = parent_cells;
    push.child_cells = cells_at_level(resolution_, child_level);
    push.child_level = child_level;
    push.count = count;
    push.threshold = kLipschitzMargin * (step_ * float(1u << child_level)) * kHalfDiagonal;
    return push;
}

// The level above the coarsest, evaluated densely, every cell kept. Only its vertices that are
// vertices of the coarsest level are evaluated (2 v <= its cells per axis): a last cell whose
// children past the grid are dropped has corners nothing reads, left 0.
nfd_result LevelBuilder::evaluate_dense_top() {
    const uint32_t l = top_ + 1, n = cells_at_level(resolution_, l);
    const uint32_t side = cells_at_level(resolution_, top_) / 2 + 1;  // <= n + 1
    const uint32_t count = side * side * side;
    Buffers scratch(*device_.vk);
    Buffer *points, *values;
    NFD_TRY(scratch.make(VkDeviceSize(count) * 12, &points));
    NFD_TRY(scratch.make(VkDeviceSize(count) * 4, &values));
    float* p = points->as<float>();
    for (uint32_t z = 0; z < side; ++z)
        for (uint32_t y = 0; y < side; ++y)
            for (uint32_t x = 0; x < side; ++x) {
                *p++ = -1.0f + float(x << l) * step_;
                *p++ = -1.0f + float(y << l) * step_;
                *p++ = -1.0f + float(z << l) * step_;
            }
    NFD_TRY(device_.vk->begin());
    NFD_TRY(record_field(device_, net_, *points, *values, count, false));
    NFD_TRY(device_.vk->submit());
    level_.points_evaluated += count;

    Level& level = level_.parents;
    level.cells = n;
    level.kept = n * n * n;
    const uint32_t words = level.words();
    NFD_TRY(level.buffers.make(VkDeviceSize(words) * 4, &level.bits));
    NFD_TRY(level.buffers.make(VkDeviceSize(words) * 4, &level.prefix));
    NFD_TRY(level.buffers.make(VkDeviceSize(level.kept) * 4, &level.list));
    NFD_TRY(level.buffers.make(VkDeviceSize(level.kept) * 32, &level.corners));
    uint32_t* bits = level.bits->as<uint32_t>();
    std::memset(bits, 0, size_t(words) * 4);
    for (uint32_t c = 0; c < level.kept; ++c) {
        bits[c >> 5] |= 1u << (c & 31);
        level.list->as<uint32_t>()[c] = c;
    }
    for (uint32_t w = 0; w < words; ++w) level.prefix->as<uint32_t>()[w] = 32 * w;
    const float* f = values->as<float>();
    float* corners = level.corners->as<float>();
    for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x)
                for (int c = 0; c < 8; ++c) {
                    const uint8_t* o = mc::kCornerOffset[c];
                    const uint32_t vx = x + o[0], vy = y + o[1], vz = z + o[2];
                    const bool evaluated = vx < side && vy < side && vz < side;
                    *corners++ = evaluated ? f[(vz * side + vy) * side + vx] : 0.0f;
                }
    return NFD_SUCCESS;
}

// The previous level's kept list and corners (from its child grids), which become the parents of
// the next; the previous parents and child grids go.
nfd_result LevelBuilder::gather_kept() {
    Level& child = kept_;
    NFD_TRY(child.buffers.make(VkDeviceSize(child.kept) * 4, &child.list));
    NFD_TRY(child.buffers.make(VkDeviceSize(child.kept) * 32, &child.corners));
    if (child.kept > 0) {
        LevelPush gather = refine_push(current_, level_.parents.cells, child.kept);
        const uint32_t words = child.words();
        NFD_TRY(device_.vk->begin());
        NFD_TRY(device_.vk->dispatch(device_[Kernel::BitmapCompact],
                                     {{NFD_B_KEPT_BITS, *child.bits},
                                      {NFD_B_KEPT_PREFIX, *child.prefix},
                                      {NFD_B_KEPT_CELLS, *child.list}},
                                     &words, words));
        NFD_TRY(device_.vk->dispatch(device_[Kernel::GatherCorners],
                                     with(child_grid_bindings(level_.parents, level_.grid),
                                          {{NFD_B_CHILD_CELLS, *child.list},
                                           {NFD_B_CHILD_CORNERS, *child.corners}}),
                                     &gather, child.kept));
        NFD_TRY(device_.vk->submit());
    }
    level_.buffers.release();
    level_.grid = PointList();
    level_.parents = std::move(kept_);
    kept_ = Level(*device_.vk);
    return NFD_SUCCESS;
}

nfd_result LevelBuilder::step() {
    if (stepped_) {
        NFD_TRY(gather_kept());
        --current_;
    } else {
        NFD_TRY(evaluate_dense_top());
    }
    stepped_ = true;
    const uint32_t l = current_;
    const Level& parents = level_.parents;
    LevelPush& view = level_.push;
    view = base_;
    view.parent_cells = parents.cells;
    view.child_cells = cells_at_level(resolution_, l);
    view.count = parents.kept;
    view.step = step_ * float(1u << l);
    level_.keep = l > 0;
    if (parents.kept == 0) return NFD_SUCCESS;  // nothing kept above: this level is empty

    const LevelPush push = refine_push(l, parents.cells, parents.kept);
    Buffers scratch(*device_.vk);
    NFD_TRY(evaluate_child_grids(device_, net_, parents, push, level_.buffers, scratch,
                                 &level_.grid));
    level_.points_evaluated += level_.grid.count;
    if (l == 0) return device_.vk->submit();
    // The keep rule on this level's cells, recorded with their values.
    Level& child = kept_;
    child.cells = push.child_cells;
    const uint32_t words = child.words();
    NFD_TRY(child.buffers.make(VkDeviceSize(words) * 4, &child.bits));
    NFD_TRY(child.buffers.make(VkDeviceSize(words) * 4, &child.prefix));
    device_.vk->fill(*child.bits, 0);
    NFD_TRY(device_.vk->dispatch(device_[Kernel::RefineCells],
                                 with(child_grid_bindings(parents, level_.grid),
                                      {{NFD_B_CHILD_BITS, *child.bits}}),
                                 &push, parents.kept));
    NFD_TRY(record_scan(device_, scratch, *child.bits, *child.prefix, words, true));
    NFD_TRY(device_.vk->submit());
    child.kept = word(*child.prefix, words - 1) +
                 uint32_t(__builtin_popcount(word(*child.bits, words - 1)));
    return NFD_SUCCESS;
}

// The mesh's vertices and triangles per kept cell, at most (mc_emit's records): 64 vertex edges,
// 8 children with the table's most triangles each.
constexpr uint64_t kMostVerticesPerParent = 64;
uint64_t most_triangles_per_parent() {
    const mc::Tables& t = mc::tables();
    return 8 * uint64_t(*std::max_element(t.triangle_count, t.triangle_count + 256));
}

uint64_t LevelBuilder::next_step_host_bytes(bool mesh) const {
    if (done() || !mesh) return 0;
    return (kMostVerticesPerParent * 24 + most_triangles_per_parent() * 12) * kept_.kept;
}

uint64_t LevelBuilder::next_step_device_bytes(bool mesh, bool udf) const {
    if (done()) return 0;
    // Per kept cell K of this level: its list entry and corners (36), its child grid's masks,
    // offsets and counts (12) and at most 19 new values (76); the points buffer of a chunk; the
    // scans' block sums (under 1/64 of what they scan, 8 bytes a block, twice for nesting).
    const uint64_t k = kept_.kept, chunk = 1u << 20;
    const uint64_t child_level = current_ - 1;
    auto scan = [](uint64_t count) { return 16 * (count / 64 + 2); };
    uint64_t bytes = 36 * k + 12 * k + 76 * k + 12 * std::min(19 * k, chunk) + scan(k);
    if (child_level > 0) {
        const uint64_t n = cells_at_level(resolution_, uint32_t(child_level));
        const uint64_t words = (n * n * n + 31) / 32;
        bytes += 8 * words + scan(words);
    }
    if (mesh) {
        // Classified (40 per parent), the vertex edges (4 + 12 + 12 bytes each), the triangles.
        bytes += 40 * k + 4 + 3 * scan(2 * k) + kMostVerticesPerParent * 28 * k +
                 most_triangles_per_parent() * 12 * k;
        // UDF: near masks, gradient masks, counts, offsets; value + gradient of at most 27
        // points per parent; a points chunk.
        if (udf) bytes += 16 * k + 16 * 27 * k + 12 * std::min(27 * k, chunk) + scan(k);
    }
    return bytes;
}

}  // namespace nfd::gpu
