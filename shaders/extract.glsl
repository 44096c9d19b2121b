// Sparse coarse-to-fine sampling shared by refine_*.comp, gather_corners.comp and mc_*.comp; the
// GPU side of extract.h and extract_cpu.cpp. Level l has n = ceil(resolution / 2^l) cells per axis
// (r below), its vertex v is fine vertex v << l, and some of its cells are kept (may contain the
// surface). Its kept cells are a bitmap over the r^3 linear cell indices
// c = x + r (y + r z) plus the exclusive prefix sum of the words' popcounts, so that the rank of a
// kept cell (its position in the sorted list of kept cells) costs two loads and a popcount, and a
// whole level needs r^3 / 8 bytes (16 MiB at r = 512) instead of a dense index grid.
//
// Refining a kept cell p splits it into 8 children; their corners form a 3x3x3 grid of which the
// 8 even points are p's corners (known) and 19 are new. A new point on a face or edge of p is
// shared with neighbouring kept cells: it is evaluated once, by its *owner*, the kept cell with
// the smallest linear index whose closed box contains it. Each kept cell records which of its 27
// local points it owns (a bit mask, `owned`) and where its first one went in the compact list of
// evaluated values (`offset`, an exclusive prefix sum of the owned counts), so anyone can find a
// value: owner -> rank -> offset + popcount of the lower owned bits.
#ifndef NFD_EXTRACT_GLSL
#define NFD_EXTRACT_GLSL
#extension GL_EXT_control_flow_attributes : require
#include "bindings.h"
#define COUNTERS_BINDING NFD_B_COUNTERS
#include "counters.glsl"

layout(local_size_x = NFD_LOCAL_SIZE) in;
layout(std430, binding = NFD_B_KEPT_BITS) readonly buffer KeptBits { uint kept_bits[]; };
layout(std430, binding = NFD_B_KEPT_PREFIX) readonly buffer KeptPrefix { uint kept_prefix[]; };
layout(std430, binding = NFD_B_KEPT_CELLS) readonly buffer KeptCells { uint kept_cells[]; };
layout(std430, binding = NFD_B_CORNERS) readonly buffer Corners { float corners[]; };
#ifndef NFD_KEPT_AROUND_WRITTEN  // level_around.comp writes it
// Per kept cell, kept_around's bits (below), found once per level by level_around.comp.
layout(std430, binding = NFD_B_KEPT_AROUND) readonly buffer KeptAround { uint kept_arounds[]; };
#endif
layout(std430, binding = NFD_B_OWNED) buffer Owned { uint owned[]; };
layout(std430, binding = NFD_B_OFFSETS) buffer Offsets { uint offsets[]; };  // into `values`
layout(std430, binding = NFD_B_VALUES) readonly buffer Values { float values[]; };

// One push-constant block for every kernel of a refinement step (parent level l + 1 -> l).
layout(push_constant) uniform LevelPush {
    vec4 center;        // mc_vertices: original = unit * scale + center.xyz
    uint parent_cells;  // cells per axis of the parent level
    uint child_cells;   // of the child level: 2 * parent_cells or one less (the last is dropped)
    uint count;         // capacity of the items (kept parents; kept children: gather_corners;
                        // vertices: mc_vertices, udf_vertices; points: dense_lookup), and with
                        // count_slot and first their number: item_count()
    uint child_level;   // l: child-grid point v is fine vertex v << l
    float step;         // fine cell edge, 2.0f / resolution
    float threshold;    // refine_cells: the activity threshold of a child cell
    float scale;        // mc_vertices, udf_vertices
    float edge_limit;   // UDF: the largest f_a + f_b of a valid edge (grid.h, udf_edge_limit)
    uint first;         // the first item (dense_lookup, udf_flood.comp: of a chunk of points)
    uint count_slot;    // the counter with the items' total (counters.glsl), or NFD_NO_COUNTER
    uint tally_slot;    // udf_gradient_count, progressive levels: the counter of the corners it
                        // copies from the level above (else NFD_NO_COUNTER)
    uint list_first;    // refine_points: its chunk of the point list, NFD_POINT_CHUNK points
                        // from this one on
} push;

uint item_count() { return counted_items(push.count, push.count_slot, push.first); }

vec3 child_point(uvec3 v) {
    return vec3(fine_coordinate(v.x << push.child_level, push.step),
                fine_coordinate(v.y << push.child_level, push.step),
                fine_coordinate(v.z << push.child_level, push.step));
}
// Children starting at or past child_cells are dropped (extract.h), and with them the points
// beyond: a child-grid point exists when no coordinate exceeds child_cells.
bool child_point_exists(uvec3 v) { return all(lessThanEqual(v, uvec3(push.child_cells))); }
bool child_cell_exists(uvec3 c) { return all(lessThan(c, uvec3(push.child_cells))); }

// Index of point l (each component 0..2) in a cell's 3x3x3 child grid; even points are corners.
uint local_index(uvec3 l) { return l.x + 3u * l.y + 9u * l.z; }
bool is_corner(uvec3 l) { return ((l.x | l.y | l.z) & 1u) == 0u; }
uint corner_index(uvec3 l) { return (l.x >> 1) | (l.y & 2u) | ((l.z & 2u) << 1); }  // l even
uvec3 corner_offset(uint c) { return uvec3(c & 1u, (c >> 1) & 1u, (c >> 2) & 1u); }
uvec3 unit_axis(uint a) { return uvec3(a == 0u ? 1u : 0u, a == 1u ? 1u : 0u, a == 2u ? 1u : 0u); }
// mc_tables.h's kEdgeCorners[e][0]: edge e runs along axis e / 4 from the corner whose other two
// coordinates, lower axis first, are the bits of e % 4. Folds to a constant in unrolled loops, so
// that per-invocation arrays are read at constant indices (on llvmpipe a read at a computed index
// is an 8-lane gather); mc.glsl's table lookup measured faster where e is computed.
uint edge_start_corner(uint e) {
    uint axis = e / 4u, j = e & 3u;
    return (j & 1u) << (axis == 0u ? 1u : 0u) | (j >> 1) << (axis == 2u ? 1u : 2u);
}
// The cube edges (bit e) of a cell with corner values f whose f_a + f_b <= limit (f32, in that
// order): grid.h's valid edges, with a UDF limit.
uint valid_edge_mask(float f[8], float limit) {
    uint valid = 0u;
    [[unroll]] for (uint e = 0u; e < 12u; ++e) {
        uint a = edge_start_corner(e), b = a + (1u << (e / 4u));
        precise float sum = f[a] + f[b];
        if (sum <= limit) valid |= 1u << e;
    }
    return valid;
}

uvec3 cell_coords(uint c, uint r) { return uvec3(c % r, (c / r) % r, c / (r * r)); }
uint cell_index(uvec3 p, uint r) { return p.x + r * (p.y + r * p.z); }

uint kept_rank(uint c) {
    return kept_prefix[c >> 5] + bitCount(kept_bits[c >> 5] & ((1u << (c & 31u)) - 1u));
}

// Owners are found on bits: the kept bits of the 27 cells around a kept cell (`around`: bit
// (x + 1) + 3 (y + 1) + 9 (z + 1) for the cell at offset (x, y, z), clear outside the grid; the
// cell's own bit 13 set) hold every candidate owner of its child grid's points and edges (the
// cell and those neighbours whose closed box holds one), so each owner is a few ALU steps. The
// bits are found once per level, by level_around.comp into kept_arounds[rank]: on llvmpipe every
// load is an 8-lane gather, and a search of the bitmap per point made several. udf_flood.comp,
// at its pipelines' 16 bindings, computes its own.
uint kept_around(uvec3 p, uint r) {
    uint around = 0u;
    for (uint z = 0u; z < 3u; ++z) {
        for (uint y = 0u; y < 3u; ++y) {
            if (p.z + z < 1u || p.z + z > r || p.y + y < 1u || p.y + y > r) continue;
            // The row's three cells lie in at most two words of the bitmap: two loads, not three.
            uint c = cell_index(uvec3(p.x, p.y + y - 1u, p.z + z - 1u), r);
            uint lo = p.x > 0u ? c - 1u : c, hi = p.x + 1u < r ? c + 1u : c;
            uint lo_word = kept_bits[lo >> 5], hi_word = kept_bits[hi >> 5];
            for (uint x = 0u; x < 3u; ++x) {
                if (p.x + x < 1u || p.x + x > r) continue;
                uint cell = c + x - 1u;
                uint word = (cell >> 5) == (lo >> 5) ? lo_word : hi_word;
                if ((word & (1u << (cell & 31u))) != 0u) around |= 1u << (x + 3u * y + 9u * z);
            }
        }
    }
    return around;
}
// The first kept cell (the owner rule's order: z, then y, then x ascending) among p's neighbours at
// offsets + 1 from lo to hi (components 0..2, lo <= hi), as an offset + 1 from p; false where none
// is kept. That order is the bits' (x + 3 y + 9 z), so it is the lowest bit of `around` within
// the box, whose mask is the product of the three axes' ranges spread to their strides: no loop
// whose trip count differs from lane to lane. The loops over a child grid's 27 points that call
// it are [[dont_unroll]]: with no loop left inside them Mesa unrolls them, and llvmpipe, which
// compiles every pipeline in every process, took half as long again to create a context
// (callgrind: 1,356 -> 2,033 M instructions) for ~25 ms less decoding of the bunny at 256.
uint axis_range(uint lo, uint hi) { return ((2u << hi) - 1u) & ~((1u << lo) - 1u); }
bool first_kept_around(uint around, uvec3 lo, uvec3 hi, out uvec3 o) {
    uint ys = axis_range(lo.y, hi.y), zs = axis_range(lo.z, hi.z);
    uint rows = axis_range(lo.x, hi.x) * ((ys & 1u) | (ys & 2u) << 2 | (ys & 4u) << 4);
    uint box = rows * ((zs & 1u) | (zs & 2u) << 8 | (zs & 4u) << 16);
    uint hit = around & box;
    uint n = uint(findLSB(hit));
    o = hit != 0u ? uvec3(n % 3u, (n / 3u) % 3u, n / 9u) : uvec3(1u);
    return hit != 0u;
}
// The owner of the point of p's child grid at local l (components 0..2), or with `axis` < 3 of the
// edge from l along that axis, as an offset + 1 from p (components 0..2): the first kept one of
// the cells whose closed box holds it (p, and p's neighbour below where a component of l is 0,
// above where it is 2; an edge lies inside p along its axis) in ascending linear index.
uvec3 owner_around(uint around, uvec3 l, uint axis) {
    uvec3 lo = (l + 1u) / 2u, hi = (l + 2u) / 2u;
    if (axis < 3u) lo[axis] = hi[axis] = 1u;
    uvec3 o;
    first_kept_around(around, lo, hi, o);  // p itself, whose bit is always set, at the latest
    return o;
}
// The owner of point l (axis 3) or of the edge from l along `axis` of kept cell p's (rank k)
// child grid, and its rank: p's own where p owns it.
uvec3 local_owner(uvec3 p, uint k, uint around, uvec3 l, uint axis, uint r, out uint rank) {
    uvec3 o = owner_around(around, l, axis);
    bool own = all(equal(o, uvec3(1u)));
    rank = own ? k : kept_rank(cell_index(p + o - 1u, r));
    return p + o - 1u;
}

// The child-grid coordinates of point i of a point list: its parent is the last one whose offset
// is at most i (a binary search over the offsets, which are non-decreasing over the whole buffer:
// parents past the last one own no points), and it is that parent's (i - offset)-th owned point
// in ascending local order, the order child_grid_value() assumes.
uvec3 listed_point(uint i) {
    uint lo = 0u, hi = uint(offsets.length());  // offsets[lo] <= i < offsets[hi] (or hi = end)
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (offsets[mid] <= i) lo = mid;
        else hi = mid;
    }
    uint mask = owned[lo];
    for (uint skip = i - offsets[lo]; skip > 0u; --skip) mask &= mask - 1u;
    uint l = uint(findLSB(mask));
    uvec3 p = cell_coords(kept_cells[lo], push.parent_cells);
    return 2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
}

// Compiled with NFD_PREDICTED_VALUES (the variants that read a UDF's finest level after
// udf_predict.comp), some new points are in the predicted list instead of the value list.
#ifdef NFD_PREDICTED_VALUES
layout(std430, binding = NFD_B_PREDICTED_OWNED) readonly buffer PredictedOwned {
    uint predicted_owned[];
};
layout(std430, binding = NFD_B_PREDICTED_OFFSETS) readonly buffer PredictedOffsets {
    uint predicted_offsets[];
};
#ifndef NFD_PREDICTED_WRITTEN  // udf_flood.comp declares it writable
layout(std430, binding = NFD_B_PREDICTED) readonly buffer Predicted { vec4 predicted[]; };
#endif
#endif

// Value at child-grid point v, not a corner of its kept cell, from its owner o (rank ko).
float owned_value(uvec3 v, uvec3 o, uint ko) {
    uint bit = 1u << local_index(v - 2u * o);
#ifdef NFD_PREDICTED_ONLY  // udf_flood.comp: every owned point has its slot there, and the
                           // value list's roles are not bound
    return predicted[predicted_offsets[ko] + bitCount(predicted_owned[ko] & (bit - 1u))].x;
#else
#ifdef NFD_PREDICTED_VALUES
    if ((predicted_owned[ko] & bit) != 0u)
        return predicted[predicted_offsets[ko] + bitCount(predicted_owned[ko] & (bit - 1u))].x;
#endif
    return values[offsets[ko] + bitCount(owned[ko] & (bit - 1u))];
#endif
}
// Value at point l of the child grid of kept cell p (rank k, kept-neighbour bits `around`) at
// level r.
float child_grid_value(uvec3 p, uint k, uint around, uvec3 l, uint r) {
    if (is_corner(l)) return corners[8u * k + corner_index(l)];
    uint ko;
    uvec3 o = local_owner(p, k, around, l, 3u, r, ko);
    return owned_value(2u * p + l, o, ko);
}

// Kept cell p's (rank k) whole child grid into `grid` (index local_index(l); 0 where a point does
// not exist). Returns kept_around(p), which the kernel may use again for owners of edges.
// p's own points (most of them) take its mask and offset, loaded once (on llvmpipe each load is
// an 8-lane gather).
uint load_child_grid(uvec3 p, uint k, uint r, out float grid[27]) {
    uint around = kept_arounds[k];
    uint own_mask = owned[k], own_offset = offsets[k];
    [[dont_unroll]] for (uint l = 0u; l < 27u; ++l) {
        uvec3 lv = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        uint bit = 1u << l;
        if (!child_point_exists(2u * p + lv))
            grid[l] = 0.0;
        else if ((own_mask & bit) != 0u)
            grid[l] = values[own_offset + bitCount(own_mask & (bit - 1u))];
        else
            grid[l] = child_grid_value(p, k, around, lv, r);
    }
    return around;
}

// The keep rule of grid.h (cell_may_contain_surface), on a child's 8 corner values; NaN
// corners fail every comparison, so such cells are dropped as on the CPU.
bool may_contain_surface(float v[8], float threshold) {
    bool inside = false, outside = false;
    float nearest = uintBitsToFloat(0x7f800000u);  // +infinity
    for (int c = 0; c < 8; ++c) {
        inside = inside || v[c] < 0.0;
        outside = outside || v[c] >= 0.0;
        nearest = abs(v[c]) < nearest ? abs(v[c]) : nearest;  // std::min: NaN never wins
    }
    return (inside && outside) || nearest <= threshold;
}

#endif
