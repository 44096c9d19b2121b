// The sparse grid: the product of coarse-to-fine field sampling, shared by every output (the SDF
// mesher, the UDF mesher, the VDB narrow band, progressive levels). The CPU reference builds it in
// grid.cpp and grid_follow.cpp. The GPU path (gpu/) applies the keep rule, the CPU's `band`
// (per-parent child grids, a fixed number of dispatches per level, where surface following grows
// a level in waves), which finds the cells surface following finds (SDF: and the voids below)
// from about 2 (UDF) to 2.5 (SDF) times the evaluations; but a UDF's finest level, where most of
// them are, follows the surface within the kept cells of level 1 (GridBuilder's
// `follow_finest`, gpu/levels.h's evaluate_finest_flood: 0.63-0.74 of the band's evaluations).
// Every value the grid holds is the field bounded to the shape's ball (network.h, ShapeBall),
// wherever it was evaluated (grid_eval.h, the GPU's field kernels).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "mc_tables.h"
#include "network.h"
#include "nfdecode/nfdecode.h"

#include "host_memory.h"
#include "parallel.h"

namespace nfd {

// Grid of `resolution` cells per axis over the unit frame [-1, 1]^3: vertex i sits at
// -1 + 2 i / resolution (computed in f32 as -1.0f + float(i) * (2.0f / float(resolution))).
// Refinement halves the cell size from coarse_resolution() up: level l (0 = finest, up to
// refinement_levels()) has ceil(resolution / 2^l) cells per axis, each 2^l fine cells wide, and
// its vertices are the fine vertices whose indices are multiples of 2^l. When 2^l does not divide
// the resolution the last cell reaches past u = 1, where the field is still defined; children
// starting at or past fine index `resolution` are dropped, so level 0 is exactly the fine grid.
// Any resolution works (not only c * 2^k), and no level is denser than the coarsest one needs.
uint32_t cells_at_level(uint32_t resolution, uint32_t level);  // ceil(resolution / 2^level)
uint32_t coarse_resolution(uint32_t resolution);  // ceil(resolution / 2^refinement_levels())
// The largest l with ceil(resolution / 2^l) >= 32, else 0: coarser grids would prune nothing for
// d* = 0.1, since the keep test below only rejects cells whose half-diagonal is well under d*.
uint32_t refinement_levels(uint32_t resolution);

// Which cells each level visits. The coarsest level: all of them, but above the finest level not
// every vertex is evaluated (evaluate_coarsest_level): a probe level twice as coarse
// (cells_at_level(resolution, level + 1) cells per axis, whose vertices are the coarsest level's
// all-even ones) is evaluated first, and only the 3^3 child vertices of the probe cells that the
// keep rule keeps; the other vertices hold the mean of the probe vertices around them. A probe
// cell that is not kept has no sign change and every corner beyond its keep threshold (h_probe
// * margin * sqrt(3) / 2, twice the coarsest level's), so each mean inside it has the corners'
// sign and a magnitude beyond every threshold the coarsest level's rules test (keep rule, valid
// and flood edges, near-zero cells): those cells stay out of every schedule below, as they would
// with their true values wherever the field's slope is within the keep margin. A surface point
// inside such a cell is what the keep rule gives up at any level. Every cell whose corners include
// a mean lies in a probe cell that is not kept, and a mesher of such a level (a progressive
// extraction's coarsest) skips those cells (GridLevel::probe_kept; the GPU path never lists
// them), so no triangle is made from a mean, nor a normal where that slope holds. (A mutated
// network whose outputs reach 1e29 showed both: 56 cells of its 32 level hidden from the probe,
// and, before the skip, CPU triangles made from means beside kept probe cells; tests/fuzz.)
// On thin shapes, whose surface crosses few cells, the dense coarsest level was most of the
// evaluations (bench/RESULTS.md, "0.13.10").
//
// Below the coarsest level, two schedules:
//
// - The band (GridBuilder's `band`): the keep rule. A cell of edge length h (unit
//   frame) is kept for refinement, and its eight children visited, when min |f| over its corners
//   <= keep_threshold(field, h) = margin * h * sqrt(3) / 2 (f32, in that order), or (SDF) its
//   corners change sign: a surface point inside the cell is within h*sqrt(3)/2 of its nearest
//   corner, so a field whose mean slope along that segment is at most the margin cannot hide a
//   surface from the test. NaN corners fail every comparison: such cells are dropped rather than
//   meshed from garbage. SDF margin 1, a distance field's slope. UDF margin 1.5: the UDF mesher
//   needs the near cells too (udf_cell_is_near), which lie beside the surface, and fields learned
//   from point clouds are steeper: margin 1 loses near cells of the shirt (paper preset) at 128
//   and 256, 1.25 of the milk cloud at 512; 1.5 finds every near cell that 2 finds on the 40 UDF
//   files of bench/RESULTS.md ("0.12.2": garments, scans, clouds, meshes; 128, 256 and 512, band
//   and surface following) with 17% fewer band evaluations at 256.
//
// - UDF: surface following (grid_follow.cpp), the SDF's schedule below with the UDF mesher's valid
//   edges (udf_edge_limit) in place of sign changes. A level visits the cells reached from
//   1. seeds: each valid edge (at its own size) of a cell above with one has its midpoint
//      evaluated, and the child holding each half that is valid at the child's size is a seed
//      (where a distance field's surface crosses the edge, the half it crosses is); a cell above
//      with a valid edge, no seed and no seed in its 26 neighbours has all its children seeded
//      (a small closed piece inside it, away from its edges: a sphere of radius 0.02 in a coarse
//      cell of 0.0625);
//   2. a flood across the faces that hold an edge with f_a + f_b <= kUdfFloodEdge * h (the
//      neighbour shares that edge), inside the region of the followed cells above and their 26
//      neighbours, plus every child of the isolated cells above (keep rule with the UDF margin,
//      no valid edge, no followed neighbour), as for an SDF.
//   The near cells that the mesher needs (udf_cell_is_near) lie on valid edges, which connect
//   them to the sheet they belong to. On the golden UDF vectors (garment, scans, coloured cloud)
//   and the bunny UDF the finest level visits every near cell of the dense grid at 128, 150, 256
//   and the band's at 512, meshes identical, from 0.45-0.56 of the band's evaluations
//   (bench/RESULTS.md, "0.12"). What it gives up is the same kind as the SDF's: a cluster of near
//   cells that no seed reaches and no floodable face joins to the sheet.
//
// - SDF: surface following (grid_follow.cpp). A level visits the cells with a sign change (a
//   corner f < 0 and one not: NaN counts as not negative, as in the mesher's case index) and
//   evaluates only their corners, about 1.75 per cell, where the keep rule evaluated every child
//   of a band about twice as thick (bench/RESULTS.md, "0.11: ..."). From the level above:
//   1. Seeds: each crossed edge (one end negative) of a cell with a sign change gets its midpoint
//      evaluated; the half that the sign change falls in is an edge of one child of that cell,
//      which has a sign change. Above the finest level, once the flood (step 2) is done, also
//      the eight children around each vertex of the level above within kSdfNearZeroVertex * h
//      (this level's edge) of zero none of which was visited, inside the region, and the flood
//      from them: a void or sliver that nearly touches a vertex above and first shows at this
//      level crosses no edge above, and beside the surface it is no isolated cell (step 3)
//      either; where a child around such a vertex was visited, the surface it nearly touches
//      mostly passes there, but within kSdfSecondSheetVertex * h of zero the children not
//      visited are seeded too (0.13.18): the other sheet of a sliver thinner than a cell. The
//      dragon's files of the 2026-12-07 encoder lost 8-40 cells at 64 or 128 this way, and their
//      children at 256 and 512: holes that the band did not have (bench/RESULTS.md, "0.13.17",
//      "0.13.18"). Evaluations: the same within 0.4% (0.13.17), +0.43% (0.13.18).
//   2. Flood: each visited cell visits the neighbours behind its faces whose four corners change
//      sign (those have a sign change too), and above the finest level a cell whose eight corners
//      all lie within kSdfNearZeroCell * h of zero visits all six, wave after wave, inside the
//      region: the children of the level above's cells with a sign change and of their 26
//      neighbours. So a level's size is bounded before it is evaluated (LevelSize), and the surface
//      may leave the coarser level's sign-change cells by one cell, as it does where it clips a
//      corner of a coarse cell without changing the sign of its corners. A near-zero cell is
//      flatter than a distance field, whose values over a cell span at least h (h * (|n_x| +
//      |n_y| + |n_z|) for a plane of unit normal n), so a field of that slope never has one: it
//      marks where a fit hovers at zero, in a thin part or along a fold, and a void may open
//      between the grid's vertices that no sign change above shows; the level below then seeds
//      from the void's crossed edges. The finest level follows sign changes only: a void that
//      first shows there is under two fine cells across, and walking the hovering area at the
//      finest level, where most evaluations are, costs about a fifth more on a shape that hovers
//      widely (lion: 3.6 evaluations per active cell at 256 against 3.0) for no cell found on the
//      ten shapes measured.
//   3. Isolated cells: a cell of the level above without a sign change that the keep rule (margin
//      1) keeps and that has no sign-change cell among its 26 neighbours has all its children
//      visited (and flooded from): a small closed component inside one coarse cell, away from the
//      rest of the surface, is found where the field's slope is at most 1, as the keep rule
//      found it. The finest level's parents are held to its near-zero bound instead (a corner
//      within kSdfNearZeroCell fine-cell edges of zero, a quarter of the parent's edge): what
//      first shows there is under two fine cells across, which step 2 gives up for voids too,
//      and the keep rule's margin made every cell of a hovering area and its fringe isolated
//      (lion at 512: 20,086 parents, 160k cells, none with a sign change, 0.49 evaluations per
//      active cell). What the finest level still finds this way is a component that nearly
//      touches a vertex of the level above: the voids of suzanne at 256 and happy at 512, within
//      0.02 coarse cells of one. Where the keep rule's threshold exceeds the file's truncation d*
//      (the 32 level, half-diagonal 0.054, of a fit at d* = 0.05), the threshold is
//      kSdfIsolatedTruncation * d* instead: a truncated fit reads about d* wherever the surface is
//      farther (its loss stops there), so a threshold over d* made every far cell whose corners
//      sit at the clamp an isolated candidate and visited all its children (up to 0.3 evaluations
//      per active cell of real shapes at 256, 1.3 of a thin rod's). What this gives up is
//      a closed component farther than 0.9 d* from every corner of its coarse cell: at d* = 0.05
//      on the 32 level, one within 0.009 of the cell's centre (bench/RESULTS.md, "0.13.19").
//   What the schedule gives up is the keep rule's band: a component of the surface that crosses
//   no crossed edge of the level above, lies within one cell of its sign-change cells and is
//   reached from them through no near-zero cell or unreached near-zero vertex above the finest
//   level (the dragon's w96 file at 256: 50 cells), or a thin sheet that runs
//   farther than one coarse cell from them between its vertices, is not found; nor is a component
//   under two fine cells across that first shows at the finest level and passes no vertex of the
//   level above within half a fine cell (a sphere of radius 0.6 fine cells in the middle of a
//   coarse cell: tests/python/test_grid.py). Learned distance fields of shapes have few such
//   spots (bench/RESULTS.md, "0.11.1" and "0.13.6": ten shapes at 128, 256 and 512 against the
//   dense grid, bench/keep_rule.cpp, bench/lost_cells.py). What near-zero cells cost is the area
//   where a fit hovers at zero: 2.4-2.7 evaluations per active cell at 256-512 on nine of those
//   shapes, 2.7-2.9 on the tenth (lion; 3.0-3.2 while the finest level's isolated cells had the
//   keep rule's margin, 2.4-2.7 without near-zero cells). Fields
//   that are no shape's distance field lose more: random SIRENs, whose surfaces fill a quarter of
//   the cells in small pieces, lose 1-44% of the dense grid's sign-change cells (width 32, seeds
//   11, 21 and 5 at 64 and 128, 0.11.1; the band: 0-3%). GridBuilder's `band`
//   (nfd_mesh_options.sample_band) keeps the keep rule.
constexpr float kSdfKeepMargin = 1.0f;
constexpr float kUdfKeepMargin = 1.5f;
constexpr float kHalfDiagonal = 0.8660254f;  // sqrt(3) / 2
// Surface following's near-zero cells (step 2 above), in cell edges: half a cell, the largest
// bound that a distance field's slope never stays under at all eight corners.
constexpr float kSdfNearZeroCell = 0.5f;
// Step 1's near-zero vertices above, in this level's cell edges: the same half cell (a whole
// cell found no more of the dragon's lost cells).
constexpr float kSdfNearZeroVertex = 0.5f;
// Step 1's vertices above so close to zero (in this level's cell edges) that the children around
// them the flood did not visit are seeded even where it visited some: a second sheet of a thin
// sliver beside the first. 0.15 found the dragon's slivers of bench/RESULTS.md "0.13.18" for +0.4%
// evaluations (0.25: no more cells, +0.8%; 0.1 missed one).
constexpr float kSdfSecondSheetVertex = 0.15f;
// Step 3's cap on an SDF's isolated-cell threshold, in units of the file's truncation d*: under
// the clamp that a fit's far field sits at (d* and a little over), over its fitting error.
constexpr float kSdfIsolatedTruncation = 0.9f;
// The keep rule's threshold (SDF: for isolated cells, step 3 above).
inline float keep_threshold(FieldType field, float h) {
    return (field == FieldType::Udf ? kUdfKeepMargin : kSdfKeepMargin) * h * kHalfDiagonal;
}
// Step 3's threshold for the isolated cells of `level` (0 = finest) in a grid of step `finest_h`
// of a field truncated at `truncation` (infinity: not truncated): the keep rule's at the level's
// edge (finest_h * 2^level, as GridBuilder computes it), for an SDF at most
// kSdfIsolatedTruncation * truncation, and the finest level's near-zero bound for an SDF's
// parents of the finest level.
inline float isolated_threshold(FieldType field, uint32_t level, float finest_h, float truncation) {
    if (field == FieldType::Udf) return keep_threshold(field, finest_h * float(1u << level));
    if (level == 1) return kSdfNearZeroCell * finest_h;
    return std::min(keep_threshold(field, finest_h * float(1u << level)),
                    kSdfIsolatedTruncation * truncation);
}
bool cell_may_contain_surface(const float corner_values[8], float threshold);

// The coarsest level `level` of a grid of `resolution` (refinement_levels(resolution)): its
// values at all side^3 vertices, side = cells_at_level(resolution, level) + 1, into `values` in
// raster order (x fastest), evaluated or, above the finest level, filled as the probe above
// leaves them. A filled vertex has an odd coordinate; its value is the sum, in f32 and in raster
// order of the offsets (z slowest, -1 before +1), of the probe vertices at -1 and +1 along its
// odd axes, times 1/2, 1/4 or 1/8. `probe_kept` (optional, cells_at_level(resolution, level +
// 1)^3 bytes, raster order): each probe cell's verdict, 1 where its child vertices are evaluated
// (every cell when level is 0: no probe). A probe cell that reaches past the grid (odd cells per
// axis) is kept. Returns the evaluations made.
uint64_t evaluate_coarsest_level(const Network& net, FieldType field, uint32_t resolution,
                                 uint32_t level, unsigned threads, float* values,
                                 uint8_t* probe_kept = nullptr);
// What evaluate_coarsest_level allocates for `side` vertices per axis: its marks and the points
// it evaluates, with the evaluator's scratch.
uint64_t evaluate_coarsest_level_bytes(const Network& net, uint32_t side, unsigned threads);

// Upper bounds of a level's size, known before it is evaluated (GridBuilder::next_level_size):
// what its vertex sets, values and meshes can allocate.
struct LevelSize {
    uint32_t cells_per_axis = 0;
    uint64_t cells = 0;     // exact
    uint64_t vertices = 0;  // corners of the cells: 27 per parent (its children's 3^3 grid)
    uint64_t edges = 0;     // grid edges between them: 54 per parent
    uint64_t blocks = 0;    // 8^3-vertex blocks (VertexSet) they touch: exact
};

class VertexSet;

// LevelSize of a level made of the children of some cells of the level above (those of the keep
// rule, or a surface-following region), counted parent by parent: the children inside the grid
// and the vertex blocks their 3^3 corner grids touch, marked in a bitmap of the child level's
// block table (bytes() bytes).
class ChildLevelSize {
public:
    explicit ChildLevelSize(uint32_t child_cells);  // the child level's cells per axis
    void add_parent(const uint32_t cell[3]);
    // add_parent for every cell of `parents` (cells named by their lowest corner), on threads.
    void add_parents(const VertexSet& parents, unsigned threads);
    LevelSize size() const;
    static uint64_t bytes(uint32_t child_cells);

private:
    uint64_t mark(const uint32_t cell[3]);  // the cell's touched blocks; returns its children
    uint32_t child_cells_, blocks_per_axis_;
    uint64_t cells_ = 0, parents_ = 0;
    nfd::vector<uint64_t> touched_;
};

// Cell and vertex coordinates of any level are <= 1024: 11 bits each, x lowest.
inline uint32_t pack_coords(uint32_t x, uint32_t y, uint32_t z) { return x | y << 11 | z << 22; }
inline void unpack_coords(uint32_t packed, uint32_t xyz[3]) {
    xyz[0] = packed & 0x7FF;
    xyz[1] = packed >> 11 & 0x7FF;
    xyz[2] = packed >> 22;
}

// Whether this x86-64 CPU has POPCNT (every one since 2008; baseline x86-64, for which this
// library is built, does not promise it). Read once, at load time (grid.cpp); false until then.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__POPCNT__)
#define NFD_POPCNT_AT_RUN_TIME 1
extern const bool kCpuHasPopcnt;
#endif

// Bits set in x by arithmetic: a dozen instructions, for targets without a bit-count instruction.
inline uint32_t popcount64_arithmetic(uint64_t x) {
    x = x - ((x >> 1) & 0x5555555555555555ull);
    x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
    x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0full;
    return uint32_t((x * 0x0101010101010101ull) >> 56);
}

// Bits set in x: the vertex sets' ranks, in the CPU path's inner loops. Where the target has the
// instruction (-mpopcnt, -march=x86-64-v2 or later, AArch64) the builtin is that instruction. On
// baseline x86-64 the builtin is a call into libgcc (__popcountdi2, 6% of a CPU decode), so the
// instruction is written out behind a test of the CPU that every call predicts alike: CPU decodes
// 1-4% and their mesh stage 4-11% faster than with the arithmetic alone (bench/RESULTS.md, 0.13.8).
inline uint32_t popcount64(uint64_t x) {
#if defined(__POPCNT__) || defined(__aarch64__)
    return uint32_t(__builtin_popcountll(x));
#else
#if defined(NFD_POPCNT_AT_RUN_TIME)
    if (__builtin_expect(kCpuHasPopcnt, 1)) {
        uint64_t bits;
        __asm__("popcntq %1, %0" : "=r"(bits) : "rm"(x) : "cc");
        return uint32_t(bits);
    }
#endif
    return popcount64_arithmetic(x);
#endif
}

// mc::kCornerOffset[k] as an index into a 3^3 block of vertices (x + 3y + 9z): a constant
// table, so that the corners of a 2^3 group's cells are read at constant offsets.
inline constexpr uint8_t kCornerIn27[8] = {0, 1, 3, 4, 9, 10, 12, 13};
static_assert([] {
    for (int k = 0; k < 8; ++k) {
        const uint8_t* o = mc::kCornerOffset[k];
        if (kCornerIn27[k] != o[0] + 3 * o[1] + 9 * o[2]) return false;
    }
    return true;
}(), "kCornerIn27 follows mc::kCornerOffset");

// A set of grid vertices with dense ranks, stored by blocks of 8^3 vertices: a block table over
// the (side / 8)^3 blocks (4 bytes each: 8.6 MB at resolution 1024) and, per occupied block, a
// 512-bit mask with the rank of its first vertex and a prefix count per 64-bit word. Memory
// follows the occupied blocks (the band around the surface), not side^3.
// Ranks follow the blocks in raster order (x fastest), then the vertices inside a block in
// raster order: for_each visits them in that order.
class VertexSet {
public:
    VertexSet() = default;
    // `side` vertices per axis (cells per axis + 1), at most 1025.
    explicit VertexSet(uint32_t side);
    uint32_t side() const { return side_; }

    // Building: insert every vertex, then finish() once; the set is read-only afterwards.
    void insert(uint32_t x, uint32_t y, uint32_t z);
    // The eight corners of the cell whose lowest corner is (x, y, z): where they share a block
    // (x and y not at a block's last vertex), two words of it, four bits each.
    void insert_cell(uint32_t x, uint32_t y, uint32_t z);
    void finish();
    // Or at once, on threads, instead of insert and finish: words_of(index, words) writes the
    // words of the block at `index` of the block table (word z & 7, bit (x & 7) + 8 * (y & 7))
    // and returns whether any is set; it is called twice for every index, on any thread.
    template <class WordsOf>
    void assign(WordsOf&& words_of, unsigned threads);

    uint32_t size() const { return size_; }
    // The rank of vertex (x, y, z), which must be in the set. Inline: the meshers' inner loops.
    uint32_t rank(uint32_t x, uint32_t y, uint32_t z) const {
        const Block& b = blocks_[table_[block_index(x, y, z)]];
        const uint64_t below = b.words[z & 7] & ((uint64_t(1) << ((x & 7) + 8 * (y & 7))) - 1);
        return b.prefix[z & 7] + popcount64(below);
    }
    // The ranks of the eight corners of the cell whose lowest corner is (x, y, z), in
    // mc::kCornerOffset order; all eight must be in the set. A cell's four corners at one z lie
    // in one block unless x or y is at a block's last vertex, and there they are bits p, p + 1,
    // p + 8 and p + 9 of one word, all set: two popcounts give the four ranks.
    void cell_ranks(uint32_t x, uint32_t y, uint32_t z, uint32_t r[8]) const {
        if ((x & 7) == 7 || (y & 7) == 7) {
            for (int k = 0; k < 8; ++k) r[k] = rank(x + (k & 1), y + (k >> 1 & 1), z + (k >> 2));
            return;
        }
        const uint32_t p = (x & 7) + 8 * (y & 7);
        for (uint32_t dz = 0; dz < 2; ++dz) {
            const Block& b = blocks_[table_[block_index(x, y, z + dz)]];
            const uint64_t word = b.words[(z + dz) & 7];
            const uint32_t low = b.prefix[(z + dz) & 7] + popcount64(word & ((uint64_t(1) << p) - 1));
            const uint32_t high = low + popcount64(word >> p & 0xFF);  // bits p..p+7 come before p+8
            r[4 * dz + 0] = low;
            r[4 * dz + 1] = low + 1;
            r[4 * dz + 2] = high;
            r[4 * dz + 3] = high + 1;
        }
    }
    // The ranks of the 3^3 vertices (x + i, y + j, z + k), i, j, k < 3, at r[9k + 3j + i]: the
    // corners of the eight cells of a 2^3 group at even (x, y, z) (corner j of cell k at
    // r[kCornerIn27[k] + kCornerIn27[j]]); all 27 must be in the set.
    // A row's three vertices are consecutive bits of one word unless x + 2 starts the next block.
    void sibling_ranks(uint32_t x, uint32_t y, uint32_t z, uint32_t r[27]) const {
        for (uint32_t k = 0; k < 3; ++k)
            for (uint32_t j = 0; j < 3; ++j) {
                uint32_t* row = r + 9 * k + 3 * j;
                row[0] = rank(x, y + j, z + k);
                row[1] = row[0] + 1;
                row[2] = (x & 7) == 6 ? rank(x + 2, y + j, z + k) : row[0] + 2;
            }
    }
    // An upper bound of the bytes a set of `side` vertices per axis in at most `blocks` blocks
    // allocates (the block table, and the blocks at their largest capacity).
    static uint64_t bytes_bound(uint32_t side, uint64_t blocks);
    // The rank of (x, y, z) if it is on the grid and in the set; coordinates may be out of range.
    // Inline: the SDF mesher's normals make eight finds per vertex.
    bool find(int64_t x, int64_t y, int64_t z, uint32_t* out_rank) const {
        if (x < 0 || y < 0 || z < 0 || x >= side_ || y >= side_ || z >= side_) return false;
        const uint32_t slot = table_[block_index(uint32_t(x), uint32_t(y), uint32_t(z))];
        if (slot == kNoBlock) return false;
        const Block& b = blocks_[slot];
        const uint32_t bit = uint32_t(x & 7) + 8 * uint32_t(y & 7);
        if (!(b.words[z & 7] >> bit & 1)) return false;
        *out_rank = b.prefix[z & 7] + popcount64(b.words[z & 7] & ((uint64_t(1) << bit) - 1));
        return true;
    }
    // fn(rank, x, y, z) for every vertex, in rank order.
    template <class Fn>
    void for_each(Fn&& fn) const {
        for_each_in_blocks(0, blocks_.size(), fn);
    }
    // The same for the vertices of blocks [first, end) of the blocks() the set occupies (8^3
    // vertices each, in rank order): threads can share a walk by block ranges.
    size_t blocks() const { return blocks_.size(); }
    template <class Fn>
    void for_each_in_blocks(size_t first, size_t end, Fn&& fn) const;
    // The block table: blocks per axis, and the slot in [0, blocks()) of block (bx, by, bz) (the
    // vertices 8 bx .. 8 bx + 7, ...), or kNoBlock where the set has none or it is off the grid.
    static constexpr uint32_t kNoBlock = ~0u;
    uint32_t blocks_per_axis() const { return blocks_per_axis_; }
    uint32_t block_slot(int64_t bx, int64_t by, int64_t bz) const {
        const int64_t m = blocks_per_axis_;
        if (bx < 0 || by < 0 || bz < 0 || bx >= m || by >= m || bz >= m) return kNoBlock;
        return table_[size_t((bz * m + by) * m + bx)];
    }

private:
    struct Block {
        uint64_t words[8];   // word z & 7, bit (x & 7) + 8 * (y & 7)
        uint32_t prefix[8];  // rank of the first vertex of each word
        uint32_t index;      // linear block index in the block table; blocks_ is sorted by it
    };
    Block& block_for_insert(uint32_t x, uint32_t y, uint32_t z);
    uint32_t block_index(uint32_t x, uint32_t y, uint32_t z) const {
        return ((z >> 3) * blocks_per_axis_ + (y >> 3)) * blocks_per_axis_ + (x >> 3);
    }
    uint32_t side_ = 0, blocks_per_axis_ = 0, size_ = 0;
    nfd::vector<uint32_t> table_;  // block index -> slot in blocks_, or kNoBlock
    nfd::vector<Block> blocks_;
};

// One level of the grid: the cells visited at that level (the coarse level: all of them; finer
// levels: the children of the previous level's kept cells, in order, each parent's children in
// mc::kCornerOffset order) and the field at their corners.
struct GridLevel {
    uint32_t level = 0;           // l: 0 = finest; vertex v of this level is fine vertex v << l
    uint32_t cells_per_axis = 0;  // cells_at_level(resolution, l)
    float cell_size = 0;          // h in the unit frame: step * 2^l; vertex v at -1 + v * h
    nfd::vector<uint32_t> cells;  // packed cell coordinates (their minimum corner)
    VertexSet vertices;           // the corners of `cells`
    nfd::vector<float> values;    // field at each vertex, by rank
    // For the UDF mesher of this level (GridBuilder::evaluate_udf_gradients): whether each cell
    // is near (udf_cell_is_near, 1 or 0, by index in `cells`); by vertex rank, kGradientKnown
    // where the gradient is known (every near cell's corner; with GridBuilder's gradient_levels,
    // every vertex the level's flood evaluated too) and kNearCorner at near cells' corners, and
    // the field gradient (unit frame), 3 floats per rank (0 where unknown). Empty otherwise.
    static constexpr uint8_t kGradientKnown = 1, kNearCorner = 2;
    nfd::vector<uint8_t> near;
    nfd::vector<uint8_t> gradient_flags;
    nfd::vector<float> gradients;
    // A coarsest level above the finest (evaluate_coarsest_level's probe): each probe cell's
    // verdict (probe_cells^3, raster order), 1 where its children's corners were all evaluated.
    // Empty on other levels. Meshing such a level (a progressive extraction) takes only those
    // children, as the GPU path does (it lists only them): a cell of a probe cell left out has
    // corners the probe filled in.
    nfd::vector<uint8_t> probe_kept;
    uint32_t probe_cells = 0;
    // The cells a mesher of this level takes: those `among` marks (per cell, non-zero; null: every
    // cell) but those of probe cells left out, in `storage`; `among` itself without a probe.
    const uint8_t* meshed_cells(const uint8_t* among, nfd::vector<uint8_t>* storage) const;
    // vertices := the corners of `cells`; values sized to match, zero.
    void collect_corners();
    // The values at the eight corners of a cell of this level, mc::kCornerOffset order.
    void corners(const uint32_t cell[3], float f[8]) const {
        uint32_t r[8];
        corners(cell, f, r);
    }
    // The same, and the corners' vertex ranks.
    void corners(const uint32_t cell[3], float f[8], uint32_t r[8]) const {
        vertices.cell_ranks(cell[0], cell[1], cell[2], r);
        for (int k = 0; k < 8; ++k) f[k] = values[r[k]];
    }
    // fn(i, cell, f, ranks) for cells[i], i in [begin, end), in order, with the cell's coordinates
    // and its eight corner values and vertex ranks (mc::kCornerOffset order); where `only` is
    // given, for the cells with only[i] != 0. Eight siblings listed together (the levels below the
    // coarsest list each parent's children so, unless the domain's end dropped some) read their 27
    // corners' ranks once (VertexSet::sibling_ranks), and not at all when `only` skips all eight.
    template <class Fn>
    void for_each_cell(size_t begin, size_t end, const uint8_t* only, Fn&& fn) const;
    // -1 + v * h equals the fine grid's -1 + (v << l) * step in f32: both products are the same
    // real number times a power of two, rounded once.
    float coord(uint32_t v) const { return -1.0f + float(v) * cell_size; }
};

struct GridOptions {
    // GridBuilder's `band` (build_grid_cpu serves nfd_grid_extract, whose product is the band).
    bool band = true;
    // Also evaluate the field gradient (unit frame) at the corners of the finest level's near
    // cells (udf_cell_is_near): what the UDF mesher needs.
    bool udf_gradients = false;
    // Non-zero: the bound of what the build holds (each step's next_*_bytes_bound added up, plus
    // `bytes_per_voxel` for each finest voxel: what the caller copies them into) must stay within
    // it, checked before each allocation, else NFD_ERROR_LIMIT_EXCEEDED.
    uint64_t max_host_bytes = 0;
    uint32_t bytes_per_voxel = 0;
};

// The UDF mesher's edge filter (extract.h, step 5): an edge of a finest cell of edge h is *valid*
// when f_a + f_b <= udf_edge_limit(h) (f32, in that order). A true distance field crossing the edge
// has f_a + f_b <= h; the factor covers gradient norms up to 1.5.
constexpr float kUdfEdgeFactor = 1.5f;
inline float udf_edge_limit(float h) { return kUdfEdgeFactor * h; }
// UDF surface following floods across the faces of a cell that hold an edge with f_a + f_b <=
// kUdfFloodEdge * h: a third more than a valid edge, so that a cluster of near cells beside the
// sheet behind a face whose edges only just fail the mesher's test is reached (the milk cloud at
// 256 loses 10 near cells at 1.5 h, none at 1.8 h; bench/RESULTS.md, "0.12").
constexpr float kUdfFloodEdge = 2.0f;
// A finest-level cell of a UDF is *near* (may carry triangles) when its corners are finite and its
// valid edges include the three edges of some triangle of the table (mc::Tables::holds_triangle):
// an emitted triangle needs three valid edges, so no other cell can emit one whatever its pseudo-
// signs, and only near cells need gradients. Every such cell has a corner within 0.75 h.
bool udf_cell_is_near(const float corner_values[8], float h);
// The mesher's valid edges of a cell of edge h (bit e for edge e of mc::kEdgeCorners), and the near
// test given them: the same verdict as above, for a caller that has the edges already.
uint32_t udf_valid_edges(const float corner_values[8], float h);
bool udf_cell_is_near(const float corner_values[8], uint32_t valid_edges);

struct GridStats {
    uint64_t points_evaluated = 0;     // field evaluations over all levels (values)
    uint64_t gradients_evaluated = 0;  // UDF meshing: see GridBuilder::evaluate_udf_gradients
    double seconds = 0;
};

struct SparseGrid {
    uint32_t resolution = 0;
    float step = 0;                 // fine cell edge in the unit frame, 2.0f / resolution
    FieldType field = FieldType::Sdf;
    float truncation = INFINITY;    // the file's d* (Geometry::truncation); infinity: not truncated
    nfd::vector<GridLevel> levels;  // levels[l] is level l: levels[0] is the finest
    GridStats stats;

    const GridLevel& finest() const { return levels.front(); }
    float coord(uint32_t fine_index) const { return -1.0f + float(fine_index) * step; }
};

// Surface following (levels below the coarsest, above): what a level's flood may enter.
struct FollowRegion {
    VertexSet parents;                 // the followed cells above (sign change, valid edge) and
                                       // their 26 neighbours
    nfd::vector<uint32_t> refine_all;  // the isolated cells above (step 3), packed
};
// The region below `level` (level.level > 0), and the size of the level it bounds. With
// `within_kept` (the GPU UDF mesher's finest level, GridBuilder's `follow_finest`), the region is
// the level's cells that the keep rule keeps, the followed ones among them, instead of the
// followed cells and their 26 neighbours: the band's parents, whose child grids the GPU path
// stores. Its isolated cells are then the kept ones with no followed cell among their 26
// neighbours, as without it. With `near` (a UDF level to be meshed): the level's near verdicts
// (GridLevel::near), from the corners this pass reads anyway; a near cell has valid edges, so it
// is a followed one.
void follow_region(const SparseGrid& grid, const GridLevel& level, FollowRegion* region,
                   LevelSize* next, bool within_kept = false, unsigned threads = 1,
                   nfd::vector<uint8_t>* near = nullptr);
// Visits and evaluates level `out` (level, cells_per_axis and cell_size set) below `parent`;
// `blocks`: its LevelSize::blocks, from follow_region. `with_gradients` (a UDF level to be
// meshed): each new vertex is evaluated with its gradient, and out->gradients and
// out->gradient_flags (kGradientKnown) are filled at them: about three in four are corners of the
// level's near cells (bench/RESULTS.md, "0.13.11"), whose gradients the mesher wants, and one
// evaluation of value and gradient costs less than a value now and both again later.
void follow_surface(const Network& net, const SparseGrid& grid, const GridLevel& parent,
                    const FollowRegion& region, uint64_t blocks, unsigned threads,
                    GridLevel* out, uint64_t* evaluated, bool with_gradients = false);
// What follow_region on a level of size `level` allocates, and what follow_surface allocates
// for a level of size `next` below a level of `parent_vertices` vertices beyond its cells, vertex
// set, values and evaluator (and, `with_gradients`, beyond the evaluator's gradients).
uint64_t follow_region_bytes_bound(const LevelSize& level, uint32_t child_cells,
                                   bool within_kept = false);
uint64_t follow_surface_bytes_bound(const LevelSize& next, uint64_t parent_vertices,
                                    bool with_gradients, unsigned threads);

// CPU reference of the coarse-to-fine evaluation, one level per step(): build_grid_cpu steps it
// to the finest level; a progressive extraction (progressive.h) meshes the levels on the way.
// A level's new corners are evaluated once; the corners it shares with its parent are copied.
class GridBuilder {
public:
    // `resolution` within NFD_MIN_RESOLUTION..NFD_MAX_RESOLUTION; `threads` as for evaluate_cpu.
    // `band`: the levels by the keep rule, for a band of values several cells deep on each side of
    // the surface (nfd_grid_extract's product), instead of surface following (the meshers', which
    // need only the sign-change or near cells). `follow_finest` (with `band`, UDF): the finest
    // level follows the surface within the kept cells of the level above (follow_region's
    // `within_kept`), as the GPU path does for the UDF mesher (gpu/levels.h,
    // evaluate_finest_flood). `gradient_levels` (UDF): bit l for each level whose gradients
    // evaluate_udf_gradients will be asked for (the meshed ones); where such a level follows the
    // surface, its flood evaluates the gradients as it goes (follow_surface's `with_gradients`).
    GridBuilder(const Geometry& geometry, uint32_t resolution, unsigned threads, bool band = false,
                bool follow_finest = false, uint32_t gradient_levels = 0);
    // Evaluates the next level (the coarse one first: all its cells; then the children of the
    // kept cells of the level before, or the cells surface following finds), then, unless it is
    // the finest, what decides the level after: the keep rule on its cells, or the region.
    void step();
    bool done() const { return stepped_ && current_ == 0; }
    uint32_t current() const { return current_; }  // the level the last step() evaluated
    // Gradients at the corners of the current level's near cells (GridLevel::gradients): known
    // from the level's flood, copied where the level above holds them at the same point (then
    // freed), evaluated elsewhere. The near verdicts come from the step's follow_region where it
    // ran (a level above the finest), else from a pass of their own. GridStats::
    // gradients_evaluated counts the near cells' corners that were not near cells' corners of
    // the level above: the corners whose gradients this level needs for itself, however they
    // were evaluated (the GPU path's count too).
    void evaluate_udf_gradients();
    // Upper bounds of the host bytes that the next step(), and evaluate_udf_gradients() after it,
    // allocate at their peak over what exists before them (counted: every vector they create at
    // its largest capacity, the evaluator's chunks and threads' scratch).
    uint64_t next_step_bytes_bound() const;
    uint64_t next_gradients_bytes_bound() const;
    LevelSize next_level_size() const;

    const SparseGrid& grid() const { return grid_; }
    SparseGrid take() { return std::move(grid_); }
    unsigned threads() const { return threads_; }  // as given: 0 = hardware concurrency

private:
    // Whether level l, the next to be stepped, follows the surface, and whether its flood
    // evaluates gradients.
    bool follows(uint32_t l) const { return stepped_ && (follow_ || (follow_finest_ && l == 0)); }
    bool flood_gradients(uint32_t l) const { return follows(l) && (gradient_levels_ >> l & 1); }
    // Whether level l's step ends with follow_region (else with the keep rule, or nothing at the
    // finest), and whether that also gives the level's near verdicts (a meshed UDF level).
    bool followed_below(uint32_t l) const { return l > 0 && (follow_ || (follow_finest_ && l == 1)); }
    bool region_near(uint32_t l) const { return followed_below(l) && (gradient_levels_ >> l & 1); }
    const Network& network_;
    const unsigned threads_;
    const bool follow_;         // surface following: without `band`
    const bool follow_finest_;  // band, then surface following at the finest level
    const uint32_t gradient_levels_;  // UDF: the levels whose floods evaluate gradients
    SparseGrid grid_;
    uint32_t current_ = 0;
    bool stepped_ = false;
    nfd::vector<uint8_t> kept_;  // keep rule: of the current level's cells, its verdicts
    FollowRegion region_;        // surface following: where the next level's flood may go
    LevelSize next_;             // of the next level, from the verdicts or the region
};

// Coarse-to-fine evaluation to the finest level, with GridOptions. NFD_ERROR_LIMIT_EXCEEDED
// outside NFD_MIN_RESOLUTION..NFD_MAX_RESOLUTION or beyond options.max_host_bytes.
nfd_result build_grid_cpu(const Geometry& geometry, uint32_t resolution, const GridOptions& options,
                          SparseGrid* grid, unsigned threads = 0);

template <class WordsOf>
void VertexSet::assign(WordsOf&& words_of, unsigned threads) {
    // Ranges of the block table count their blocks, then write them after the ranges before.
    constexpr size_t kRange = 4096;
    const size_t ranges = (table_.size() + kRange - 1) / kRange;
    nfd::vector<uint32_t> first(ranges + 1);
    for_each_range(table_.size(), kRange, threads, [&](size_t g, size_t begin, size_t end) {
        uint64_t words[8];
        uint32_t count = 0;
        for (size_t i = begin; i < end; ++i) count += words_of(i, words);
        first[g + 1] = count;
    });
    for (size_t g = 0; g < ranges; ++g) first[g + 1] += first[g];
    blocks_.resize(first[ranges]);
    for_each_range(table_.size(), kRange, threads, [&](size_t g, size_t begin, size_t end) {
        uint32_t slot = first[g];
        for (size_t i = begin; i < end; ++i) {
            uint64_t words[8];
            if (!words_of(i, words)) continue;
            Block& b = blocks_[slot];
            std::memcpy(b.words, words, sizeof(words));
            b.index = uint32_t(i);
            table_[i] = slot++;
        }
    });
    uint32_t total = 0;
    for (Block& b : blocks_)
        for (int w = 0; w < 8; ++w) {
            b.prefix[w] = total;
            total += popcount64(b.words[w]);
        }
    size_ = total;
}

template <class Fn>
void VertexSet::for_each_in_blocks(size_t first, size_t end, Fn&& fn) const {
    if (first >= end) return;
    uint32_t r = blocks_[first].prefix[0];
    for (size_t s = first; s < end; ++s) {
        const Block& b = blocks_[s];
        const uint32_t bx = b.index % blocks_per_axis_, by = b.index / blocks_per_axis_ % blocks_per_axis_,
                       bz = b.index / (blocks_per_axis_ * blocks_per_axis_);
        for (uint32_t w = 0; w < 8; ++w)
            for (uint64_t bits = b.words[w]; bits; bits &= bits - 1) {
                const uint32_t i = uint32_t(__builtin_ctzll(bits));  // x + 8 y within slice z = w
                fn(r++, 8 * bx + (i & 7), 8 * by + (i >> 3), 8 * bz + w);
            }
    }
}

template <class Fn>
void GridLevel::for_each_cell(size_t begin, size_t end, const uint8_t* only, Fn&& fn) const {
    // Whether cells[i..i+8) are the eight children of one parent in mc::kCornerOffset order.
    auto sibling_group = [this](size_t i) {
        const uint32_t base = cells[i];
        if (base & (1u | 1u << 11 | 1u << 22)) return false;  // an odd coordinate: not a first child
        for (int k = 1; k < 8; ++k) {
            const uint8_t* o = mc::kCornerOffset[k];
            if (cells[i + k] != base + pack_coords(o[0], o[1], o[2])) return false;
        }
        return true;
    };
    for (size_t i = begin; i < end;) {
        uint32_t c[3];
        unpack_coords(cells[i], c);
        if (i + 8 <= end && sibling_group(i)) {
            uint64_t wanted = 0xFF;  // any of the eight: their bytes as one word
            if (only) std::memcpy(&wanted, only + i, 8);
            if (wanted) {
                uint32_t r27[27];
                vertices.sibling_ranks(c[0], c[1], c[2], r27);
                for (int k = 0; k < 8; ++k) {
                    if (only && !only[i + k]) continue;
                    const uint8_t* o = mc::kCornerOffset[k];
                    const uint32_t ck[3] = {c[0] + o[0], c[1] + o[1], c[2] + o[2]};
                    const uint32_t* child = r27 + kCornerIn27[k];
                    uint32_t r[8];
                    float f[8];
                    for (int j = 0; j < 8; ++j) {
                        r[j] = child[kCornerIn27[j]];
                        f[j] = values[r[j]];
                    }
                    fn(i + k, ck, f, r);
                }
            }
            i += 8;
        } else {
            if (!only || only[i]) {
                uint32_t r[8];
                float f[8];
                corners(c, f, r);
                fn(i, c, f, r);
            }
            ++i;
        }
    }
}

}  // namespace nfd
