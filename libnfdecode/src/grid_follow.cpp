// CPU reference of the SDF levels below the coarsest (grid.h, "Surface following"): the cells of a
// level are found from the crossed edges of the level above and flooded across faces with a sign
// change and (above the finest level) out of cells near zero, each corner evaluated once, inside
// a region sized before the level starts.
#include <algorithm>
#include <cmath>

#include "grid.h"
#include "grid_eval.h"
#include "mc_tables.h"

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

// The corners of the face of a cell across which its neighbour lies, per face 2 * axis + side.
constexpr uint8_t kFaceCorners[6][4] = {{0, 2, 4, 6}, {1, 3, 5, 7}, {0, 1, 4, 5},
                                        {2, 3, 6, 7}, {0, 1, 2, 3}, {4, 5, 6, 7}};

// The child level while the flood grows it, by blocks of 8^3 vertices as VertexSet stores them:
// per block the vertices whose value is known or queued and the cells visited (a cell's bit is
// that of its lowest corner), kept apart from the values so that the flood's bit tests stay in
// cache. A slot is a block's index times 512 plus the vertex's place in it, z, y, x.
class FloodStore {
public:
    // `blocks`: at least the blocks it will touch (LevelSize::blocks): reserved, never moved.
    FloodStore(uint32_t side, uint64_t blocks)
        : per_axis_((side + 7) / 8), table_(size_t(per_axis_) * per_axis_ * per_axis_, kNoBlock) {
        bits_.reserve(blocks);
        values_.reserve(512 * blocks);
    }
    static uint64_t bytes_bound(uint32_t side, uint64_t blocks) {
        const uint64_t per_axis = (side + 7) / 8;
        return 4 * per_axis * per_axis * per_axis + (sizeof(Bits) + 512 * 4) * blocks;
    }
    uint32_t slot(uint32_t x, uint32_t y, uint32_t z) {
        return block(x, y, z) << 9 | (z & 7) << 6 | (y & 7) << 3 | (x & 7);
    }
    // The slots of the corners of cell (x, y, z), mc::kCornerOffset order: one block lookup
    // where the cell lies inside a block (343 cells in 512), and then true.
    bool cell_slots(uint32_t x, uint32_t y, uint32_t z, uint32_t s[8]) {
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
    // Marks the corners of the cell whose corner slots are `s` (cell_slots, `in_block` what it
    // returned) known and calls fn(k) for each corner k that was not: in a block, two words.
    template <class Fn>
    void claim_corners(const uint32_t s[8], bool in_block, Fn&& fn) {
        if (!in_block) {
            for (int k = 0; k < 8; ++k)
                if (claim_known(s[k])) fn(k);
            return;
        }
        uint64_t* words = bits_[s[0] >> 9].known;
        const uint32_t w = s[0] >> 6 & 7, p = s[0] & 63;
        const uint64_t lower = ~words[w] >> p & 0x303, upper = ~words[w + 1] >> p & 0x303;
        if (!(lower | upper)) return;
        words[w] |= uint64_t(0x303) << p;
        words[w + 1] |= uint64_t(0x303) << p;
        for (int k = 0; k < 4; ++k) {
            const uint32_t bit = (k & 1) + 8 * (k >> 1);
            if (lower >> bit & 1) fn(k);
            if (upper >> bit & 1) fn(k + 4);
        }
    }
    // Whether cell (x, y, z) was visited; makes no block.
    bool visited(uint32_t x, uint32_t y, uint32_t z) const {
        const uint32_t b = table_[((z >> 3) * per_axis_ + (y >> 3)) * per_axis_ + (x >> 3)];
        return b != kNoBlock && bits_[b].visited[z & 7] >> ((x & 7) + 8 * (y & 7)) & 1;
    }
    // Marks vertex `s` known, or the cell at it visited; false if it was already.
    bool claim_known(uint32_t s) { return claim(bits_[s >> 9].known, s); }
    bool claim_visited(uint32_t s) { return claim(bits_[s >> 9].visited, s); }
    float& value(uint32_t s) { return values_[s]; }
    // fn(x, y, z) for every visited cell: blocks in raster order, inside a block by 2^3 groups
    // in raster order, and a group in mc::kCornerOffset order. So a parent's children are
    // consecutive, a sibling group where all eight were visited (marching.h).
    template <class Fn>
    void for_each_visited(Fn&& fn) const {
        for (size_t t = 0; t < table_.size(); ++t) {
            if (table_[t] == kNoBlock) continue;
            const uint32_t bx = uint32_t(t % per_axis_), by = uint32_t(t / per_axis_ % per_axis_),
                           bz = uint32_t(t / (size_t(per_axis_) * per_axis_));
            const Bits& b = bits_[table_[t]];
            for (uint32_t g = 0; g < 64; ++g) {
                const uint32_t gx = 2 * (g & 3), gy = 2 * (g >> 2 & 3), gz = 2 * (g >> 4);
                for (const auto& o : mc::kCornerOffset) {
                    const uint32_t x = gx + o[0], y = gy + o[1], z = gz + o[2];
                    if (b.visited[z] >> (x + 8 * y) & 1) fn(8 * bx + x, 8 * by + y, 8 * bz + z);
                }
            }
        }
    }

private:
    static constexpr uint32_t kNoBlock = ~0u;
    static constexpr uint32_t kCornerStep[8] = {0, 1, 8, 9, 64, 65, 72, 73};
    struct Bits {
        uint64_t known[8], visited[8];
    };
    uint32_t block(uint32_t x, uint32_t y, uint32_t z) {
        uint32_t& b = table_[((z >> 3) * per_axis_ + (y >> 3)) * per_axis_ + (x >> 3)];
        if (b == kNoBlock) {
            b = uint32_t(bits_.size());
            bits_.push_back(Bits{});
            values_.resize(values_.size() + 512);
        }
        return b;
    }
    static bool claim(uint64_t* words, uint32_t s) {
        uint64_t& word = words[s >> 6 & 7];
        const uint64_t bit = uint64_t(1) << (s & 63);
        if (word & bit) return false;
        word |= bit;
        return true;
    }
    uint32_t per_axis_;
    nfd::vector<uint32_t> table_;
    nfd::vector<Bits> bits_;
    nfd::vector<float> values_;
};

}  // namespace

void follow_region(const SparseGrid& grid, const GridLevel& level, FollowRegion* region,
                   LevelSize* next) {
    const uint32_t n = level.cells_per_axis;
    const float threshold = keep_threshold(grid.field, level.cell_size);
    region->parents = VertexSet(n + 1);
    region->refine_all = nfd::vector<uint32_t>();  // first the keep rule's cells without a sign change
    for (size_t i = 0; i < level.cells.size(); ++i) {
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        float f[8];
        level.corners(c, f);
        if (!has_sign_change(f)) {
            if (cell_may_contain_surface(f, threshold)) region->refine_all.push_back(level.cells[i]);
            continue;
        }
        for (uint32_t z = c[2] ? c[2] - 1 : 0; z <= std::min(c[2] + 1, n - 1); ++z)
            for (uint32_t y = c[1] ? c[1] - 1 : 0; y <= std::min(c[1] + 1, n - 1); ++y)
                for (uint32_t x = c[0] ? c[0] - 1 : 0; x <= std::min(c[0] + 1, n - 1); ++x)
                    region->parents.insert(x, y, z);
    }
    region->parents.finish();
    // Of those, the isolated ones: no sign-change neighbour, so not in the region.
    auto in_region = [&](uint32_t packed) {
        uint32_t c[3], r;
        unpack_coords(packed, c);
        return region->parents.find(c[0], c[1], c[2], &r);
    };
    nfd::vector<uint32_t>& cells = region->refine_all;
    cells.erase(std::remove_if(cells.begin(), cells.end(), in_region), cells.end());

    // The next level's size: the children of the region's cells.
    ChildLevelSize size(cells_at_level(grid.resolution, level.level - 1));
    region->parents.for_each([&](uint32_t, uint32_t x, uint32_t y, uint32_t z) {
        const uint32_t c[3] = {x, y, z};
        size.add_parent(c);
    });
    for (uint32_t packed : region->refine_all) {
        uint32_t c[3];
        unpack_coords(packed, c);
        size.add_parent(c);
    }
    *next = size.size();
}

uint64_t follow_region_bytes_bound(const LevelSize& level, uint32_t child_cells) {
    // The region's cell set, whose cells lie in the level's vertex blocks or beside them; the
    // refine-all list (grown by doubling); the next level's block bitmap.
    const uint64_t per_axis = (level.cells_per_axis + 1 + 7) / 8;
    const uint64_t region_blocks = std::min(27 * level.blocks, per_axis * per_axis * per_axis);
    return VertexSet::bytes_bound(level.cells_per_axis + 1, region_blocks) + 8 * level.cells +
           ChildLevelSize::bytes(child_cells);
}

uint64_t follow_surface_bytes_bound(const LevelSize& next) {
    // The flood's store, its two frontiers (each at most the level's cells, grown by doubling).
    return FloodStore::bytes_bound(next.cells_per_axis + 1, next.blocks) + 16 * next.cells;
}

void follow_surface(const Network& net, const SparseGrid& grid, const GridLevel& parent,
                    const FollowRegion& region, uint64_t blocks, unsigned threads,
                    GridLevel* out, uint64_t* evaluated) {
    const uint32_t n = out->cells_per_axis, l = out->level;
    FloodStore store(n + 1, blocks);
    auto store_value = [&store](uint32_t slot, float value, const float*) { store.value(slot) = value; };
    auto evaluator = make_evaluator(net, false, threads, store_value);
    // The value of vertex (x, y, z) at slot s, just claimed: a corner of the parent level is
    // copied, any other queued.
    auto fetch = [&](uint32_t s, uint32_t x, uint32_t y, uint32_t z) {
        uint32_t r;
        if (((x | y | z) & 1) == 0 && parent.vertices.find(x / 2, y / 2, z / 2, &r)) {
            store.value(s) = parent.values[r];
        } else {
            const float xyz[3] = {grid.coord(x << l), grid.coord(y << l), grid.coord(z << l)};
            evaluator.push(s, xyz);
        }
    };
    nfd::vector<uint32_t> frontier, wave;
    size_t visited = 0;
    auto visit = [&](uint32_t x, uint32_t y, uint32_t z) {
        if (x < n && y < n && z < n && store.claim_visited(store.slot(x, y, z))) {
            frontier.push_back(pack_coords(x, y, z));
            ++visited;
        }
    };

    // Seeds: the midpoint of each crossed edge of a parent with a sign change tells which half
    // the surface crosses; the parent's child holding that half has a sign change. A parent
    // edge is shared by up to four parents, which evaluate its midpoint once and agree.
    struct CrossedParentEdge {
        uint32_t cell[3];       // the parent
        const uint8_t* lower;   // its corner at the edge's lower end (mc::kCornerOffset)
        float f_lower;          // the value there
        int axis;
        uint32_t middle[3];     // the midpoint, a vertex of this level
        uint32_t slot;          // the midpoint's
    };
    auto for_each_crossed_edge = [&](auto&& fn) {
        for (uint32_t packed : parent.cells) {
            CrossedParentEdge e;
            unpack_coords(packed, e.cell);
            float f[8];
            parent.corners(e.cell, f);
            if (!has_sign_change(f)) continue;
            for (int k = 0; k < 12; ++k) {
                const uint8_t a = mc::kEdgeCorners[k][0], b = mc::kEdgeCorners[k][1];
                if ((f[a] < 0.0f) == (f[b] < 0.0f)) continue;
                e.lower = mc::kCornerOffset[a];
                e.f_lower = f[a];
                e.axis = k / 4;
                for (int i = 0; i < 3; ++i) e.middle[i] = 2 * (e.cell[i] + e.lower[i]);
                ++e.middle[e.axis];
                // Past the level's last vertex (an odd cell count): the half's cells are dropped.
                if (e.middle[0] > n || e.middle[1] > n || e.middle[2] > n) continue;
                e.slot = store.slot(e.middle[0], e.middle[1], e.middle[2]);
                fn(e);
            }
        }
    };
    for_each_crossed_edge([&](const CrossedParentEdge& e) {
        if (store.claim_known(e.slot)) fetch(e.slot, e.middle[0], e.middle[1], e.middle[2]);
    });
    evaluator.finish();
    for_each_crossed_edge([&](const CrossedParentEdge& e) {
        uint32_t child[3];
        for (int i = 0; i < 3; ++i) child[i] = 2 * e.cell[i] + e.lower[i];
        child[e.axis] = 2 * e.cell[e.axis] + ((e.f_lower < 0.0f) == (store.value(e.slot) < 0.0f));
        visit(child[0], child[1], child[2]);
    });
    for (uint32_t packed : region.refine_all) {
        uint32_t c[3];
        unpack_coords(packed, c);
        for (const auto& o : mc::kCornerOffset)
            visit(2 * c[0] + o[0], 2 * c[1] + o[1], 2 * c[2] + o[2]);
    }

    // The flood, a wave at a time: the wave's corners evaluated together, then the neighbours
    // behind its faces with a sign change (which have one too), or above the finest level behind
    // all six faces of a cell near zero (|f| < 0 holds nowhere), inside the region.
    const float near_zero = l > 0 ? kSdfNearZeroCell * out->cell_size : 0.0f;
    while (!frontier.empty()) {
        std::swap(frontier, wave);  // visit() appends the next wave to `frontier`
        frontier.clear();
        for (uint32_t packed : wave) {
            uint32_t c[3], s[8];
            unpack_coords(packed, c);
            const bool in_block = store.cell_slots(c[0], c[1], c[2], s);
            store.claim_corners(s, in_block, [&](int k) {
                const uint8_t* o = mc::kCornerOffset[k];
                fetch(s[k], c[0] + o[0], c[1] + o[1], c[2] + o[2]);
            });
        }
        evaluator.finish();
        for (uint32_t packed : wave) {
            uint32_t c[3], s[8], r;
            unpack_coords(packed, c);
            store.cell_slots(c[0], c[1], c[2], s);
            float f[8];
            for (int k = 0; k < 8; ++k) f[k] = store.value(s[k]);
            const bool every_face = is_near_zero(f, near_zero);
            if (!every_face && !has_sign_change(f)) continue;
            for (int face = 0; face < 6; ++face) {
                const float g[4] = {f[kFaceCorners[face][0]], f[kFaceCorners[face][1]],
                                    f[kFaceCorners[face][2]], f[kFaceCorners[face][3]]};
                if (!every_face && !has_sign_change(g, 4)) continue;
                uint32_t nb[3] = {c[0], c[1], c[2]};
                const int axis = face / 2;
                if (face & 1) {
                    ++nb[axis];
                } else if (nb[axis]-- == 0) {
                    continue;
                }
                // Most neighbours were visited already: that test first, the region's after.
                if (nb[axis] < n && !store.visited(nb[0], nb[1], nb[2]) &&
                    region.parents.find(nb[0] / 2, nb[1] / 2, nb[2] / 2, &r))
                    visit(nb[0], nb[1], nb[2]);
            }
        }
    }
    *evaluated += evaluator.finish();
    frontier = nfd::vector<uint32_t>();
    wave = nfd::vector<uint32_t>();

    out->cells.reserve(visited);
    store.for_each_visited(
        [&](uint32_t x, uint32_t y, uint32_t z) { out->cells.push_back(pack_coords(x, y, z)); });
    out->collect_corners();
    out->vertices.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        out->values[r] = store.value(store.slot(x, y, z));
    });
}

}  // namespace nfd
