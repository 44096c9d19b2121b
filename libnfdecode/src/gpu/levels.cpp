// The sparse levels on the device, the GPU side of grid.cpp, one level per LevelBuilder::step:
// the coarsest level evaluated on the host (HostTop), then per level the child grids of the kept
// cells (refine_count/points.comp + the field), the keep rule on their children
// (refine_cells.comp), the child level's sorted kept list and corner values (bitmap_compact,
// gather_corners.comp). Counts stay on the device (Job): a level's buffers are sized up front
// from its parents' capacity, and own jobs read the counts after the level's batch only.
#include <algorithm>
#include <cstring>
#include <new>

#include "../mc_tables.h"
#include "../network.h"
#include "levels.h"

namespace nfd::gpu {
namespace {

std::vector<Bind> with(std::vector<Bind> b, std::initializer_list<Bind> more) {
    b.insert(b.end(), more);
    return b;
}
std::vector<Bind> with(std::vector<Bind> b, const std::vector<Bind>& more) {
    b.insert(b.end(), more.begin(), more.end());
    return b;
}

constexpr uint32_t kNewPointsPerParent = 19;  // of a child grid's 27, the 8 corners are known

// udf_predict.comp's guess, in cell edges h of the level: a new point of a meshed UDF level whose
// trilinear interpolation of its parent's corners is at most this is evaluated with its gradient.
// The UDF mesher needs a gradient at every corner of a near cell (one with a valid edge, f_a +
// f_b <= 1.5 h). On the bunny UDF w32 at 256 (dense field, bench/RESULTS.md "0.12.2") 2 h
// predicts 99.1% of the new points that need one, and 13% of those it predicts do not: at 0.59
// and 0.91 us a value and a value + gradient on lavapipe, the cheapest of 1.5 to 5 h.
constexpr float kPredictedCorner = 2.0f;

// A point list over the kept cells of `parent`: its masks (zero past their count) and offsets from
// `buffers`, and a fresh counter for its total.
nfd_result make_point_list(Job& job, const Level& parent, Buffers& buffers, PointList* g) {
    NFD_TRY(buffers.make(VkDeviceSize(parent.capacity) * 4, &g->owned));
    NFD_TRY(buffers.make(VkDeviceSize(parent.capacity) * 4, &g->offsets));
    job.fill(*g->owned, 0);
    return job.new_slot(&g->slot);
}

// refine_count: which new points of each kept parent's child grid it owns, into g.owned.
nfd_result record_refine_count(Job& job, const Level& parent, const LevelPush& push,
                               const PointList& g) {
    return job.dispatch(Kernel::RefineCount,
                        with(level_bindings(parent), {{NFD_B_OWNED, *g.owned}}), &push,
                        parent.count());
}

// The values of point list `g` once its masks are set: the offsets (a scan of the masks'
// popcounts over the parents' capacity), the total into its counter, then the list evaluated into
// values from `buffers` (with `dense`, copied: record_list).
nfd_result record_values(Job& job, DeviceNetwork& net, const Level& parent, const LevelPush& push,
                         Buffers& buffers, Buffers& scratch, const Buffer* dense, PointList* g) {
    const uint32_t k = parent.capacity;
    g->capacity = uint32_t(std::min<uint64_t>(uint64_t(k) * kNewPointsPerParent, UINT32_MAX));
    NFD_TRY(buffers.make(VkDeviceSize(g->capacity) * 4, &g->values));
    NFD_TRY(record_scan(job, scratch, *g->owned, *g->offsets, k, true));
    NFD_TRY(job.total(*g->owned, *g->offsets, k, true, g->slot, g->capacity));
    return record_list(job, net, parent, *g, *g->values, false, push, scratch, dense);
}

// Records the evaluation of the new points of the child grids of all kept cells of `parent` into
// `g` (its buffers from `buffers`, temporaries from `scratch`).
nfd_result evaluate_child_grids(Job& job, DeviceNetwork& net, const Level& parent,
                                const LevelPush& push, Buffers& buffers, Buffers& scratch,
                                const Buffer* dense, PointList* g) {
    NFD_TRY(make_point_list(job, parent, buffers, g));
    NFD_TRY(record_refine_count(job, parent, push, *g));
    return record_values(job, net, parent, push, buffers, scratch, dense, g);
}

// extract.glsl's kept_around on the host: bit (x + 1) + 3 (y + 1) + 9 (z + 1) set where the cell
// at offset (x, y, z) from p is in the grid of n^3 cells and kept.
uint32_t kept_around(const uint8_t* kept, uint32_t n, const uint32_t p[3]) {
    uint32_t around = 0;
    for (uint32_t z = 0; z < 3; ++z)
        for (uint32_t y = 0; y < 3; ++y)
            for (uint32_t x = 0; x < 3; ++x) {
                const uint32_t q[3] = {p[0] + x - 1, p[1] + y - 1, p[2] + z - 1};  // wraps below 0
                if (q[0] < n && q[1] < n && q[2] < n && kept[(size_t(q[2]) * n + q[1]) * n + q[0]])
                    around |= 1u << (x + 3 * y + 9 * z);
            }
    return around;
}

// The value and gradient at the coarsest level's vertices that `wanted` marks, by the C++
// evaluator, into `out` (4 floats a vertex).
nfd_result evaluate_top_gradients(const HostTop& top, const nfd::vector<uint8_t>& wanted,
                                  float* out) {
    try {
        nfd::vector<uint32_t> index;
        nfd::vector<float> xyz;
        const size_t count = size_t(std::count(wanted.begin(), wanted.end(), 1));
        index.reserve(count);
        xyz.reserve(3 * count);
        for (uint32_t z = 0; z < top.side; ++z)
            for (uint32_t y = 0; y < top.side; ++y)
                for (uint32_t x = 0; x < top.side; ++x) {
                    const size_t i = top.index(x, y, z);
                    if (!wanted[i]) continue;
                    index.push_back(uint32_t(i));
                    xyz.insert(xyz.end(), {top.coord(x), top.coord(y), top.coord(z)});
                }
        nfd::vector<float> values(index.size()), g(3 * index.size());
        evaluate_gradient_cpu(*top.network, xyz.data(), index.size(), values.data(), g.data(),
                              top.threads);
        top.network->ball.bound(xyz.data(), index.size(), values.data());
        for (size_t k = 0; k < index.size(); ++k) {
            float* o = out + 4 * size_t(index[k]);
            o[0] = values[k];
            std::copy_n(&g[3 * k], 3, o + 1);
        }
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

}  // namespace

uint32_t Plan::level_cells(uint32_t level, uint32_t cells_per_axis) const {
    const uint64_t all = uint64_t(cells_per_axis) * cells_per_axis * cells_per_axis;
    uint64_t c = cells;
    if (level > 1) c = 2 * ((c >> (2 * (level - 1))) + 64);
    return uint32_t(std::min<uint64_t>({c, all, UINT32_MAX}));
}

std::vector<Bind> level_cells_bindings(const Level& level) {
    return {{NFD_B_KEPT_BITS, *level.bits},
            {NFD_B_KEPT_PREFIX, *level.prefix},
            {NFD_B_KEPT_CELLS, *level.list}};
}

std::vector<Bind> level_bindings(const Level& level) {
    return with(level_cells_bindings(level), {{NFD_B_KEPT_AROUND, *level.around}});
}

nfd_result record_list(Job& job, DeviceNetwork& net, const Level& parents, const PointList& list,
                       const Buffer& results, bool gradient, const LevelPush& push,
                       Buffers& scratch, const Buffer* dense) {
    // Chunks of NFD_POINT_CHUNK points: the points buffer (12 bytes a point, 167 MB for the 14M
    // new points of resolution 1024) stays at 12 MB.
    constexpr uint32_t kListChunk = NFD_POINT_CHUNK;
    if (list.capacity == 0 || parents.capacity == 0) return NFD_SUCCESS;
    // dense_lookup searches the offsets of the parents' capacity, no further (buffers may be
    // larger than asked for).
    const BufferRange offsets(*list.offsets, 0, VkDeviceSize(parents.capacity) * 4);
    if (dense) {
        LevelPush all = push;
        const Count c{list.capacity, list.slot};
        all.set(c);
        return job.dispatch(gradient ? Kernel::DenseGradients : Kernel::DenseValues,
                            {{NFD_B_KEPT_CELLS, *parents.list},
                             {NFD_B_OWNED, *list.owned},
                             {NFD_B_OFFSETS, offsets},
                             {NFD_B_DENSE_VALUES, *dense},
                             {NFD_B_POINTS, results}},
                            &all, c);
    }
    Buffer* points;
    NFD_TRY(scratch.make(VkDeviceSize(std::min(list.capacity, kListChunk)) * 12, &points));
    LevelPush chunk = push;  // refine_points runs per parent, writing its points in the chunk
    chunk.set(parents.count());
    for (uint64_t first = 0; first < list.capacity; first += kListChunk) {
        const Count c{uint32_t(std::min<uint64_t>(kListChunk, list.capacity - first)), list.slot,
                      uint32_t(first)};
        chunk.list_first = uint32_t(first);
        NFD_TRY(job.dispatch(Kernel::RefinePoints,
                             {{NFD_B_KEPT_CELLS, *parents.list},
                              {NFD_B_OWNED, *list.owned},
                              {NFD_B_OFFSETS, offsets},
                              {NFD_B_POINTS, *points}},
                             &chunk, parents.count()));
        NFD_TRY(record_field(job, net, *points, results, c, gradient, net.ball));
    }
    return NFD_SUCCESS;
}

nfd_result top_gradients(const HostTop& top, float h, Buffers& buffers, Buffer** out) {
    const uint32_t cells = top.side - 1;
    const size_t n = top.vertices();
    NFD_TRY(buffers.make(VkDeviceSize(n) * 16, out, Memory::Host));
    float* dense = (*out)->as<float>();
    std::fill_n(dense, 4 * n, 0.0f);
    const float* values = top.values->as<float>();
    try {
        nfd::vector<uint8_t> wanted(n, 0);
        for (uint32_t z = 0; z < cells; ++z)
            for (uint32_t y = 0; y < cells; ++y)
                for (uint32_t x = 0; x < cells; ++x) {
                    float f[8];
                    for (int k = 0; k < 8; ++k) {
                        const uint8_t* o = mc::kCornerOffset[k];
                        f[k] = values[top.index(x + o[0], y + o[1], z + o[2])];
                    }
                    if (!udf_cell_is_near(f, h)) continue;
                    for (const auto& o : mc::kCornerOffset)
                        wanted[top.index(x + o[0], y + o[1], z + o[2])] = 1;
                }
        return evaluate_top_gradients(top, wanted, dense);
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
}

std::vector<Bind> child_grid_bindings(const Level& parent, const PointList& g) {
    std::vector<Bind> b = level_bindings(parent);
    b.insert(b.end(), {{NFD_B_CORNERS, *parent.corners},
                       {NFD_B_OWNED, *g.owned},
                       {NFD_B_OFFSETS, *g.offsets},
                       {NFD_B_VALUES, *g.values}});
    return b;
}

LevelBuilder::LevelBuilder(Job& job, DeviceNetwork& net, const Geometry& geometry,
                           uint32_t resolution, const Plan* plan, bool band,
                           uint32_t meshed_levels)
    : job_(job), net_(net), network_(geometry.network), plan_(plan), resolution_(resolution),
      top_(refinement_levels(resolution)), step_(2.0f / float(resolution)),
      field_(geometry.field), follow_finest_(!band), meshed_levels_(meshed_levels),
      current_(top_),
      level_(*job.device.vk), kept_(*job.device.vk) {
    base_.step = step_;
    base_.scale = geometry.scale;
    for (int a = 0; a < 3; ++a) base_.center[a] = geometry.emit_center(a);
}

LevelPush LevelBuilder::refine_push(uint32_t child_level, uint32_t parent_cells,
                                    Count parents) const {
    LevelPush push = base_;
    push.parent_cells = parent_cells;
    push.child_cells = cells_at_level(resolution_, child_level);
    push.child_level = child_level;
    push.set(parents);
    push.threshold = keep_threshold(field_, step_ * float(1u << child_level));
    return push;
}

// The coarsest level on the host (HostTop): its values at its side^3 vertices (grid.h,
// evaluate_coarsest_level) into a host-visible buffer that its child grids copy; the level above
// it, its cells the probe keeps (every one when the coarsest level is the finest), written here
// too (bitmap, list, prefix and the corners, from the same values: a vertex v of it is the
// coarsest level's 2 v), so that the coarsest level's cells are those cells' children. Small (at
// most 64^3 vertices): host memory, no staging while recording.
nfd_result LevelBuilder::evaluate_top_on_host() {
    const uint32_t l = top_ + 1, n = cells_at_level(resolution_, l);
    HostTop& top = level_.top;
    top.network = &network_;
    top.side = cells_at_level(resolution_, top_) + 1;
    top.level = top_;
    top.step = step_;
    top.threads = job_.device.host_threads;
    const uint32_t side = top.side;
    NFD_TRY(level_.buffers.make(VkDeviceSize(top.vertices()) * 4, &top.values, Memory::Host));
    const float* values = top.values->as<float>();
    Level& level = level_.parents;
    level.cells = n;
    const uint32_t words = level.words();
    NFD_TRY(level.buffers.make(VkDeviceSize(words) * 4, &level.bits, Memory::Host));
    NFD_TRY(level.buffers.make(VkDeviceSize(words) * 4, &level.prefix, Memory::Host));
    uint32_t* bits = level.bits->as<uint32_t>();
    uint32_t* prefix = level.prefix->as<uint32_t>();
    try {
        nfd::vector<uint8_t> kept(size_t(n) * n * n);
        evaluate_coarsest_level(network_, field_, resolution_, top_, top.threads,
                                top.values->as<float>(), kept.data());
        // Counted as the CPU counts: the level above's vertices here, the new points of the
        // kept cells' child grids (the rest of what the probe evaluated) with those grids.
        const uint32_t above = (side - 1) / 2 + 1;  // 2 v <= the coarsest level's cells per axis
        level_.points_evaluated += uint64_t(above) * above * above;
        std::memset(bits, 0, size_t(words) * 4);
        uint32_t count = 0;
        for (uint32_t c = 0; c < kept.size(); ++c) {
            if (c % 32 == 0) prefix[c / 32] = count;
            if (!kept[c]) continue;
            bits[c >> 5] |= 1u << (c & 31);
            ++count;
        }
        level.capacity = level.kept = count;
        const VkDeviceSize listed = std::max(count, 1u);  // a buffer holds a byte at least
        NFD_TRY(level.buffers.make(listed * 4, &level.list, Memory::Host));
        NFD_TRY(level.buffers.make(listed * 32, &level.corners, Memory::Host));
        NFD_TRY(level.buffers.make(listed * 4, &level.around, Memory::Host));
        uint32_t* list = level.list->as<uint32_t>();
        float* corners = level.corners->as<float>();
        uint32_t* around = level.around->as<uint32_t>();
        uint32_t i = 0;
        for (uint32_t c = 0; c < kept.size(); ++c) {
            if (!kept[c]) continue;
            list[i] = c;
            const uint32_t p[3] = {c % n, c / n % n, c / (n * n)};
            around[i] = kept_around(kept.data(), n, p);
            for (int k = 0; k < 8; ++k) {
                const uint8_t* o = mc::kCornerOffset[k];
                const uint32_t v[3] = {2 * (p[0] + o[0]), 2 * (p[1] + o[1]), 2 * (p[2] + o[2])};
                // A last cell whose children past the grid are dropped has corners nothing reads.
                const bool exists = v[0] < side && v[1] < side && v[2] < side;
                corners[8 * i + k] = exists ? values[top.index(v[0], v[1], v[2])] : 0.0f;
            }
            ++i;
        }
    } catch (const std::bad_alloc&) {
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    return NFD_SUCCESS;
}

// The previous level's kept list and corners (from its child grids), which become the parents of
// the next; the previous parents and child grids go. Own jobs know the kept count by now and
// size the list exactly; recorded ones take the plan's capacity. With `carried` (the previous
// level's UDF gradient list), also where each corner of the kept cells is in that list.
nfd_result LevelBuilder::gather_kept(CarriedGradients* carried) {
    Level& child = kept_;
    child.capacity = plan_ ? plan_->level_cells(current_, child.cells) : child.kept;
    NFD_TRY(child.buffers.make(VkDeviceSize(child.capacity) * 4, &child.list));
    NFD_TRY(child.buffers.make(VkDeviceSize(child.capacity) * 32, &child.corners));
    NFD_TRY(child.buffers.make(VkDeviceSize(child.capacity) * 4, &child.around));
    if (child.capacity > 0) {
        LevelPush gather = refine_push(current_, level_.parents.cells, child.count());
        const uint32_t words = child.words();
        NFD_TRY(job_.begin());
        NFD_TRY(job_.dispatch(Kernel::BitmapCompact,
                              {{NFD_B_KEPT_BITS, *child.bits},
                               {NFD_B_KEPT_PREFIX, *child.prefix},
                               {NFD_B_KEPT_CELLS, *child.list}},
                              &words, Count{words}));
        LevelPush around = gather;
        around.parent_cells = child.cells;
        NFD_TRY(job_.dispatch(Kernel::LevelAround, level_bindings(child), &around,
                              child.count()));
        std::vector<Bind> corners = with(child_grid_bindings(level_.parents, level_.grid),
                                         {{NFD_B_CHILD_CELLS, *child.list},
                                          {NFD_B_CHILD_CORNERS, *child.corners}});
        const bool gradients = carried && carried->gradients;
        if (gradients) {
            NFD_TRY(carried->buffers.make(VkDeviceSize(child.capacity) * 32, &carried->corners));
            corners = with(corners, {{NFD_B_GRADIENT_OWNED, *carried->owned},
                                     {NFD_B_GRADIENT_OFFSETS, *carried->offsets},
                                     {NFD_B_CORNER_GRADIENTS, *carried->corners}});
        }
        NFD_TRY(job_.dispatch(gradients ? Kernel::GatherCornersGradients : Kernel::GatherCorners,
                              corners, &gather, child.count()));
        NFD_TRY(job_.submit());
    }
    level_.buffers.release();
    level_.grid = PointList();
    level_.predicted_buffers.release();  // the mesher's, if it did not run
    level_.predicted = PointList();
    level_.near_buffers.release();
    level_.near = nullptr;
    level_.classified.release();  // the mesher's, if it did not run
    level_.top = HostTop();
    level_.parents = std::move(kept_);
    kept_ = Level(*job_.device.vk);
    return NFD_SUCCESS;
}

// A UDF's finest level in an own job: surface following where its slots fit
// (evaluate_finest_flood), else the band split by evaluate_predicted.
nfd_result LevelBuilder::evaluate_finest_udf(const LevelPush& push, Buffers& scratch) {
    if (follow_finest_ && uint64_t(level_.parents.capacity) * kNewPointsPerParent * 16 <=
                              job_.device.predicted_list_bytes)
        return evaluate_finest_flood(push, scratch);
    return evaluate_predicted(push, scratch);
}

// A meshed UDF level in an own job: refine_count's lists of new points split by udf_predict
// into the value list (level_.grid) and the predicted list, evaluated with their gradients; the
// predicted count is read back between two batches to size that list exactly (past
// predicted_list_bytes, the value list whole instead). Leaves the second batch open, as
// evaluate_child_grids does.
nfd_result LevelBuilder::evaluate_predicted(const LevelPush& push, Buffers& scratch) {
    const Level& parents = level_.parents;
    const uint32_t k = parents.capacity;
    PointList& g = level_.grid;
    PointList& p = level_.predicted;
    NFD_TRY(make_point_list(job_, parents, level_.buffers, &g));
    NFD_TRY(make_point_list(job_, parents, level_.predicted_buffers, &p));
    NFD_TRY(record_refine_count(job_, parents, push, g));
    LevelPush predict = push;
    predict.threshold = kPredictedCorner * step_ * float(1u << push.child_level);
    NFD_TRY(job_.dispatch(Kernel::UdfPredict,
                          {{NFD_B_CORNERS, *parents.corners},
                           {NFD_B_OWNED, *g.owned},
                           {NFD_B_PREDICTED_OWNED, *p.owned}},
                          &predict, parents.count()));
    NFD_TRY(record_scan(job_, scratch, *p.owned, *p.offsets, k, true));
    NFD_TRY(job_.total(*p.owned, *p.offsets, k, true, p.slot, UINT32_MAX));
    NFD_TRY(job_.sync());
    p.count = p.capacity = job_.counter(p.slot);
    if (uint64_t(p.capacity) * 16 > job_.device.predicted_list_bytes) {
        // refine_count again: the value list whole, as on the other levels.
        NFD_TRY(record_refine_count(job_, parents, push, g));
        level_.predicted_buffers.release();
        p = PointList();
    }
    NFD_TRY(record_values(job_, net_, parents, push, level_.buffers, scratch, nullptr, &g));
    if (!p.owned) return NFD_SUCCESS;
    NFD_TRY(level_.predicted_buffers.make(VkDeviceSize(p.capacity) * 16, &p.values));
    return record_list(job_, net_, parents, p, *p.values, true, push, scratch);
}

// A meshed UDF level above the finest, after evaluate_predicted: its two lists joined into one
// value list (udf_predict.comp's NFD_PREDICT_JOIN) that the keep rule, the next level's corners
// and the mesher read as any level's; the mesher still copies the predicted gradients.
nfd_result LevelBuilder::join_predicted(const LevelPush& push) {
    PointList& g = level_.grid;
    const PointList& p = level_.predicted;
    if (!p.owned) return NFD_SUCCESS;  // not split (evaluate_predicted's cap)
    const uint32_t k = level_.parents.capacity;
    Buffer* joined;
    NFD_TRY(level_.buffers.make(VkDeviceSize(k) * kNewPointsPerParent * 4, &joined));
    LevelPush all = push;
    all.set(Count{k, NFD_NO_COUNTER});  // the offsets past the last parent too
    NFD_TRY(job_.dispatch(Kernel::UdfPredictJoin,
                          {{NFD_B_OWNED, *g.owned},
                           {NFD_B_OFFSETS, *g.offsets},
                           {NFD_B_VALUES, *g.values},
                           {NFD_B_PREDICTED_OWNED, *p.owned},
                           {NFD_B_PREDICTED_OFFSETS, *p.offsets},
                           {NFD_B_PREDICTED, *p.values},
                           {NFD_B_JOINED_VALUES, *joined}},
                          &all, Count{k, NFD_NO_COUNTER}));
    g.values = joined;
    return NFD_SUCCESS;
}

// A UDF's finest level in an own job by surface following within the kept parents (grid.h; the
// CPU twin: GridBuilder's `follow_finest`), udf_flood.comp's modes in waves, one batch each, the
// claimed points' and the frontier's totals read after it: seeds from the parents' valid edges,
// then per wave the new frontier's corners claimed and evaluated with their gradients, and the
// floodable faces of its cells crossed. The evaluated points go to the predicted list's slots
// (the masks and offsets of every owned point: a vec4 each, at most predicted_list_bytes), where
// the UDF mesher reads their values and copies their gradients; the value list is empty. Leaves
// the last batch open, as evaluate_child_grids does.
nfd_result LevelBuilder::evaluate_finest_flood(const LevelPush& push, Buffers& scratch) {
    Context& vk = *job_.device.vk;
    const Level& parents = level_.parents;
    const uint32_t k = parents.capacity;
    PointList& g = level_.grid;
    PointList& p = level_.predicted;
    Buffers& kept = level_.predicted_buffers;
    // The slots: every owned point of the child grids, in the value list's layout.
    NFD_TRY(make_point_list(job_, parents, kept, &p));
    NFD_TRY(record_refine_count(job_, parents, push, p));
    NFD_TRY(record_scan(job_, scratch, *p.owned, *p.offsets, k, true));
    p.capacity = k * kNewPointsPerParent;  // at most 16 bytes each within predicted_list_bytes
    NFD_TRY(kept.make(VkDeviceSize(p.capacity) * 16, &p.values));
    NFD_TRY(level_.near_buffers.make(VkDeviceSize(k) * 4, &level_.near));
    // The value list holds nothing: zero masks, so that the mesher finds every point in the slots.
    NFD_TRY(make_point_list(job_, parents, level_.buffers, &g));
    NFD_TRY(level_.buffers.make(4, &g.values));
    job_.fill(*g.offsets, 0);

    Buffers flood(vk);
    Buffer *visited, *fresh[2], *claimed, *claimed_points, *frontier, *points, *results;
    const uint32_t frontier_capacity = 8 * k;  // a parent enters once per child it gets
    const uint32_t chunk = std::min(p.capacity, 1u << 20);
    NFD_TRY(flood.make(VkDeviceSize(k) * 4, &visited));
    NFD_TRY(flood.make(VkDeviceSize(k) * 4, &fresh[0]));
    NFD_TRY(flood.make(VkDeviceSize(k) * 4, &fresh[1]));
    NFD_TRY(flood.make(VkDeviceSize(k) * 4, &claimed));
    NFD_TRY(flood.make(VkDeviceSize(p.capacity) * 4, &claimed_points));
    NFD_TRY(flood.make(VkDeviceSize(frontier_capacity) * 4, &frontier));
    NFD_TRY(flood.make(VkDeviceSize(chunk) * 12, &points));
    NFD_TRY(flood.make(VkDeviceSize(chunk) * 16, &results));
    for (Buffer* b : {visited, level_.near, fresh[0], fresh[1], claimed}) job_.fill(*b, 0);
    LevelPush wave = push;
    uint32_t frontier_slot;
    NFD_TRY(job_.new_slot(&wave.tally_slot));  // the claimed points', then the frontier's
    NFD_TRY(job_.new_slot(&frontier_slot));
    if (frontier_slot != wave.tally_slot + 1) return NFD_ERROR_INTERNAL;
    int now = 0;  // fresh[now]: the children the frontier's entries got in the wave before
    auto run = [&](Kernel kernel, Count items) {
        LevelPush at = wave;
        at.set(items);
        std::vector<Bind> roles = with(level_cells_bindings(parents),
                                       {{NFD_B_CORNERS, *parents.corners},
                                        {NFD_B_PREDICTED_OWNED, *p.owned},
                                        {NFD_B_PREDICTED_OFFSETS, *p.offsets},
                                        {NFD_B_PREDICTED, *p.values},
                                        {NFD_B_FLOOD_VISITED, *visited},
                                        {NFD_B_FLOOD_FRESH, *fresh[now]},
                                        {NFD_B_FLOOD_NEXT, *fresh[1 - now]},
                                        {NFD_B_FLOOD_FRONTIER, *frontier}});
        if (kernel == Kernel::UdfFloodFaces)
            roles = with(roles, {{NFD_B_NEAR_MASKS, *level_.near},
                                 {NFD_B_MC_TABLES, job_.device.mc_tables}});
        else
            roles = with(roles, {{NFD_B_FLOOD_CLAIMED, *claimed},
                                 {NFD_B_FLOOD_POINTS, *claimed_points},
                                 {NFD_B_FLOOD_RESULTS, *results},
                                 {NFD_B_POINTS, *points}});
        return job_.dispatch(kernel, roles, &at, items);
    };
    // The claimed points [from, to) with their gradients, into their slots.
    auto evaluate = [&](uint32_t from, uint32_t to) {
        for (uint32_t first = from; first < to; first += std::min(chunk, to - first)) {
            const Count c{std::min(chunk, to - first), NFD_NO_COUNTER, first};
            NFD_TRY(run(Kernel::UdfFloodListPoints, c));
            NFD_TRY(record_field(job_, net_, *points, *results, Count{c.capacity}, true, net_.ball));
            NFD_TRY(run(Kernel::UdfFloodStoreValues, c));
        }
        return NFD_SUCCESS;
    };
    NFD_TRY(run(Kernel::UdfFloodSeedMidpoints, parents.count()));
    NFD_TRY(job_.sync());
    uint32_t evaluated = 0, claims = job_.counter(wave.tally_slot);
    NFD_TRY(evaluate(evaluated, claims));
    evaluated = claims;
    NFD_TRY(run(Kernel::UdfFloodSeedChildren, parents.count()));
    NFD_TRY(run(Kernel::UdfFloodSeedIsolated, parents.count()));
    uint32_t wave_begin = 0, wave_end = 0;  // the frontier entries of the current wave
    do {
        // The corners of the frontier's new entries (their fresh children), claimed.
        NFD_TRY(run(Kernel::UdfFloodClaimCorners,
                    Count{frontier_capacity - wave_end, frontier_slot, wave_end}));
        NFD_TRY(job_.sync());
        wave_begin = wave_end;
        wave_end = job_.counter(frontier_slot);
        claims = job_.counter(wave.tally_slot);
        NFD_TRY(evaluate(evaluated, claims));
        evaluated = claims;
        // Across the floodable faces of the wave's fresh children: the next wave's entries.
        if (wave_end > wave_begin)
            NFD_TRY(run(Kernel::UdfFloodFaces,
                        Count{wave_end - wave_begin, NFD_NO_COUNTER, wave_begin}));
        now = 1 - now;
    } while (wave_end > wave_begin);
    // The open batch holds nothing yet (the last wave claimed nothing): the flood's buffers go.
    p.count = evaluated;
    return NFD_SUCCESS;
}

nfd_result LevelBuilder::step(CarriedGradients* carried) {
    Buffers scratch(*job_.device.vk);
    if (stepped_) {
        NFD_TRY(gather_kept(carried));
        --current_;
        NFD_TRY(job_.begin());
    } else {
        NFD_TRY(evaluate_top_on_host());
        NFD_TRY(job_.begin());
    }
    stepped_ = true;
    const uint32_t l = current_;
    const Level& parents = level_.parents;
    LevelPush& view = level_.push;
    view = base_;
    view.parent_cells = parents.cells;
    view.child_cells = cells_at_level(resolution_, l);
    view.set(parents.count());
    view.step = step_ * float(1u << l);
    level_.keep = l > 0;
    const bool empty = !plan_ && parents.kept == 0;  // own jobs: nothing kept above
    if (!empty) {
        const LevelPush push = refine_push(l, parents.cells, parents.count());
        const bool predicts = field_ == FieldType::Udf && !plan_ && !level_.top.values;
        if (predicts && l == 0) {
            NFD_TRY(evaluate_finest_udf(push, scratch));
        } else if (predicts && (meshed_levels_ >> l & 1) &&
                   field_ready(job_.device, net_, true)) {
            NFD_TRY(evaluate_predicted(push, scratch));
            NFD_TRY(join_predicted(push));
        } else {
            NFD_TRY(evaluate_child_grids(job_, net_, parents, push, level_.buffers, scratch,
                                         level_.top.values, &level_.grid));
        }
        try {
            point_slots_.push_back(level_.grid.slot);
            if (l > 0) kept_slots_.reserve(kept_slots_.size() + 1);
        } catch (const std::bad_alloc&) {
            return NFD_ERROR_OUT_OF_MEMORY;
        }
        if (l > 0) {
            // The keep rule on this level's cells, recorded with their values.
            Level& child = kept_;
            child.cells = push.child_cells;
            const uint32_t words = child.words();
            NFD_TRY(child.buffers.make(VkDeviceSize(words) * 4, &child.bits));
            NFD_TRY(child.buffers.make(VkDeviceSize(words) * 4, &child.prefix));
            NFD_TRY(job_.new_slot(&child.slot));
            kept_slots_.emplace_back(l, child.slot);  // reserved above
            job_.fill(*child.bits, 0);
            std::vector<Bind> refine = with(child_grid_bindings(parents, level_.grid),
                                            {{NFD_B_CHILD_BITS, *child.bits}});
            // A meshed level: the keep rule reads the values its mesher starts from, so it
            // also finds a UDF's near cells (refine_cells.comp's NFD_NEAR_MASKS) or classifies an
            // SDF's parents (NFD_MC_CASES) for the mesher.
            const bool meshed = (meshed_levels_ >> l & 1) != 0;
            const bool finds_near = meshed && field_ == FieldType::Udf;
            const bool classifies = meshed && field_ == FieldType::Sdf;
            LevelPush keep = push;
            Kernel kernel = Kernel::RefineCells;
            if (finds_near) {
                kernel = Kernel::RefineCellsNear;
                NFD_TRY(level_.near_buffers.make(VkDeviceSize(parents.capacity) * 4, &level_.near));
                job_.fill(*level_.near, 0);  // the mesher's scan runs over the capacity
                keep.edge_limit = udf_edge_limit(view.step);  // the mesher's (mesh_udf.cpp)
                refine = with(refine, {{NFD_B_NEAR_MASKS, *level_.near},
                                       {NFD_B_MC_TABLES, job_.device.mc_tables}});
            } else if (classifies) {
                kernel = Kernel::McClassify;
                NFD_TRY(level_.classified.make(job_, parents.capacity, nullptr));
                refine = with(with(refine, level_.classified.classify_bindings()),
                              {{NFD_B_MC_TABLES, job_.device.mc_tables}});
            }
            NFD_TRY(job_.dispatch(kernel, refine, &keep, parents.count()));
            NFD_TRY(record_scan(job_, scratch, *child.bits, *child.prefix, words, true));
            const uint32_t capacity =
                plan_ ? plan_->level_cells(l, child.cells) : UINT32_MAX;  // own: sized once known
            NFD_TRY(job_.total(*child.bits, *child.prefix, words, true, child.slot, capacity));
        }
    }
    NFD_TRY(job_.submit());
    if (job_.own && !empty) {
        level_.grid.count = job_.counter(level_.grid.slot);
        level_.points_evaluated += level_.grid.count + level_.predicted.count;
        if (l > 0) kept_.kept = job_.counter(kept_.slot);
    }
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

uint64_t LevelBuilder::next_step_device_bytes(bool mesh, bool udf, bool carried) const {
    if (done()) return 0;
    // Per kept cell K of this level: its list entry, corners and neighbour bits (40), its child
    // grid's masks, offsets and counts (12) and at most 19 new values (76); the points buffer of
    // a chunk; the scans' block sums (under 1/64 of what they scan, 8 bytes a block, twice for
    // nesting).
    const uint64_t k = kept_.kept, chunk = 1u << 20;
    const uint64_t child_level = current_ - 1;
    auto scan = [](uint64_t count) { return 16 * (count / 64 + 2); };
    // The job's counters and a block of indirect records, made by the first step: 32 KiB.
    uint64_t bytes = 40 * k + 12 * k + 76 * k + 12 * std::min(19 * k, chunk) + scan(k) + 32768;
    if (child_level > 0) {
        const uint64_t n = cells_at_level(resolution_, uint32_t(child_level));
        const uint64_t words = (n * n * n + 31) / 32;
        bytes += 8 * words + scan(words);
    }
    if (mesh) {
        // Classified (48 per parent), the emitting cells' list (8 per parent at most), the
        // vertex edges (4 + 12 + 12 bytes each), the triangles.
        bytes += 48 * k + 32 * k + 4 * scan(2 * k) + kMostVerticesPerParent * 28 * k +
                 most_triangles_per_parent() * 12 * k;
        // UDF: near masks, gradient masks, counts, offsets; value + gradient of at most 27
        // points per parent; a points chunk; the near cells' prefix and list (8 per parent at
        // most) with their scan.
        if (udf)
            bytes += 16 * k + 16 * 27 * k + 12 * std::min(27 * k, chunk) + scan(k) + 4 * k +
                     32 * k + scan(k);
        // A meshed UDF level: the predicted list (masks, offsets, values), capped, and above the
        // finest its joined value list; surface following's (evaluate_finest_flood) per parent:
        // visited, two fresh masks, claimed bits, 8 frontier entries, 19 claimed points; a
        // chunk's points and results.
        if (udf)
            bytes += 8 * k + std::min<uint64_t>(job_.device.predicted_list_bytes,
                                                16 * kNewPointsPerParent * k);
        if (udf && child_level > 0) bytes += 4 * kNewPointsPerParent * k;
        if (udf && child_level == 0 && follow_finest_)
            bytes += (16 + 32 + 4 * kNewPointsPerParent) * k +
                     28 * std::min<uint64_t>(kNewPointsPerParent * k, chunk);
        // Carried: the corners' indices in the list above, the fresh points' masks, offsets and
        // values, the second scan.
        if (udf && carried) bytes += 32 * k + 8 * k + 16 * 27 * k + scan(k);
    }
    return bytes;
}

}  // namespace nfd::gpu
