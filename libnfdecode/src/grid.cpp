// CPU reference of the sparse grid (grid.h). Each level keeps the list of cells it visits; their
// corners are collected in a blocked VertexSet, evaluated once. For a UDF the cells that may
// contain the surface pass their eight children to the next level, as the GPU path (gpu/) does;
// an SDF's levels below the coarsest follow the surface (grid_follow.cpp).
#include "grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "grid_eval.h"
#include "mc_tables.h"
#include "parallel.h"

namespace nfd {

#if defined(NFD_POPCNT_AT_RUN_TIME)
const bool kCpuHasPopcnt = (__builtin_cpu_init(), __builtin_cpu_supports("popcnt"));
#endif

namespace {

constexpr uint32_t kMinCoarse = 32;

// Collects and evaluates the corners of `cells`. Vertices with all-even coordinates were corners
// of the parent level (every child's even corners are its parent's corners) and are copied, not
// re-evaluated: one evaluation in eight saved.
void evaluate_level(const Network& net, const SparseGrid& grid, const GridLevel& parent,
                    unsigned threads, GridLevel* out, uint64_t* evaluated) {
    out->collect_corners();
    const uint32_t l = out->level;
    auto evaluator = make_evaluator(net, false, threads, [out](uint32_t r, float value, const float*) {
        out->values[r] = value;
    });
    out->vertices.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        if (((x | y | z) & 1) == 0) {
            out->values[r] = parent.values[parent.vertices.rank(x / 2, y / 2, z / 2)];
        } else {
            const float xyz[3] = {grid.coord(x << l), grid.coord(y << l), grid.coord(z << l)};
            evaluator.push(r, xyz);
        }
    });
    *evaluated += evaluator.finish();
}

// The coarsest level: every cell, the values evaluate_coarsest_level gives its vertices, and
// above the finest level its probe's verdicts.
void evaluate_coarsest(const Network& net, const SparseGrid& grid, unsigned threads, GridLevel* out,
                       uint64_t* evaluated) {
    const uint32_t n = out->cells_per_axis, side = n + 1;
    out->cells.reserve(size_t(n) * n * n);
    for (uint32_t z = 0; z < n; ++z)
        for (uint32_t y = 0; y < n; ++y)
            for (uint32_t x = 0; x < n; ++x) out->cells.push_back(pack_coords(x, y, z));
    out->collect_corners();
    nfd::vector<float> raster(size_t(side) * side * side);
    if (out->level > 0) {
        out->probe_cells = cells_at_level(grid.resolution, out->level + 1);
        out->probe_kept.assign(size_t(out->probe_cells) * out->probe_cells * out->probe_cells, 0);
    }
    *evaluated += evaluate_coarsest_level(net, grid.field, grid.resolution, out->level, threads,
                                          raster.data(),
                                          out->probe_kept.empty() ? nullptr : out->probe_kept.data());
    out->vertices.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        out->values[r] = raster[(size_t(z) * side + y) * side + x];
    });
}

// The keep rule's verdict on each cell of `level`, and the size of the level its kept cells'
// children form: their count, and the vertex blocks their corners (a 3^3 grid per kept cell)
// touch, marked in a bitmap of the child level's block table.
nfd::vector<uint8_t> keep_cells(const SparseGrid& grid, const GridLevel& level, LevelSize* next) {
    const uint32_t child_cells = cells_at_level(grid.resolution, level.level - 1);
    nfd::vector<uint8_t> kept(level.cells.size());
    ChildLevelSize size(child_cells);
    for (size_t i = 0; i < level.cells.size(); ++i) {
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        float f[8];
        level.corners(c, f);
        kept[i] = cell_may_contain_surface(f, keep_threshold(grid.field, level.cell_size));
        if (kept[i]) size.add_parent(c);
    }
    *next = size.size();
    return kept;
}

// The children of the kept cells of `level`, in order: allocated once at their count, since the
// finest level's list is the grid's largest array and growing it by doubling would double the peak.
nfd::vector<uint32_t> children_of(const SparseGrid& grid, const GridLevel& level,
                                  const nfd::vector<uint8_t>& kept, size_t count) {
    const uint32_t child_cells = cells_at_level(grid.resolution, level.level - 1);
    nfd::vector<uint32_t> children;
    children.reserve(count);
    for (size_t i = 0; i < level.cells.size(); ++i) {
        if (!kept[i]) continue;
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        for (const auto& o : mc::kCornerOffset) {
            const uint32_t x = 2 * c[0] + o[0], y = 2 * c[1] + o[1], z = 2 * c[2] + o[2];
            if (x < child_cells && y < child_cells && z < child_cells)
                children.push_back(pack_coords(x, y, z));
        }
    }
    return children;
}

}  // namespace

// ---- VertexSet ------------------------------------------------------------------------------

VertexSet::VertexSet(uint32_t side)
    : side_(side), blocks_per_axis_((side + 7) / 8),
      table_(size_t(blocks_per_axis_) * blocks_per_axis_ * blocks_per_axis_, kNoBlock) {}

// Blocks are appended on first touch, then sorted by index in finish(): ranks do not depend on
// the insertion order.
VertexSet::Block& VertexSet::block_for_insert(uint32_t x, uint32_t y, uint32_t z) {
    uint32_t& slot = table_[block_index(x, y, z)];
    if (slot == kNoBlock) {
        slot = uint32_t(blocks_.size());
        blocks_.push_back(Block{{}, {}, block_index(x, y, z)});
    }
    return blocks_[slot];
}

void VertexSet::insert(uint32_t x, uint32_t y, uint32_t z) {
    block_for_insert(x, y, z).words[z & 7] |= uint64_t(1) << ((x & 7) + 8 * (y & 7));
}

// The grid's levels insert their cells' corners this way: eight single inserts were 8% of a
// CPU decode, most of it the block table's lookups.
void VertexSet::insert_cell(uint32_t x, uint32_t y, uint32_t z) {
    if ((x & 7) == 7 || (y & 7) == 7) {
        for (const auto& o : mc::kCornerOffset) insert(x + o[0], y + o[1], z + o[2]);
        return;
    }
    const uint64_t square = uint64_t(0x303) << ((x & 7) + 8 * (y & 7));  // bits p, p+1, p+8, p+9
    block_for_insert(x, y, z).words[z & 7] |= square;
    block_for_insert(x, y, z + 1).words[(z + 1) & 7] |= square;
}

void VertexSet::finish() {
    std::sort(blocks_.begin(), blocks_.end(),
              [](const Block& a, const Block& b) { return a.index < b.index; });
    uint32_t total = 0;
    for (size_t s = 0; s < blocks_.size(); ++s) {
        Block& b = blocks_[s];
        table_[b.index] = uint32_t(s);
        for (int w = 0; w < 8; ++w) {
            b.prefix[w] = total;
            total += popcount64(b.words[w]);
        }
    }
    size_ = total;
}

uint64_t VertexSet::bytes_bound(uint32_t side, uint64_t blocks) {
    const uint64_t blocks_per_axis = (side + 7) / 8;
    const uint64_t table = blocks_per_axis * blocks_per_axis * blocks_per_axis;
    // blocks_ grows by push_back: its capacity stays under twice the blocks it holds; assign()
    // sizes it exactly and counts the blocks of each range of 4096 table entries.
    return 4 * table + 2 * sizeof(Block) * blocks + 4 * (table / 4096 + 2);
}

// ---- GridLevel -----------------------------------------------------------------------------

void GridLevel::collect_corners() {
    vertices = VertexSet(cells_per_axis + 1);
    for (uint32_t packed : cells) {
        uint32_t c[3];
        unpack_coords(packed, c);
        vertices.insert_cell(c[0], c[1], c[2]);
    }
    vertices.finish();
    values.assign(vertices.size(), 0.0f);
}

const uint8_t* GridLevel::meshed_cells(const uint8_t* among, nfd::vector<uint8_t>* storage) const {
    if (probe_kept.empty()) return among;
    storage->assign(cells.size(), 0);
    for (size_t i = 0; i < cells.size(); ++i) {
        uint32_t c[3];
        unpack_coords(cells[i], c);
        const size_t probe = (size_t(c[2] / 2) * probe_cells + c[1] / 2) * probe_cells + c[0] / 2;
        (*storage)[i] = probe_kept[probe] && (!among || among[i]);
    }
    return storage->data();
}

// ---- levels and rules ---------------------------------------------------------------------

ChildLevelSize::ChildLevelSize(uint32_t child_cells)
    : child_cells_(child_cells), blocks_per_axis_((child_cells + 1 + 7) / 8),
      touched_((uint64_t(blocks_per_axis_) * blocks_per_axis_ * blocks_per_axis_ + 63) / 64) {}

void ChildLevelSize::add_parent(const uint32_t c[3]) {
    ++parents_;
    cells_ += mark(c);
}

void ChildLevelSize::add_parents(const VertexSet& parents, unsigned threads) {
    nfd::vector<uint64_t> children(resolve_thread_count(threads));
    parallel_slices(parents.blocks(), 16, threads, [&](size_t t, size_t begin, size_t end) {
        parents.for_each_in_blocks(begin, end, [&](uint32_t, uint32_t x, uint32_t y, uint32_t z) {
            const uint32_t c[3] = {x, y, z};
            children[t] += mark(c);
        });
    });
    parents_ += parents.size();
    for (uint64_t count : children) cells_ += count;
}

uint64_t ChildLevelSize::mark(const uint32_t c[3]) {
    uint64_t cells = 0;
    for (const auto& o : mc::kCornerOffset)
        cells += 2 * c[0] + o[0] < child_cells_ && 2 * c[1] + o[1] < child_cells_ &&
                 2 * c[2] + o[2] < child_cells_;
    uint32_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = 2 * c[a] >> 3;
        hi[a] = std::min(2 * c[a] + 2, child_cells_) >> 3;
    }
    for (uint32_t z = lo[2]; z <= hi[2]; ++z)
        for (uint32_t y = lo[1]; y <= hi[1]; ++y)
            for (uint32_t x = lo[0]; x <= hi[0]; ++x) {
                const uint64_t b = (uint64_t(z) * blocks_per_axis_ + y) * blocks_per_axis_ + x;
                uint64_t* word = &touched_[b >> 6];
                const uint64_t bit = uint64_t(1) << (b & 63);
                // add_parents marks from several threads; most blocks are marked already.
                if (!(__atomic_load_n(word, __ATOMIC_RELAXED) & bit))
                    __atomic_fetch_or(word, bit, __ATOMIC_RELAXED);
            }
    return cells;
}

LevelSize ChildLevelSize::size() const {
    LevelSize s;
    const uint64_t side = child_cells_ + 1;
    s.cells_per_axis = child_cells_;
    s.cells = cells_;
    s.vertices = std::min<uint64_t>(27 * parents_, side * side * side);
    s.edges = std::min<uint64_t>(54 * parents_, 3 * s.vertices);
    for (uint64_t w : touched_) s.blocks += popcount64(w);
    return s;
}

uint64_t ChildLevelSize::bytes(uint32_t child_cells) {
    const uint64_t blocks_per_axis = (child_cells + 1 + 7) / 8;
    return 8 * ((blocks_per_axis * blocks_per_axis * blocks_per_axis + 63) / 64);
}

uint32_t cells_at_level(uint32_t resolution, uint32_t level) {
    return (resolution + (1u << level) - 1) >> level;
}

uint32_t refinement_levels(uint32_t resolution) {
    uint32_t levels = 0;
    while (levels < 31 && cells_at_level(resolution, levels + 1) >= kMinCoarse) ++levels;
    return levels;
}

uint32_t coarse_resolution(uint32_t resolution) {
    return cells_at_level(resolution, refinement_levels(resolution));
}

bool cell_may_contain_surface(const float corner_values[8], float threshold) {
    bool negative = false, positive = false;
    float min_abs = INFINITY;
    for (int k = 0; k < 8; ++k) {
        const float f = corner_values[k];
        negative |= f < 0.0f;
        positive |= f >= 0.0f;
        min_abs = std::min(min_abs, std::fabs(f));
    }
    return (negative && positive) || min_abs <= threshold;
}

uint32_t udf_valid_edges(const float corner_values[8], float h) {
    const float limit = udf_edge_limit(h);
    uint32_t valid = 0;
    for (int e = 0; e < 12; ++e) {
        const uint8_t* ends = mc::kEdgeCorners[e];
        const float sum = corner_values[ends[0]] + corner_values[ends[1]];
        valid |= uint32_t(sum <= limit) << e;
    }
    return valid;
}

bool udf_cell_is_near(const float corner_values[8], uint32_t valid_edges) {
    // A non-finite corner has no usable gradient or crossing: the cell is not meshed.
    for (int k = 0; k < 8; ++k)
        if (!std::isfinite(corner_values[k])) return false;
    return mc::tables().holds_triangle[valid_edges / 32] >> (valid_edges % 32) & 1;
}

bool udf_cell_is_near(const float corner_values[8], float h) {
    return udf_cell_is_near(corner_values, udf_valid_edges(corner_values, h));
}

uint64_t evaluate_coarsest_level(const Network& net, FieldType field, uint32_t resolution,
                                 uint32_t level, unsigned threads, float* values,
                                 uint8_t* probe_kept) {
    const uint32_t n = cells_at_level(resolution, level), side = n + 1;
    const uint32_t m = cells_at_level(resolution, level + 1);  // the probe's cells per axis
    const float step = 2.0f / float(resolution);
    auto index = [side](uint32_t x, uint32_t y, uint32_t z) {
        return (size_t(z) * side + y) * side + x;
    };
    // Per vertex: 0 = to fill, 1 = to evaluate next, 2 = evaluated.
    nfd::vector<uint8_t> state(size_t(side) * side * side, level == 0 ? 1 : 0);
    auto evaluate_marked = [&]() {
        const size_t count = size_t(std::count(state.begin(), state.end(), uint8_t(1)));
        nfd::vector<uint32_t> slots;
        nfd::vector<float> xyz;
        slots.reserve(count);
        xyz.reserve(3 * count);
        for (uint32_t z = 0; z < side; ++z)
            for (uint32_t y = 0; y < side; ++y)
                for (uint32_t x = 0; x < side; ++x) {
                    const size_t i = index(x, y, z);
                    if (state[i] != 1) continue;
                    slots.push_back(uint32_t(i));
                    for (uint32_t v : {x, y, z}) xyz.push_back(-1.0f + float(v << level) * step);
                }
        nfd::vector<float> out(slots.size());
        evaluate_cpu(net, xyz.data(), slots.size(), out.data(), threads);
        net.ball.bound(xyz.data(), slots.size(), out.data());
        for (size_t k = 0; k < slots.size(); ++k) {
            values[slots[k]] = out[k];
            state[slots[k]] = 2;
        }
        return uint64_t(slots.size());
    };
    const size_t probe_cells = size_t(m) * m * m;
    if (level == 0) {  // the coarsest level is the finest: all of it
        if (probe_kept) std::fill_n(probe_kept, probe_cells, uint8_t(1));
        return evaluate_marked();
    }
    for (uint32_t z = 0; z < side; z += 2)
        for (uint32_t y = 0; y < side; y += 2)
            for (uint32_t x = 0; x < side; x += 2) state[index(x, y, z)] = 1;
    uint64_t evaluated = evaluate_marked();
    const float threshold = keep_threshold(field, step * float(1u << (level + 1)));
    for (uint32_t c = 0; c < probe_cells; ++c) {
        const uint32_t p[3] = {c % m, c / m % m, c / m / m};
        bool kept = 2 * p[0] + 2 > n || 2 * p[1] + 2 > n || 2 * p[2] + 2 > n;
        if (!kept) {
            float f[8];
            for (int k = 0; k < 8; ++k) {
                const uint8_t* o = mc::kCornerOffset[k];
                f[k] = values[index(2 * (p[0] + o[0]), 2 * (p[1] + o[1]), 2 * (p[2] + o[2]))];
            }
            kept = cell_may_contain_surface(f, threshold);
        }
        if (probe_kept) probe_kept[c] = kept;
        if (!kept) continue;
        for (uint32_t dz = 0; dz < 3; ++dz)
            for (uint32_t dy = 0; dy < 3; ++dy)
                for (uint32_t dx = 0; dx < 3; ++dx) {
                    const uint32_t x = 2 * p[0] + dx, y = 2 * p[1] + dy, z = 2 * p[2] + dz;
                    if (x <= n && y <= n && z <= n && state[index(x, y, z)] == 0)
                        state[index(x, y, z)] = 1;
                }
    }
    evaluated += evaluate_marked();
    // The rest lie in probe cells that are not kept, so their probe neighbours are on the grid.
    auto around = [](uint32_t v) { return v & 1 ? 2u : 1u; };  // probe neighbours along an axis
    for (uint32_t z = 0; z < side; ++z)
        for (uint32_t y = 0; y < side; ++y)
            for (uint32_t x = 0; x < side; ++x) {
                if (state[index(x, y, z)] != 0) continue;
                float sum = 0.0f, scale = 1.0f;
                for (uint32_t a : {x, y, z}) scale *= a & 1 ? 0.5f : 1.0f;
                for (uint32_t k = 0; k < around(z); ++k)
                    for (uint32_t j = 0; j < around(y); ++j)
                        for (uint32_t i = 0; i < around(x); ++i)
                            sum += values[index(x & 1 ? x - 1 + 2 * i : x, y & 1 ? y - 1 + 2 * j : y,
                                                z & 1 ? z - 1 + 2 * k : z)];
                values[index(x, y, z)] = sum * scale;
            }
    return evaluated;
}

uint64_t evaluate_coarsest_level_bytes(const Network& net, uint32_t side, unsigned threads) {
    const uint64_t vertices = uint64_t(side) * side * side;
    // The marks, at most every vertex's slot, point and value, and the probe's verdicts (GridLevel
    // keeps them: fewer than one a vertex).
    return 2 * vertices + 20 * vertices + evaluate_scratch_bytes(net, false, threads);
}

// ---- the builder ---------------------------------------------------------------------------

GridBuilder::GridBuilder(const Geometry& geometry, uint32_t resolution, unsigned threads, bool band,
                         bool follow_finest, uint32_t gradient_levels)
    : network_(geometry.network), threads_(threads),
      follow_(!band), follow_finest_(band && follow_finest && geometry.field == FieldType::Udf),
      gradient_levels_(geometry.field == FieldType::Udf ? gradient_levels : 0) {
    grid_.resolution = resolution;
    grid_.step = 2.0f / float(resolution);
    grid_.field = geometry.field;
    grid_.truncation = geometry.truncation;
    current_ = refinement_levels(resolution);
    grid_.levels.resize(current_ + 1);
}

void GridBuilder::step() {
    const auto t0 = std::chrono::steady_clock::now();
    const uint32_t l = stepped_ ? current_ - 1 : current_;
    GridLevel& level = grid_.levels[l];
    level.level = l;
    level.cells_per_axis = cells_at_level(grid_.resolution, l);
    level.cell_size = grid_.step * float(1u << l);
    const GridLevel* parent = stepped_ ? &grid_.levels[l + 1] : nullptr;
    if (follows(l)) {
        follow_surface(network_, grid_, *parent, region_, next_.blocks, threads_, &level,
                       &grid_.stats.points_evaluated, flood_gradients(l));
        region_ = FollowRegion();
    } else {
        if (parent) {
            level.cells = children_of(grid_, *parent, kept_, next_.cells);
            kept_ = nfd::vector<uint8_t>();
            evaluate_level(network_, grid_, *parent, threads_, &level,
                           &grid_.stats.points_evaluated);
        } else {
            evaluate_coarsest(network_, grid_, threads_, &level, &grid_.stats.points_evaluated);
        }
    }
    if (followed_below(l))
        follow_region(grid_, level, &region_, &next_, !follow_, threads_,
                      region_near(l) ? &level.near : nullptr);
    else if (l > 0)
        kept_ = keep_cells(grid_, level, &next_);
    current_ = l;
    stepped_ = true;
    grid_.stats.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A vertex with all-even coordinates where the level above has gradients (it was meshed, in a
// progressive extraction) is the same f32 point as that level's vertex (x/2, y/2, z/2): its
// gradient is copied, not evaluated again. Those gradients are freed then; this level's stay for
// its mesh and the next level. The near test runs once per level (in follow_region above the
// finest, else here, on threads) and the near cells mark their corners; the mesher reads its
// verdicts, and finds the gradients by the ranks it has for the values.
void GridBuilder::evaluate_udf_gradients() {
    const auto t0 = std::chrono::steady_clock::now();
    GridLevel& level = grid_.levels[current_];
    GridLevel* above = current_ + 1 < grid_.levels.size() ? &grid_.levels[current_ + 1] : nullptr;
    nfd::vector<uint8_t>& near = level.near;
    nfd::vector<uint8_t>& flags = level.gradient_flags;
    nfd::vector<float>& gradients = level.gradients;
    if (flags.size() != level.vertices.size()) {  // not from the flood (follow_surface)
        flags.assign(level.vertices.size(), 0);
        gradients.assign(size_t(3) * level.vertices.size(), 0.0f);
    }
    // The near verdicts, unless follow_region gave them; then the near cells mark their corners.
    const bool judged = region_near(current_);
    if (!judged) near.assign(level.cells.size(), 0);
    parallel_for(level.cells.size(), 16384, threads_, [&](size_t begin, size_t end) {
        level.for_each_cell(begin, end, judged ? near.data() : nullptr,
                            [&](size_t i, const uint32_t*, const float* f, const uint32_t* r) {
                                if (!judged) {
                                    if (!udf_cell_is_near(f, level.cell_size)) return;
                                    near[i] = 1;
                                }
                                // Neighbouring cells on other threads mark shared corners
                                // too, all with the same value: no other bit changes here.
                                for (int k = 0; k < 8; ++k) {
                                    const uint8_t was = __atomic_load_n(&flags[r[k]], __ATOMIC_RELAXED);
                                    if (!(was & GridLevel::kNearCorner))
                                        __atomic_store_n(&flags[r[k]], uint8_t(was | GridLevel::kNearCorner),
                                                         __ATOMIC_RELAXED);
                                }
                            });
    });
    // By ranges of vertex blocks on threads, each with its own evaluator.
    auto store = [&gradients](uint32_t r, float, const float* g) {
        std::copy(g, g + 3, &gradients[size_t(3) * r]);
    };
    using Evaluator = decltype(make_slice_evaluator(network_, true, threads_, store));
    nfd::vector<Evaluator> evaluators;
    evaluators.reserve(resolve_thread_count(threads_));
    for (unsigned t = 0; t < resolve_thread_count(threads_); ++t)
        evaluators.push_back(make_slice_evaluator(network_, true, threads_, store));
    nfd::vector<uint64_t> own_corners(evaluators.size());  // per slice: gradients_evaluated
    parallel_slices(level.vertices.blocks(), 16, threads_, [&](size_t t, size_t begin, size_t end) {
        level.vertices.for_each_in_blocks(begin, end, [&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
            if (!(flags[r] & GridLevel::kNearCorner)) return;
            uint32_t known;
            const uint8_t from_above =
                above && ((x | y | z) & 1) == 0 && above->vertices.find(x / 2, y / 2, z / 2, &known) &&
                        known < above->gradient_flags.size()
                    ? above->gradient_flags[known]
                    : 0;
            own_corners[t] += !(from_above & GridLevel::kNearCorner);
            if (flags[r] & GridLevel::kGradientKnown) return;
            flags[r] |= GridLevel::kGradientKnown;
            if (from_above) {
                std::copy_n(&above->gradients[size_t(3) * known], 3, &gradients[size_t(3) * r]);
                return;
            }
            const float xyz[3] = {level.coord(x), level.coord(y), level.coord(z)};
            evaluators[t].push(r, xyz);
        });
        evaluators[t].finish();
    });
    for (uint64_t corners : own_corners) grid_.stats.gradients_evaluated += corners;
    for (uint32_t l = current_ + 1; l < grid_.levels.size(); ++l) {
        grid_.levels[l].near = nfd::vector<uint8_t>();
        grid_.levels[l].gradient_flags = nfd::vector<uint8_t>();
        grid_.levels[l].gradients = nfd::vector<float>();
    }
    grid_.stats.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

LevelSize GridBuilder::next_level_size() const {
    if (stepped_) return next_;
    LevelSize coarse;  // the first step: every cell and vertex of the coarse level
    const uint64_t n = cells_at_level(grid_.resolution, current_), side = n + 1;
    coarse.cells_per_axis = uint32_t(n);
    coarse.cells = n * n * n;
    coarse.vertices = side * side * side;
    coarse.edges = 3 * coarse.vertices;
    coarse.blocks = uint64_t((side + 7) / 8) * ((side + 7) / 8) * ((side + 7) / 8);
    return coarse;
}

uint64_t GridBuilder::next_step_bytes_bound() const {
    if (done()) return 0;
    const LevelSize next = next_level_size();
    const uint32_t level = stepped_ ? current_ - 1 : current_;
    // Its cells, its vertex set and values, the evaluator; surface following's flood below the
    // coarsest level; unless it is the finest, what decides the level after: the keep rule's
    // verdicts on it and the bitmap of the blocks of the level after (keep_cells), or the region.
    const bool gradients = flood_gradients(level);
    const uint64_t flood = follows(level) ? follow_surface_bytes_bound(
                                                next, grid_.levels[current_].vertices.size(),
                                                gradients, threads_)
                                          : 0;
    uint64_t refine = 0;
    if (followed_below(level)) {
        refine = follow_region_bytes_bound(next, cells_at_level(grid_.resolution, level - 1),
                                           !follow_) +
                 (region_near(level) ? next.cells : 0);  // the near verdicts
    } else if (level > 0) {
        refine = next.cells + ChildLevelSize::bytes(cells_at_level(grid_.resolution, level - 1));
    }
    // The coarsest level's values come in raster order first (evaluate_coarsest).
    const uint64_t evaluation =
        stepped_ ? evaluator_bytes(network_, next.vertices, gradients, threads_)
                 : 4 * next.vertices +
                       evaluate_coarsest_level_bytes(network_, next.cells_per_axis + 1, threads_);
    return 4 * next.cells + VertexSet::bytes_bound(next.cells_per_axis + 1, next.blocks) +
           4 * next.vertices + evaluation + flood + refine;
}

uint64_t GridBuilder::next_gradients_bytes_bound() const {
    if (done()) return 0;
    const LevelSize next = next_level_size();
    // The near verdicts; the flags and gradients, unless the level's flood made them
    // (follow_surface_bytes_bound counts them then).
    const bool from_flood = flood_gradients(stepped_ ? current_ - 1 : current_);
    return next.cells + (from_flood ? 0 : 13 * next.vertices) +
           evaluator_bytes(network_, next.vertices, true, threads_);
}

nfd_result build_grid_cpu(const Geometry& geometry, uint32_t resolution, const GridOptions& options,
                          SparseGrid* out, unsigned threads) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    GridBuilder builder(geometry, resolution, threads, options.band);
    const uint64_t limit = options.max_host_bytes;
    uint64_t held = 0;
    auto reserve = [&](uint64_t bytes) {
        held += bytes;
        return !limit || held <= limit;
    };
    do {
        if (!reserve(builder.next_step_bytes_bound())) return NFD_ERROR_LIMIT_EXCEEDED;
        builder.step();
    } while (!builder.done());
    if (options.udf_gradients) {
        if (!reserve(builder.next_gradients_bytes_bound())) return NFD_ERROR_LIMIT_EXCEEDED;
        builder.evaluate_udf_gradients();
    }
    const uint64_t voxels = builder.grid().levels.front().vertices.size();
    if (!reserve(voxels * options.bytes_per_voxel)) return NFD_ERROR_LIMIT_EXCEEDED;
    *out = builder.take();
    return NFD_SUCCESS;
}

}  // namespace nfd
