// CPU reference of the levels below the coarsest (grid.h, "Surface following"): the cells of a
// level are found from the crossed (SDF) or valid (UDF) edges of the level above and flooded across
// faces with a sign change and (above the finest level) out of cells near zero, or (UDF) across
// faces holding an edge close to valid, each corner evaluated once, inside a region sized before
// the level starts.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include "grid.h"
#include "grid_eval.h"
#include "mc_tables.h"
#include "parallel.h"

namespace nfd {
namespace {

// A corner is negative when f < 0; NaN counts as not negative, as in the mesher's case index.
bool has_sign_change(const float* f, int n) {
    bool negative = false, other = false;
    for (int k = 0; k < n; ++k) (f[k] < 0.0f ? negative : other) = true;
    return negative && other;
}
bool has_sign_change(const float f[8]) { return has_sign_change(f, 8); }
// Whether the eight corners of a cell all lie within `limit` of zero (NaN does not).
bool is_near_zero(const float f[8], float limit) {
    bool near = true;
    for (int k = 0; k < 8; ++k) near &= std::fabs(f[k]) < limit;
    return near;
}

// The edges of a cell whose ends' values sum to at most `limit`: bit e for edge e of
// mc::kEdgeCorners. NaN makes no edge pass.
uint32_t edges_within(const float f[8], float limit) {
    uint32_t within = 0;
    for (int e = 0; e < 12; ++e)
        within |= uint32_t(f[mc::kEdgeCorners[e][0]] + f[mc::kEdgeCorners[e][1]] <= limit) << e;
    return within;
}
// The edges of a cell whose ends differ in sign (f < 0 against not: NaN counts as not negative).
uint32_t crossed_edges(const float f[8]) {
    uint32_t crossed = 0;
    for (int e = 0; e < 12; ++e) {
        const bool a = f[mc::kEdgeCorners[e][0]] < 0.0f, b = f[mc::kEdgeCorners[e][1]] < 0.0f;
        crossed |= uint32_t(a != b) << e;
    }
    return crossed;
}

// Cells of a pass per thread, at least: smaller passes stay on the caller's thread, where starting
// a thread would cost more than the tests it takes over.
constexpr size_t kFloodGrain = 4096;
// Cells of a wave per thread when its slice also evaluates the corners it claims (~1 per cell):
// a thread pays for itself sooner.
constexpr size_t kClaimGrain = 1024;

// The corners of the face of a cell across which its neighbour lies, per face 2 * axis + side,
// and the edges of that face (mc::kEdgeCorners indices) as a mask.
constexpr uint8_t kFaceCorners[6][4] = {{0, 2, 4, 6}, {1, 3, 5, 7}, {0, 1, 4, 5},
                                        {2, 3, 6, 7}, {0, 1, 2, 3}, {4, 5, 6, 7}};
bool face_changes_sign(const float f[8], int face) {
    const float g[4] = {f[kFaceCorners[face][0]], f[kFaceCorners[face][1]],
                        f[kFaceCorners[face][2]], f[kFaceCorners[face][3]]};
    return has_sign_change(g, 4);
}
constexpr uint32_t face_edges(int face) {
    uint32_t mask = 0;
    for (int e = 0; e < 12; ++e) {
        const uint8_t a = mc::kEdgeCorners[e][0], b = mc::kEdgeCorners[e][1];
        const int axis = face / 2, side = face & 1;
        if (mc::kCornerOffset[a][axis] == side && mc::kCornerOffset[b][axis] == side)
            mask |= 1u << e;
    }
    return mask;
}
constexpr uint32_t kFaceEdges[6] = {face_edges(0), face_edges(1), face_edges(2),
                                    face_edges(3), face_edges(4), face_edges(5)};

// The child level while the flood grows it, by blocks of 8^3 vertices as VertexSet stores them:
// per block the vertices whose value is known or queued and the cells visited (a cell's bit is
// that of its lowest corner), kept apart from the values so that the flood's bit tests stay in
// cache. A slot is a block's index times 512 plus the vertex's place in it, z, y, x.
// Threads may make slots and claim bits at once (a claim is an atomic or, a block is made under a
// lock and published by its table entry); the reads that make no block run between such passes.
class FloodStore {
public:
    // `blocks`: at least the blocks it will touch (LevelSize::blocks): reserved, never moved.
    FloodStore(uint32_t side, uint64_t blocks)
        : per_axis_((side + 7) / 8), table_(size_t(per_axis_) * per_axis_ * per_axis_, kNoBlock) {
        bits_.reserve(blocks);
        block_index_.reserve(blocks);
        values_.reserve(512 * blocks);
    }
    static uint64_t bytes_bound(uint32_t side, uint64_t blocks) {
        const uint64_t per_axis = (side + 7) / 8;
        // The block table, the blocks, visited_cells' counts per range of the table.
        const uint64_t table = per_axis * per_axis * per_axis;
        return 4 * table + (sizeof(Bits) + 4 + 512 * 4) * blocks + 8 * (table / kListRange + 2);
    }
    uint32_t slot(uint32_t x, uint32_t y, uint32_t z) { return in_block(block(x, y, z), x, y, z); }
    // The slots of the corners of cell (x, y, z), mc::kCornerOffset order: one block lookup
    // where the cell lies inside a block (343 cells in 512), and then true.
    bool cell_slots(uint32_t x, uint32_t y, uint32_t z, uint32_t s[8]) {
        return corner_slots(x, y, z, s,
                            [this](uint32_t u, uint32_t v, uint32_t w) { return slot(u, v, w); });
    }
    // The same for a cell whose corners are known: it makes no block, so threads may share it.
    void known_cell_slots(uint32_t x, uint32_t y, uint32_t z, uint32_t s[8]) const {
        corner_slots(x, y, z, s, [this](uint32_t u, uint32_t v, uint32_t w) {
            return in_block(table_[block_index(u, v, w)], u, v, w);
        });
    }
    // Marks the corners of the cell whose corner slots are `s` (cell_slots, `in_block` what it
    // returned) known and calls fn(k) for each corner k that was not: in a block, two words.
    // Of threads claiming a corner at once, one gets fn.
    template <class Fn>
    void claim_corners(const uint32_t s[8], bool in_block, Fn&& fn) {
        if (!in_block) {
            for (int k = 0; k < 8; ++k)
                if (claim_known(s[k])) fn(k);
            return;
        }
        uint64_t* words = bits_[s[0] >> 9].known;
        const uint32_t w = s[0] >> 6 & 7, p = s[0] & 63;
        const uint64_t mask = uint64_t(0x303) << p;
        if ((__atomic_load_n(&words[w], __ATOMIC_RELAXED) & mask) == mask &&
            (__atomic_load_n(&words[w + 1], __ATOMIC_RELAXED) & mask) == mask)
            return;  // the common case: a neighbour claimed all eight
        const uint64_t lower = ~__atomic_fetch_or(&words[w], mask, __ATOMIC_RELAXED) >> p & 0x303,
                       upper = ~__atomic_fetch_or(&words[w + 1], mask, __ATOMIC_RELAXED) >> p & 0x303;
        for (int k = 0; k < 4; ++k) {
            const uint32_t bit = (k & 1) + 8 * (k >> 1);
            if (lower >> bit & 1) fn(k);
            if (upper >> bit & 1) fn(k + 4);
        }
    }
    // The corners of the visited cells in the block at `index` of the block table, VertexSet's
    // words (VertexSet::assign): the cells of this block and those of its lower neighbours
    // across x, y and z that touch it. Every corner of a visited cell was claimed, so a block
    // that was never made has none. Makes no block.
    bool corner_words(size_t index, uint64_t out[8]) const {
        std::memset(out, 0, 8 * sizeof(uint64_t));
        if (table_[index] == kNoBlock) return false;
        uint32_t block[3];
        block_coords(index, block);
        const uint32_t bx = block[0], by = block[1], bz = block[2];
        // The visited words of block (bx - dx, by - dy, bz - dz), or null.
        auto cells = [&](uint32_t dx, uint32_t dy, uint32_t dz) -> const uint64_t* {
            if (dx > bx || dy > by || dz > bz) return nullptr;
            const uint32_t b = table_[(size_t(bz - dz) * per_axis_ + (by - dy)) * per_axis_ + (bx - dx)];
            return b == kNoBlock ? nullptr : bits_[b].visited;
        };
        constexpr uint64_t kLastX = 0x8080808080808080ull, kLastY = 0xFF00000000000000ull;
        for (uint32_t dz = 0; dz < 2; ++dz) {
            const uint64_t *same = cells(0, 0, dz), *below_x = cells(1, 0, dz),
                           *below_y = cells(0, 1, dz), *below_xy = cells(1, 1, dz);
            // A layer of cells puts corners on its own layer of vertices and on the next; the
            // lower z block's last layer on this block's first.
            for (uint32_t z = dz ? 7 : 0; z < 8; ++z) {
                uint64_t corners = 0;
                if (same) {
                    const uint64_t v = same[z];
                    corners |= v | (v & ~kLastX) << 1 | (v & ~kLastY) << 8 | (v & ~kLastX & ~kLastY) << 9;
                }
                if (below_x) {  // its cells at x = 7: corners at x = 0 here, rows y and y + 1
                    const uint64_t v = below_x[z] & kLastX;
                    corners |= v >> 7 | (v & ~kLastY) << 1;
                }
                if (below_y) {  // its cells at y = 7: corners at y = 0 here, columns x and x + 1
                    const uint64_t v = below_y[z] & kLastY;
                    corners |= v >> 56 | (v & ~kLastX) >> 55;
                }
                if (below_xy) corners |= below_xy[z] >> 63;  // its cell (7, 7): corner (0, 0)
                if (dz) {
                    out[0] |= corners;
                } else {
                    out[z] |= corners;
                    if (z < 7) out[z + 1] |= corners;
                }
            }
        }
        uint64_t any = 0;
        for (int w = 0; w < 8; ++w) any |= out[w];
        return any != 0;
    }
    // Whether cell (x, y, z) was visited; makes no block.
    bool visited(uint32_t x, uint32_t y, uint32_t z) const {
        const uint32_t b = table_[block_index(x, y, z)];
        return b != kNoBlock && bits_[b].visited[z & 7] >> ((x & 7) + 8 * (y & 7)) & 1;
    }
    // Marks vertex `s` known, or the cell at it visited; false if it was already.
    bool claim_known(uint32_t s) { return claim(bits_[s >> 9].known, s); }
    bool claim_visited(uint32_t s) { return claim(bits_[s >> 9].visited, s); }
    float& value(uint32_t s) { return values_[s]; }
    float value(uint32_t s) const { return values_[s]; }
    // The value at vertex (x, y, z) of a block that exists (the vertex was claimed): makes no
    // block, so threads may share it.
    float known_value(uint32_t x, uint32_t y, uint32_t z) const {
        return values_[in_block(table_[block_index(x, y, z)], x, y, z)];
    }
    // The vertex at slot `s` of a block that exists.
    void vertex(uint32_t s, uint32_t v[3]) const {
        block_coords(block_index_[s >> 9], v);
        for (int a = 0; a < 3; ++a) v[a] = 8 * v[a] + (s >> 3 * a & 7);
    }
    // The visited cells, packed: blocks in raster order, inside a block by 2^3 groups in raster
    // order, and a group in mc::kCornerOffset order. So a parent's children are consecutive, a
    // sibling group where all eight were visited (marching.h). Ranges of the block table count
    // their cells, then write them after the ranges before, on threads.
    void visited_cells(nfd::vector<uint32_t>* cells, unsigned threads) const {
        const size_t ranges = (table_.size() + kListRange - 1) / kListRange;
        nfd::vector<size_t> first(ranges + 1);
        for_each_range(table_.size(), kListRange, threads, [&](size_t g, size_t begin, size_t end) {
            size_t count = 0;
            for (size_t t = begin; t < end; ++t)
                if (table_[t] != kNoBlock)
                    for (uint64_t w : bits_[table_[t]].visited) count += popcount64(w);
            first[g + 1] = count;
        });
        for (size_t g = 0; g < ranges; ++g) first[g + 1] += first[g];
        cells->resize(first[ranges]);
        for_each_range(table_.size(), kListRange, threads, [&](size_t g, size_t begin, size_t end) {
            uint32_t* out = cells->data() + first[g];
            for (size_t t = begin; t < end; ++t) {
                if (table_[t] == kNoBlock) continue;
                uint32_t block[3];
                block_coords(t, block);
                const uint32_t bx = block[0], by = block[1], bz = block[2];
                const Bits& b = bits_[table_[t]];
                for (uint32_t group = 0; group < 64; ++group) {
                    const uint32_t gx = 2 * (group & 3), gy = 2 * (group >> 2 & 3), gz = 2 * (group >> 4);
                    for (const auto& o : mc::kCornerOffset) {
                        const uint32_t x = gx + o[0], y = gy + o[1], z = gz + o[2];
                        if (b.visited[z] >> (x + 8 * y) & 1)
                            *out++ = pack_coords(8 * bx + x, 8 * by + y, 8 * bz + z);
                    }
                }
            }
        });
    }

private:
    static constexpr uint32_t kNoBlock = ~0u;
    static constexpr uint32_t kCornerStep[8] = {0, 1, 8, 9, 64, 65, 72, 73};
    static constexpr size_t kListRange = 1024;  // block table entries per range of visited_cells
    struct Bits {
        uint64_t known[8], visited[8];
    };
    size_t block_index(uint32_t x, uint32_t y, uint32_t z) const {
        return (size_t(z >> 3) * per_axis_ + (y >> 3)) * per_axis_ + (x >> 3);
    }
    // The block at `index` of the table, in blocks per axis (block_index's inverse).
    void block_coords(size_t index, uint32_t b[3]) const {
        b[0] = uint32_t(index % per_axis_);
        b[1] = uint32_t(index / per_axis_ % per_axis_);
        b[2] = uint32_t(index / (size_t(per_axis_) * per_axis_));
    }
    static uint32_t in_block(uint32_t block, uint32_t x, uint32_t y, uint32_t z) {
        return block << 9 | (z & 7) << 6 | (y & 7) << 3 | (x & 7);
    }
    template <class SlotFn>
    static bool corner_slots(uint32_t x, uint32_t y, uint32_t z, uint32_t s[8], SlotFn&& slot) {
        if ((x & 7) == 7 || (y & 7) == 7 || (z & 7) == 7) {
            for (int k = 0; k < 8; ++k) {
                const uint8_t* o = mc::kCornerOffset[k];
                s[k] = slot(x + o[0], y + o[1], z + o[2]);
            }
            return false;
        }
        const uint32_t base = slot(x, y, z);
        for (int k = 0; k < 8; ++k) s[k] = base + kCornerStep[k];
        return true;
    }
    uint32_t block(uint32_t x, uint32_t y, uint32_t z) {
        uint32_t* entry = &table_[block_index(x, y, z)];
        uint32_t b = __atomic_load_n(entry, __ATOMIC_ACQUIRE);
        if (b != kNoBlock) return b;
        std::lock_guard<std::mutex> lock(grow_);
        b = __atomic_load_n(entry, __ATOMIC_RELAXED);
        if (b != kNoBlock) return b;
        // Threads read the blocks while one is made: the storage must not move.
        if (bits_.size() == bits_.capacity()) throw std::length_error("FloodStore: blocks past the bound");
        b = uint32_t(bits_.size());
        bits_.push_back(Bits{});
        block_index_.push_back(uint32_t(block_index(x, y, z)));
        values_.resize(values_.size() + 512);
        __atomic_store_n(entry, b, __ATOMIC_RELEASE);
        return b;
    }
    static bool claim(uint64_t* words, uint32_t s) {
        uint64_t* word = &words[s >> 6 & 7];
        const uint64_t bit = uint64_t(1) << (s & 63);
        if (__atomic_load_n(word, __ATOMIC_RELAXED) & bit) return false;
        return !(__atomic_fetch_or(word, bit, __ATOMIC_RELAXED) & bit);
    }
    std::mutex grow_;
    uint32_t per_axis_;
    nfd::vector<uint32_t> table_;
    nfd::vector<Bits> bits_;
    nfd::vector<uint32_t> block_index_;  // per block: its index in the table
    nfd::vector<float> values_;
};

// The gradients a flood evaluates (follow_surface's `with_gradients`), per slice as they come:
// (slot, gradient) records in chunks of fixed capacity, so that what grows is never copied and
// only the pages written are touched; the level's ranks exist only once the flood is over.
class GradientRecords {
public:
    struct Record {
        uint32_t slot;
        float gradient[3];
    };
    static constexpr size_t kChunk = 4096;  // records: 64 KiB
    static uint64_t bytes_bound(uint64_t records, unsigned threads) {
        const uint64_t slices = resolve_thread_count(threads);
        const uint64_t chunks = records / kChunk + slices;  // a partial chunk per slice at most
        return chunks * kChunk * sizeof(Record) + 2 * chunks * sizeof(nfd::vector<Record>);
    }
    void add(uint32_t slot, const float g[3]) {
        if (chunks_.empty() || chunks_.back().size() == kChunk) {
            chunks_.emplace_back();
            chunks_.back().reserve(kChunk);
        }
        chunks_.back().push_back(Record{slot, {g[0], g[1], g[2]}});
    }
    template <class Fn>
    void for_each(Fn&& fn) const {
        for (const nfd::vector<Record>& chunk : chunks_)
            for (const Record& record : chunk) fn(record);
    }

private:
    nfd::vector<nfd::vector<Record>> chunks_;
};

// A set of a level's cells as bits in the blocks of the level's vertex set (a cell is named by
// its lowest corner, a vertex of the level): VertexSet's words, one group of eight per block slot.
// Threads may set bits at once.
class CellBits {
public:
    // `used` false: an empty set that holds no memory (and must not be used).
    explicit CellBits(const VertexSet& vertices, bool used = true)
        : vertices_(vertices), words_(used ? size_t(8) * vertices.blocks() : 0) {}
    static uint64_t bytes(uint64_t blocks) { return 64 * blocks; }
    void set(const uint32_t c[3]) {
        const uint32_t slot = vertices_.block_slot(c[0] >> 3, c[1] >> 3, c[2] >> 3);
        __atomic_fetch_or(&words_[size_t(8) * slot + (c[2] & 7)], bit(c), __ATOMIC_RELAXED);
    }
    bool has(int64_t x, int64_t y, int64_t z) const {
        const uint64_t* w = words(x >> 3, y >> 3, z >> 3);  // arithmetic shift: -1 stays off the grid
        return w && w[z & 7] >> ((x & 7) + 8 * (y & 7)) & 1;
    }
    // The words of block (bx, by, bz), or null where the level has no vertex there.
    const uint64_t* words(int64_t bx, int64_t by, int64_t bz) const {
        const uint32_t slot = vertices_.block_slot(bx, by, bz);
        return slot == VertexSet::kNoBlock ? nullptr : &words_[size_t(8) * slot];
    }
    // The cells within one cell (the 3^3 around each) of a cell in the set, below `n` on each
    // axis, in block `index` of the table: VertexSet::assign's words. x, then y, then z, each
    // across the block's faces.
    bool dilated_words(size_t index, uint32_t n, uint64_t out[8]) const {
        constexpr uint64_t kFirstX = 0x0101010101010101ull, kLastX = kFirstX << 7;
        const int64_t m = vertices_.blocks_per_axis(), bx = int64_t(index % m), by = int64_t(index / m % m),
                      bz = int64_t(index / (m * m));
        uint64_t along_x[3][3][8], along_y[3][8];
        bool any = false;
        for (int dz = 0; dz < 3; ++dz)
            for (int dy = 0; dy < 3; ++dy) {
                const uint64_t* mid = words(bx, by + dy - 1, bz + dz - 1);
                const uint64_t* low = words(bx - 1, by + dy - 1, bz + dz - 1);
                const uint64_t* high = words(bx + 1, by + dy - 1, bz + dz - 1);
                for (int z = 0; z < 8; ++z) {
                    const uint64_t v = mid ? mid[z] : 0;
                    along_x[dz][dy][z] = v | (v & ~kLastX) << 1 | (v & ~kFirstX) >> 1 |
                                         (low ? (low[z] & kLastX) >> 7 : 0) |
                                         (high ? (high[z] & kFirstX) << 7 : 0);
                    any |= along_x[dz][dy][z] != 0;
                }
            }
        if (!any) {
            std::memset(out, 0, 8 * sizeof(uint64_t));
            return false;
        }
        for (int dz = 0; dz < 3; ++dz)
            for (int z = 0; z < 8; ++z) {
                const uint64_t v = along_x[dz][1][z];
                along_y[dz][z] = v | v << 8 | v >> 8 | along_x[dz][0][z] >> 56 | along_x[dz][2][z] << 56;
            }
        // Cells past the level's last (n - 1) on an axis are not cells.
        uint64_t keep = ~uint64_t(0);
        for (int64_t i = 0; i < 8; ++i) {
            if (8 * bx + i >= n) keep &= ~(kFirstX << i);
            if (8 * by + i >= n) keep &= ~(uint64_t(0xFF) << (8 * i));
        }
        uint64_t set = 0;
        for (int z = 0; z < 8; ++z) {
            const uint64_t below = z > 0 ? along_y[1][z - 1] : along_y[0][7];
            const uint64_t above = z < 7 ? along_y[1][z + 1] : along_y[2][0];
            out[z] = 8 * bz + z < n ? (along_y[1][z] | below | above) & keep : 0;
            set |= out[z];
        }
        return set != 0;
    }

private:
    static uint64_t bit(const uint32_t c[3]) { return uint64_t(1) << ((c[0] & 7) + 8 * (c[1] & 7)); }
    const VertexSet& vertices_;
    nfd::vector<uint64_t> words_;
};

}  // namespace

void follow_region(const SparseGrid& grid, const GridLevel& level, FollowRegion* region,
                   LevelSize* next, bool within_kept, unsigned threads,
                   nfd::vector<uint8_t>* near) {
    const uint32_t n = level.cells_per_axis;
    const float threshold = isolated_threshold(grid.field, level.level, grid.step, grid.truncation);
    const bool udf = grid.field == FieldType::Udf;
    // Each cell's verdict on threads: followed, or a candidate of step 3 (not followed, may hold
    // the surface); the followed cells (with `within_kept`, also the candidates: `kept`) as bits.
    constexpr uint8_t kFollowed = 1, kCandidate = 2, kIsolated = 4;
    nfd::vector<uint8_t> verdict(level.cells.size());
    CellBits followed(level.vertices), kept(level.vertices, within_kept);
    if (near) near->assign(level.cells.size(), 0);
    parallel_for(level.cells.size(), kFloodGrain, threads, [&](size_t begin, size_t end) {
        level.for_each_cell(begin, end, nullptr, [&](size_t i, const uint32_t* c, const float* f, const uint32_t*) {
            // A level grows from a sign change (SDF) or a valid edge (UDF).
            const uint32_t valid = udf ? udf_valid_edges(f, level.cell_size) : 0;
            if (udf ? valid != 0 : has_sign_change(f)) {
                verdict[i] = kFollowed;
                followed.set(c);
                if (near) (*near)[i] = udf_cell_is_near(f, valid);
            } else if (cell_may_contain_surface(f, threshold)) {
                verdict[i] = kCandidate;
            } else {
                return;
            }
            if (within_kept) kept.set(c);
        });
    });
    // The region: the followed cells and their 26 neighbours, or with `within_kept` the kept cells
    // (a followed cell is kept: a valid edge's ends average <= 0.75 h).
    region->parents = VertexSet(n + 1);
    region->parents.assign(
        [&](size_t index, uint64_t words[8]) {
            if (!within_kept) return followed.dilated_words(index, n, words);
            const int64_t m = region->parents.blocks_per_axis();
            const uint64_t* w = kept.words(int64_t(index % m), int64_t(index / m % m), int64_t(index / (m * m)));
            uint64_t any = 0;
            for (int z = 0; z < 8; ++z) any |= words[z] = w ? w[z] : 0;
            return any != 0;
        },
        threads);
    // The isolated candidates: no followed cell among their 26 neighbours (so, without
    // `within_kept`, not in the region). Listed in the level's order.
    parallel_for(level.cells.size(), kFloodGrain, threads, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            if (verdict[i] != kCandidate) continue;
            uint32_t c[3], r;
            unpack_coords(level.cells[i], c);
            bool beside = false;
            if (!within_kept) {
                beside = region->parents.find(c[0], c[1], c[2], &r);
            } else {
                for (int k = 0; k < 27 && !beside; ++k)
                    beside = followed.has(int64_t(c[0]) + k % 3 - 1, int64_t(c[1]) + k / 3 % 3 - 1,
                                          int64_t(c[2]) + k / 9 - 1);
            }
            if (!beside) verdict[i] = kIsolated;
        }
    });
    nfd::vector<uint32_t>& isolated = region->refine_all;
    isolated = nfd::vector<uint32_t>(size_t(std::count(verdict.begin(), verdict.end(), kIsolated)));
    for (size_t i = 0, j = 0; i < level.cells.size(); ++i)
        if (verdict[i] == kIsolated) isolated[j++] = level.cells[i];

    // The next level's size: the children of the region's cells (within_kept: the isolated
    // cells are among them).
    ChildLevelSize size(cells_at_level(grid.resolution, level.level - 1));
    size.add_parents(region->parents, threads);
    for (size_t i = 0; !within_kept && i < isolated.size(); ++i) {
        uint32_t c[3];
        unpack_coords(isolated[i], c);
        size.add_parent(c);
    }
    *next = size.size();
}

uint64_t follow_region_bytes_bound(const LevelSize& level, uint32_t child_cells,
                                   bool within_kept) {
    // The region's cell set, whose cells lie in the level's vertex blocks or beside them; the
    // cells' verdicts and the isolated ones' list; the next level's block bitmap; the followed
    // cells' bits in the level's blocks and, within_kept, the kept ones'.
    const uint64_t per_axis = (level.cells_per_axis + 1 + 7) / 8;
    const uint64_t region_blocks = std::min(27 * level.blocks, per_axis * per_axis * per_axis);
    return VertexSet::bytes_bound(level.cells_per_axis + 1, region_blocks) + 5 * level.cells +
           ChildLevelSize::bytes(child_cells) + CellBits::bytes(level.blocks) * (within_kept ? 2 : 1);
}

uint64_t follow_surface_bytes_bound(const LevelSize& next, uint64_t parent_vertices,
                                    bool with_gradients, unsigned threads) {
    // The flood's store, its two frontiers (each at most the level's cells, grown by doubling),
    // a wave's face masks, a UDF's seeded-parent bits (an SDF's near-zero vertices to seed around),
    // the parents' edge masks and seeds (a parent cell's lowest corner is one of its vertices:
    // no more cells than vertices); with gradients, their records (at most one per vertex), the
    // level's flags and gradients.
    const uint64_t gradients =
        with_gradients ? GradientRecords::bytes_bound(next.vertices, threads) + 13 * next.vertices : 0;
    return FloodStore::bytes_bound(next.cells_per_axis + 1, next.blocks) + 17 * next.cells +
           (parent_vertices + 63) / 64 * 8 + 6 * parent_vertices + gradients;
}

void follow_surface(const Network& net, const SparseGrid& grid, const GridLevel& parent,
                    const FollowRegion& region, uint64_t blocks, unsigned threads,
                    GridLevel* out, uint64_t* evaluated, bool with_gradients) {
    const uint32_t n = out->cells_per_axis, l = out->level;
    FloodStore store(n + 1, blocks);
    // Every pass runs on threads, a slice each (parallel_slices): the slice claims corners and
    // evaluates the ones it claimed on its own thread, with its share of the evaluator's chunk, and
    // collects the cells it visits. A cell or corner is claimed once, whichever slice gets it: the
    // flood reaches the same cells and evaluates the same points in any order, and the level is
    // read out in raster order (FloodStore::visited_cells).
    nfd::vector<GradientRecords> records(resolve_thread_count(threads));
    struct StoreValue {
        FloodStore* store;
        GradientRecords* records;
        void operator()(uint32_t slot, float value, const float* gradient) const {
            store->value(slot) = value;
            if (gradient) records->add(slot, gradient);
        }
    };
    struct Slice {
        decltype(make_slice_evaluator(net, false, threads, StoreValue{})) evaluator;
        nfd::vector<uint32_t> visits;  // the next wave's cells this slice found
    };
    nfd::vector<Slice> slices;
    slices.reserve(records.size());
    for (GradientRecords& slice_records : records)
        slices.push_back(Slice{
            make_slice_evaluator(net, with_gradients, threads, StoreValue{&store, &slice_records}), {}});
    // The value of vertex (x, y, z) at slot s, just claimed: a corner of the parent level is
    // copied, any other queued.
    auto fetch = [&](Slice& slice, uint32_t s, uint32_t x, uint32_t y, uint32_t z) {
        uint32_t r;
        if (((x | y | z) & 1) == 0 && parent.vertices.find(x / 2, y / 2, z / 2, &r)) {
            store.value(s) = parent.values[r];
        } else {
            const float xyz[3] = {grid.coord(x << l), grid.coord(y << l), grid.coord(z << l)};
            slice.evaluator.push(s, xyz);
        }
    };
    auto visit = [&](Slice& slice, uint32_t x, uint32_t y, uint32_t z) {
        if (x < n && y < n && z < n && store.claim_visited(store.slot(x, y, z))) {
            slice.visits.push_back(pack_coords(x, y, z));
        }
    };
    nfd::vector<uint32_t> wave;
    // The slices' visits, in slice order, become the next wave.
    auto gather = [&] {
        wave.clear();
        for (Slice& slice : slices) {
            wave.insert(wave.end(), slice.visits.begin(), slice.visits.end());
            slice.visits.clear();
        }
    };
    nfd::vector<uint8_t> through;  // per cell of a wave: the faces it floods through (bit = face)

    // Seeds. SDF: the midpoint of each crossed edge of a parent with a sign change tells which
    // half the surface crosses; the parent's child holding that half has a sign change. UDF: each
    // valid edge of a parent (at the parent's size) has its midpoint evaluated, and the child
    // holding each half that is valid at this level's size is a seed; where a distance field's
    // surface crosses the edge, the half it crosses is. A parent edge is shared by up to four
    // parents, which evaluate its midpoint once and agree.
    const bool udf = grid.field == FieldType::Udf;
    // Each parent's crossed (SDF) or valid (UDF) edges, bit k for edge k, found once: the passes
    // below read them, and only the parents with some read their corners again.
    nfd::vector<uint16_t> parent_edges(parent.cells.size());
    parallel_for(parent.cells.size(), kFloodGrain, threads, [&](size_t begin, size_t end) {
        parent.for_each_cell(begin, end, nullptr, [&](size_t i, const uint32_t*, const float* f, const uint32_t*) {
            parent_edges[i] = uint16_t(udf ? udf_valid_edges(f, parent.cell_size) : crossed_edges(f));
        });
    });
    // The midpoint of edge k of parent cell c, a vertex of this level; false past the level's
    // last vertex (an odd cell count), where the half's cells are dropped.
    auto edge_midpoint = [n](const uint32_t c[3], int k, uint32_t middle[3]) {
        const uint8_t* lower = mc::kCornerOffset[mc::kEdgeCorners[k][0]];
        for (int i = 0; i < 3; ++i) middle[i] = 2 * (c[i] + lower[i]);
        ++middle[k / 4];
        return middle[0] <= n && middle[1] <= n && middle[2] <= n;
    };
    parallel_slices(parent.cells.size(), kFloodGrain, threads, [&](size_t t, size_t begin, size_t end) {
        for (size_t cell = begin; cell < end; ++cell) {
            const uint32_t edges = parent_edges[cell];
            if (!edges) continue;
            uint32_t c[3], m[3];
            unpack_coords(parent.cells[cell], c);
            for (int k = 0; k < 12; ++k) {
                if (!(edges >> k & 1) || !edge_midpoint(c, k, m)) continue;
                const uint32_t slot = store.slot(m[0], m[1], m[2]);
                if (store.claim_known(slot)) fetch(slices[t], slot, m[0], m[1], m[2]);
            }
        }
        slices[t].evaluator.finish();
    });
    // The seeds each parent gives (they only read the midpoints' values): bit k, the child
    // holding edge k's lower half; bit 16 + k, its upper half's. Then their visits.
    constexpr uint32_t kUpperHalf = 16, kLone = 1u << 31;
    const float edge_limit = udf_edge_limit(out->cell_size);
    nfd::vector<uint32_t> seeds(parent.cells.size());
    parallel_for(parent.cells.size(), kFloodGrain, threads, [&](size_t begin, size_t end) {
        const FloodStore& known = store;
        for (size_t cell = begin; cell < end; ++cell) {
            const uint32_t edges = parent_edges[cell];
            if (!edges) continue;
            uint32_t c[3];
            unpack_coords(parent.cells[cell], c);
            float f[8];
            parent.corners(c, f);
            uint32_t children = 0;
            for (int k = 0; k < 12; ++k) {
                if (!(edges >> k & 1)) continue;
                uint32_t m[3];
                if (!edge_midpoint(c, k, m)) continue;
                const uint8_t a = mc::kEdgeCorners[k][0], b = mc::kEdgeCorners[k][1];
                const float f_middle = known.known_value(m[0], m[1], m[2]);
                if (!udf) {
                    children |= 1u << (k + ((f[a] < 0.0f) == (f_middle < 0.0f) ? kUpperHalf : 0));
                    continue;
                }
                children |= uint32_t(f[a] + f_middle <= edge_limit) << k;
                children |= uint32_t(f_middle + f[b] <= edge_limit) << (k + kUpperHalf);
            }
            seeds[cell] = children;
        }
    });
    // UDF: the parents whose edges gave a seed, a bit per parent vertex rank of their lowest
    // corner.
    nfd::vector<uint64_t> seeded(udf ? (parent.vertices.size() + 63) / 64 : 0);
    parallel_slices(parent.cells.size(), kFloodGrain, threads, [&](size_t t, size_t begin, size_t end) {
        for (size_t cell = begin; cell < end; ++cell) {
            const uint32_t children = seeds[cell];
            if (!children) continue;
            uint32_t c[3];
            unpack_coords(parent.cells[cell], c);
            for (int k = 0; k < 12; ++k) {
                if (!(children >> k & (1u | 1u << kUpperHalf))) continue;
                uint32_t child[3];
                const uint8_t* lower = mc::kCornerOffset[mc::kEdgeCorners[k][0]];
                for (int i = 0; i < 3; ++i) child[i] = 2 * c[i] + lower[i];
                if (children >> k & 1) visit(slices[t], child[0], child[1], child[2]);
                ++child[k / 4];
                if (children >> (k + kUpperHalf) & 1) visit(slices[t], child[0], child[1], child[2]);
            }
            if (udf) {
                const uint32_t r = parent.vertices.rank(c[0], c[1], c[2]);
                __atomic_fetch_or(&seeded[r / 64], uint64_t(1) << (r % 64), __ATOMIC_RELAXED);
            }
        }
    });
    // UDF: a parent with a valid edge but no seed, none of whose 26 neighbours has one, holds the
    // surface inside, away from its edges (a small closed piece): all its children are seeds.
    // Where a neighbour has seeds, the surface passes beside it and the flood comes from there.
    auto is_seeded = [&](int64_t x, int64_t y, int64_t z) {
        uint32_t r;
        return parent.vertices.find(x, y, z, &r) && (seeded[r / 64] >> (r % 64) & 1);
    };
    const size_t lone_candidates = udf ? parent.cells.size() : 0;
    parallel_for(lone_candidates, kFloodGrain, threads, [&](size_t begin, size_t end) {
        for (size_t cell = begin; cell < end; ++cell) {
            if (!parent_edges[cell] || seeds[cell]) continue;
            uint32_t c[3];
            unpack_coords(parent.cells[cell], c);
            bool lone = true;
            for (int k = 0; k < 27 && lone; ++k)
                lone = !is_seeded(int64_t(c[0]) + k % 3 - 1, int64_t(c[1]) + k / 3 % 3 - 1,
                                  int64_t(c[2]) + k / 9 - 1);
            if (lone) seeds[cell] = kLone;
        }
    });
    // All children of the lone parents and of step 3's candidates (region.refine_all) are seeds.
    auto visit_children = [&](Slice& slice, uint32_t packed) {
        uint32_t c[3];
        unpack_coords(packed, c);
        for (const auto& o : mc::kCornerOffset)
            visit(slice, 2 * c[0] + o[0], 2 * c[1] + o[1], 2 * c[2] + o[2]);
    };
    parallel_slices(lone_candidates, kFloodGrain, threads, [&](size_t t, size_t begin, size_t end) {
        for (size_t cell = begin; cell < end; ++cell)
            if (seeds[cell] == kLone) visit_children(slices[t], parent.cells[cell]);
    });
    parallel_slices(region.refine_all.size(), kFloodGrain, threads,
                    [&](size_t t, size_t begin, size_t end) {
                        for (size_t i = begin; i < end; ++i) visit_children(slices[t], region.refine_all[i]);
                    });
    gather();

    // The flood, a wave at a time: the wave's corners evaluated together, then the neighbours
    // behind its faces with a sign change (which have one too), or above the finest level behind
    // all six faces of a cell near zero (|f| < 0 holds nowhere), or (UDF) behind its faces holding
    // an edge with f_a + f_b <= kUdfFloodEdge * h (which the neighbour shares), inside the region.
    const float near_zero = l > 0 && !udf ? kSdfNearZeroCell * out->cell_size : 0.0f;
    const float flood_limit = kUdfFloodEdge * out->cell_size;
    auto flood = [&] {
        while (!wave.empty()) {
            parallel_slices(wave.size(), kClaimGrain, threads, [&](size_t t, size_t begin, size_t end) {
                for (size_t i = begin; i < end; ++i) {
                    uint32_t c[3], s[8];
                    unpack_coords(wave[i], c);
                    const bool in_block = store.cell_slots(c[0], c[1], c[2], s);
                    store.claim_corners(s, in_block, [&](int k) {
                        const uint8_t* o = mc::kCornerOffset[k];
                        fetch(slices[t], s[k], c[0] + o[0], c[1] + o[1], c[2] + o[2]);
                    });
                }
                slices[t].evaluator.finish();
            });
            // Which faces each cell of the wave floods through (reading the store only), then the
            // visits.
            through.assign(wave.size(), 0);
            parallel_for(wave.size(), kFloodGrain, threads, [&](size_t begin, size_t end) {
                const FloodStore& known = store;
                for (size_t i = begin; i < end; ++i) {
                    uint32_t c[3], s[8], r;
                    unpack_coords(wave[i], c);
                    known.known_cell_slots(c[0], c[1], c[2], s);
                    float f[8];
                    for (int k = 0; k < 8; ++k) f[k] = known.value(s[k]);
                    const bool every_face = is_near_zero(f, near_zero);
                    const uint32_t floodable = udf ? edges_within(f, flood_limit) : 0;
                    if (udf ? floodable == 0 : !every_face && !has_sign_change(f)) continue;
                    for (int face = 0; face < 6; ++face) {
                        if (udf ? !(floodable & kFaceEdges[face])
                                : !every_face && !face_changes_sign(f, face))
                            continue;
                        uint32_t nb[3] = {c[0], c[1], c[2]};
                        const int axis = face / 2;
                        if (face & 1) {
                            ++nb[axis];
                        } else if (nb[axis]-- == 0) {
                            continue;
                        }
                        // Most neighbours were visited already: that test first, the region's after.
                        if (nb[axis] < n && !known.visited(nb[0], nb[1], nb[2]) &&
                            region.parents.find(nb[0] / 2, nb[1] / 2, nb[2] / 2, &r))
                            through[i] |= uint8_t(1u << face);
                    }
                }
            });
            parallel_slices(wave.size(), kFloodGrain, threads, [&](size_t t, size_t begin, size_t end) {
                for (size_t i = begin; i < end; ++i) {
                    if (!through[i]) continue;
                    uint32_t c[3];
                    unpack_coords(wave[i], c);
                    for (int face = 0; face < 6; ++face) {
                        if (!(through[i] >> face & 1)) continue;
                        uint32_t nb[3] = {c[0], c[1], c[2]};
                        nb[face / 2] += face & 1 ? 1 : -1;
                        visit(slices[t], nb[0], nb[1], nb[2]);
                    }
                }
            });
            gather();
        }
    };
    flood();
    // SDF above the finest level, once the flood is done: the eight children around each vertex
    // above within kSdfNearZeroVertex * h of zero none of which was visited, or within
    // kSdfSecondSheetVertex * h whether or not, inside the region, then the flood from them
    // (grid.h, step 1). Which vertices, first (reading the visits only).
    if (!udf && l > 0) {
        const float vertex_near_zero = kSdfNearZeroVertex * out->cell_size;
        const float second_sheet = kSdfSecondSheetVertex * out->cell_size;
        nfd::vector<uint64_t> seed_around((parent.vertices.size() + 63) / 64);
        auto for_each_child_around = [n](uint32_t x, uint32_t y, uint32_t z, auto&& fn) {
            for (const auto& o : mc::kCornerOffset)
                if (o[0] <= 2 * x && o[1] <= 2 * y && o[2] <= 2 * z && 2 * x - o[0] < n &&
                    2 * y - o[1] < n && 2 * z - o[2] < n)
                    fn(2 * x - o[0], 2 * y - o[1], 2 * z - o[2]);
        };
        parallel_for(parent.vertices.blocks(), 1, threads, [&](size_t begin, size_t end) {
            const FloodStore& known = store;
            parent.vertices.for_each_in_blocks(begin, end, [&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
                const float f = std::fabs(parent.values[r]);
                if (!(f <= vertex_near_zero)) return;  // NaN: not near
                bool reached = false;
                if (f > second_sheet)
                    for_each_child_around(x, y, z, [&](uint32_t cx, uint32_t cy, uint32_t cz) {
                        reached = reached || known.visited(cx, cy, cz);
                    });
                if (!reached) __atomic_fetch_or(&seed_around[r / 64], uint64_t(1) << (r % 64), __ATOMIC_RELAXED);
            });
        });
        parallel_slices(parent.vertices.blocks(), 1, threads, [&](size_t t, size_t begin, size_t end) {
            parent.vertices.for_each_in_blocks(begin, end, [&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
                if (!(seed_around[r / 64] >> (r % 64) & 1)) return;
                for_each_child_around(x, y, z, [&](uint32_t cx, uint32_t cy, uint32_t cz) {
                    uint32_t found;
                    if (region.parents.find(cx / 2, cy / 2, cz / 2, &found)) visit(slices[t], cx, cy, cz);
                });
            });
        });
        gather();
        flood();
    }
    for (Slice& slice : slices) *evaluated += slice.evaluator.finish();
    slices = nfd::vector<Slice>();
    wave = nfd::vector<uint32_t>();
    through = nfd::vector<uint8_t>();

    store.visited_cells(&out->cells, threads);
    // The level's vertices, the corners of its cells (GridLevel::collect_corners) from the
    // store's bits, and their values, by ranges of blocks (64: a few thousand vertices) on
    // threads.
    const FloodStore& known = store;
    out->vertices = VertexSet(n + 1);
    out->vertices.assign([&known](size_t index, uint64_t words[8]) { return known.corner_words(index, words); },
                         threads);
    out->values.assign(out->vertices.size(), 0.0f);
    parallel_for(out->vertices.blocks(), 64, threads, [&](size_t begin, size_t end) {
        out->vertices.for_each_in_blocks(
            begin, end, [&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
                out->values[r] = known.known_value(x, y, z);
            });
    });
    if (!with_gradients) return;
    out->gradient_flags.assign(out->vertices.size(), 0);
    out->gradients.assign(size_t(3) * out->vertices.size(), 0.0f);
    parallel_for(records.size(), 1, threads, [&](size_t begin, size_t end) {
        for (size_t t = begin; t < end; ++t)
            records[t].for_each([&](const GradientRecords::Record& record) {
                uint32_t v[3], r;
                known.vertex(record.slot, v);
                // A seed's edge midpoint whose cells were not visited is no vertex of the level.
                if (!out->vertices.find(v[0], v[1], v[2], &r)) return;
                out->gradient_flags[r] = GridLevel::kGradientKnown;
                std::copy_n(record.gradient, 3, &out->gradients[size_t(3) * r]);
            });
    });
}

}  // namespace nfd
