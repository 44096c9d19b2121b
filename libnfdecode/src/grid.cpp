// CPU reference of the sparse grid (grid.h). Each level keeps the list of cells it visits; their
// corners are collected in a blocked VertexSet, evaluated once, and the cells that may contain the
// surface pass their eight children to the next level. The GPU path (gpu/) mirrors this.
#include "grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "mc_tables.h"

namespace nfd {
namespace {

constexpr uint32_t kMinCoarse = 32;
constexpr size_t kEvalChunk = size_t(1) << 20;  // points per evaluate call: bounds scratch

// Evaluates points as they are pushed, kEvalChunk at a time, so that scratch memory does not
// grow with the level: push(slot, xyz) queues a point, and `store(slot, value, gradient)` takes
// its result at the next flush (gradient null unless `gradients`).
template <class Store>
class ChunkedEvaluator {
public:
    ChunkedEvaluator(const Network& net, bool gradients, unsigned threads, Store store)
        : net_(net), gradients_(gradients), threads_(threads), store_(std::move(store)) {}
    void push(uint32_t slot, const float xyz[3]) {
        if (slots_.empty()) reserve();
        slots_.push_back(slot);
        xyz_.insert(xyz_.end(), xyz, xyz + 3);
        if (slots_.size() == kEvalChunk) flush();
    }
    // Evaluates what is queued; returns the number of points evaluated since construction.
    uint64_t finish() {
        flush();
        return total_;
    }

private:
    void reserve() {
        slots_.reserve(kEvalChunk);
        xyz_.reserve(3 * kEvalChunk);
    }
    void flush() {
        const size_t n = slots_.size();
        if (n == 0) return;
        values_.resize(n);
        grad_.resize(gradients_ ? 3 * n : 0);
        if (gradients_)
            evaluate_gradient_cpu(net_, xyz_.data(), n, values_.data(), grad_.data(), threads_);
        else
            evaluate_cpu(net_, xyz_.data(), n, values_.data(), threads_);
        for (size_t k = 0; k < n; ++k) store_(slots_[k], values_[k], gradients_ ? &grad_[3 * k] : nullptr);
        total_ += n;
        slots_.clear();
        xyz_.clear();
    }
    const Network& net_;
    const bool gradients_;
    const unsigned threads_;
    Store store_;
    std::vector<uint32_t> slots_;
    std::vector<float> xyz_, values_, grad_;
    uint64_t total_ = 0;
};

template <class Store>
ChunkedEvaluator<Store> make_evaluator(const Network& net, bool gradients, unsigned threads,
                                       Store store) {
    return ChunkedEvaluator<Store>(net, gradients, threads, std::move(store));
}

// Collects and evaluates the corners of `cells`. Vertices with all-even coordinates were corners
// of the parent level (every child's even corners are its parent's corners) and are copied, not
// re-evaluated: one evaluation in eight saved.
void evaluate_level(const Network& net, const SparseGrid& grid, const GridLevel* parent,
                    unsigned threads, GridLevel* out, uint64_t* evaluated) {
    out->vertices = VertexSet(out->cells_per_axis + 1);
    for (uint32_t packed : out->cells) {
        uint32_t c[3];
        unpack_coords(packed, c);
        for (const auto& o : mc::kCornerOffset) out->vertices.insert(c[0] + o[0], c[1] + o[1], c[2] + o[2]);
    }
    out->vertices.finish();
    out->values.assign(out->vertices.size(), 0.0f);

    const uint32_t l = out->level;
    auto evaluator = make_evaluator(net, false, threads, [out](uint32_t r, float value, const float*) {
        out->values[r] = value;
    });
    out->vertices.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        if (parent && ((x | y | z) & 1) == 0) {
            out->values[r] = parent->values[parent->vertices.rank(x / 2, y / 2, z / 2)];
        } else {
            const float xyz[3] = {grid.coord(x << l), grid.coord(y << l), grid.coord(z << l)};
            evaluator.push(r, xyz);
        }
    });
    *evaluated += evaluator.finish();
}

// The keep rule's verdict on each cell of `level`, and the count of their children on the grid.
std::vector<uint8_t> keep_cells(const SparseGrid& grid, const GridLevel& level, size_t* children) {
    const uint32_t child_cells = cells_at_level(grid.resolution, level.level - 1);
    std::vector<uint8_t> kept(level.cells.size());
    size_t count = 0;
    for (size_t i = 0; i < level.cells.size(); ++i) {
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        float f[8];
        for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
        kept[i] = cell_may_contain_surface(f, level.cell_size);
        if (!kept[i]) continue;
        for (const auto& o : mc::kCornerOffset)
            count += 2 * c[0] + o[0] < child_cells && 2 * c[1] + o[1] < child_cells &&
                     2 * c[2] + o[2] < child_cells;
    }
    *children = count;
    return kept;
}

// The children of the kept cells of `level`, in order: allocated once at their count, since the
// finest level's list is the grid's largest array and growing it by doubling would double the peak.
std::vector<uint32_t> children_of(const SparseGrid& grid, const GridLevel& level,
                                  const std::vector<uint8_t>& kept, size_t count) {
    const uint32_t child_cells = cells_at_level(grid.resolution, level.level - 1);
    std::vector<uint32_t> children;
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

// The points one ChunkedEvaluator over `points` points holds: its queue and results at a chunk.
uint64_t evaluator_bytes(const Network& net, uint64_t points, bool gradients, unsigned threads) {
    if (points == 0) return 0;
    // slots_ and xyz_ are reserved at a full chunk; values_ and grad_ at the largest flush.
    const uint64_t flush = std::min<uint64_t>(points, kEvalChunk);
    return kEvalChunk * 16 + flush * (gradients ? 16 : 4) + evaluate_scratch_bytes(net, gradients, threads);
}

}  // namespace

// ---- VertexSet ------------------------------------------------------------------------------

VertexSet::VertexSet(uint32_t side)
    : side_(side), blocks_per_axis_((side + 7) / 8),
      table_(size_t(blocks_per_axis_) * blocks_per_axis_ * blocks_per_axis_, kNoBlock) {}

// Blocks are appended on first touch, then sorted by index in finish(): ranks do not depend on
// the insertion order.
void VertexSet::insert(uint32_t x, uint32_t y, uint32_t z) {
    uint32_t& slot = table_[block_index(x, y, z)];
    if (slot == kNoBlock) {
        slot = uint32_t(blocks_.size());
        blocks_.push_back(Block{{}, {}, block_index(x, y, z)});
    }
    blocks_[slot].words[z & 7] |= uint64_t(1) << ((x & 7) + 8 * (y & 7));
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
            total += uint32_t(__builtin_popcountll(b.words[w]));
        }
    }
    size_ = total;
}

uint32_t VertexSet::rank(uint32_t x, uint32_t y, uint32_t z) const {
    const Block& b = blocks_[table_[block_index(x, y, z)]];
    const uint64_t below = b.words[z & 7] & ((uint64_t(1) << ((x & 7) + 8 * (y & 7))) - 1);
    return b.prefix[z & 7] + uint32_t(__builtin_popcountll(below));
}

uint64_t VertexSet::bytes_bound(uint32_t side, uint64_t vertices) {
    const uint64_t blocks_per_axis = (side + 7) / 8;
    const uint64_t table = blocks_per_axis * blocks_per_axis * blocks_per_axis;
    // blocks_ grows by push_back: its capacity stays under twice the blocks it holds.
    return 4 * table + 2 * sizeof(Block) * std::min(table, vertices);
}

bool VertexSet::find(int64_t x, int64_t y, int64_t z, uint32_t* out_rank) const {
    if (x < 0 || y < 0 || z < 0 || x >= side_ || y >= side_ || z >= side_) return false;
    const uint32_t slot = table_[block_index(uint32_t(x), uint32_t(y), uint32_t(z))];
    if (slot == kNoBlock) return false;
    if (!(blocks_[slot].words[z & 7] >> ((x & 7) + 8 * (y & 7)) & 1)) return false;
    *out_rank = rank(uint32_t(x), uint32_t(y), uint32_t(z));
    return true;
}

// ---- levels and rules ---------------------------------------------------------------------

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

bool cell_may_contain_surface(const float corner_values[8], float h) {
    bool negative = false, positive = false;
    float min_abs = INFINITY;
    for (int k = 0; k < 8; ++k) {
        const float f = corner_values[k];
        negative |= f < 0.0f;
        positive |= f >= 0.0f;
        min_abs = std::min(min_abs, std::fabs(f));
    }
    return (negative && positive) || min_abs <= kLipschitzMargin * h * kHalfDiagonal;
}

bool udf_cell_is_near(const float corner_values[8], float h) {
    // A non-finite corner has no usable gradient or crossing: the cell is not meshed.
    float lowest = INFINITY;
    for (int k = 0; k < 8; ++k) {
        if (!std::isfinite(corner_values[k])) return false;
        lowest = std::min(lowest, corner_values[k]);
    }
    return lowest <= udf_near_threshold(h);
}

float GridLevel::corner(const uint32_t cell[3], int corner_index) const {
    const uint8_t* o = mc::kCornerOffset[corner_index];
    return values[vertices.rank(cell[0] + o[0], cell[1] + o[1], cell[2] + o[2])];
}

// ---- the builder ---------------------------------------------------------------------------

GridBuilder::GridBuilder(const Geometry& geometry, uint32_t resolution, unsigned threads)
    : network_(geometry.network), threads_(threads) {
    grid_.resolution = resolution;
    grid_.step = 2.0f / float(resolution);
    grid_.field = geometry.field;
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
    if (parent) {
        level.cells = children_of(grid_, *parent, kept_, children_);
        kept_ = std::vector<uint8_t>();
    } else {
        const uint32_t n = level.cells_per_axis;
        level.cells.reserve(size_t(n) * n * n);
        for (uint32_t z = 0; z < n; ++z)
            for (uint32_t y = 0; y < n; ++y)
                for (uint32_t x = 0; x < n; ++x) level.cells.push_back(pack_coords(x, y, z));
    }
    evaluate_level(network_, grid_, parent, threads_, &level, &grid_.stats.points_evaluated);
    if (l > 0) kept_ = keep_cells(grid_, level, &children_);
    current_ = l;
    stepped_ = true;
    grid_.stats.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A vertex with all-even coordinates where the level above has gradients (it was meshed, in a
// progressive extraction) is the same f32 point as that level's vertex (x/2, y/2, z/2): its
// gradient is copied, not evaluated again. Those gradients are freed then; this level's stay for
// its mesh and the next level.
void GridBuilder::evaluate_udf_gradients() {
    const auto t0 = std::chrono::steady_clock::now();
    GridLevel& level = grid_.levels[current_];
    GridLevel* above = current_ + 1 < grid_.levels.size() ? &grid_.levels[current_ + 1] : nullptr;
    VertexSet& wanted = level.gradient_vertices;
    wanted = VertexSet(level.cells_per_axis + 1);
    for (uint32_t packed : level.cells) {
        uint32_t c[3];
        unpack_coords(packed, c);
        float f[8];
        for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
        if (!udf_cell_is_near(f, level.cell_size)) continue;
        for (const auto& o : mc::kCornerOffset) wanted.insert(c[0] + o[0], c[1] + o[1], c[2] + o[2]);
    }
    wanted.finish();
    std::vector<float>& gradients = level.gradients;
    gradients.assign(size_t(3) * wanted.size(), 0.0f);
    auto evaluator = make_evaluator(network_, true, threads_, [&gradients](uint32_t r, float, const float* g) {
        std::copy(g, g + 3, &gradients[size_t(3) * r]);
    });
    wanted.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        uint32_t known;
        if (above && ((x | y | z) & 1) == 0 &&
            above->gradient_vertices.find(x / 2, y / 2, z / 2, &known)) {
            std::copy_n(&above->gradients[size_t(3) * known], 3, &gradients[size_t(3) * r]);
            return;
        }
        const float xyz[3] = {level.coord(x), level.coord(y), level.coord(z)};
        evaluator.push(r, xyz);
    });
    grid_.stats.gradients_evaluated += evaluator.finish();
    for (uint32_t l = current_ + 1; l < grid_.levels.size(); ++l) {
        grid_.levels[l].gradient_vertices = VertexSet();
        grid_.levels[l].gradients = std::vector<float>();
    }
    grid_.stats.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

uint32_t GridBuilder::next_cells_per_axis() const {
    return cells_at_level(grid_.resolution, stepped_ ? current_ - 1 : current_);
}

size_t GridBuilder::next_cells_bound() const {
    const size_t n = next_cells_per_axis();
    return stepped_ ? children_ : n * n * n;
}

uint64_t GridBuilder::next_step_bytes_bound() const {
    if (done()) return 0;
    const uint64_t cells = next_cells_bound();
    const uint32_t side = next_cells_per_axis() + 1;
    const uint64_t vertices = std::min<uint64_t>(8 * cells, uint64_t(side) * side * side);
    const bool refines = (stepped_ ? current_ - 1 : current_) > 0;
    return 4 * cells + VertexSet::bytes_bound(side, vertices) + 4 * vertices +
           evaluator_bytes(network_, vertices, false, threads_) + (refines ? cells : 0);
}

uint64_t GridBuilder::next_gradients_bytes_bound() const {
    if (done()) return 0;
    const uint64_t cells = next_cells_bound();
    const uint32_t side = next_cells_per_axis() + 1;
    const uint64_t vertices = std::min<uint64_t>(8 * cells, uint64_t(side) * side * side);
    return VertexSet::bytes_bound(side, vertices) + 12 * vertices +
           evaluator_bytes(network_, vertices, true, threads_);
}

nfd_result build_grid_cpu(const Geometry& geometry, uint32_t resolution, const GridOptions& options,
                          SparseGrid* out, unsigned threads) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    GridBuilder builder(geometry, resolution, threads);
    do builder.step();
    while (!builder.done());
    if (options.udf_gradients) builder.evaluate_udf_gradients();
    *out = builder.take();
    return NFD_SUCCESS;
}

}  // namespace nfd
