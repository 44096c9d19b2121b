// A UDF's finest level by surface following within the kept parents (grid.h, "UDF: surface
// following"; the CPU twin is grid_follow.cpp's follow_surface after follow_region's
// `within_kept`): instead of all 19 new points of every kept parent's child grid, the corners of
// the cells a flood reaches, each evaluated once with its gradient, into the parents' point slots
// (the predicted list's roles: NFD_B_OWNED's masks and offsets, a vec4 per owned point, of which
// only the evaluated ones are ever read). One source, one kernel per MODE (a compile-time
// definition, so that each holds only its own code: lavapipe compiles all of a module), run by
// LevelBuilder::evaluate_finest_flood in waves:
//   0 seed_midpoints  per kept parent: claim the midpoints of its valid edges (parent size)
//   1 seed_children   per kept parent: the children holding each half valid at the fine size
//   2 seed_isolated   per kept parent: all children of one with a valid edge but no seed, and no
//                     seed among its 26 neighbours, or with no valid edge and no neighbour that
//                     has one (the keep rule kept it: a small piece away from the rest)
//   3 claim_corners   per frontier entry: claim the corners of the parent's fresh children
//   4 flood_faces     per frontier entry: visit the neighbours behind the faces of its fresh
//                     children that hold an edge with f_a + f_b <= 2 h, inside kept parents;
//                     mark those of its fresh children that are near cells (udf_near's test)
//   5 list_points     per claimed point of a chunk: its unit-frame position
//   6 store_values    per claimed point of a chunk: its (value, gradient) into its owner's slot
// A point is claimed by setting its bit in its owner's NFD_B_FLOOD_CLAIMED word and appended to
// NFD_B_FLOOD_POINTS (counter push.tally_slot) by the claimant only, so it is evaluated once; a
// child is visited by setting its bit in NFD_B_FLOOD_VISITED, and its parent appended to the
// frontier (counter push.tally_slot + 1) when its first fresh bit of the wave is set. Both lists
// grow over the waves, never shrink: a point is claimed once (at most the owned points), a child
// visited once (at most 8 per parent), so their capacities bound them.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "bindings.h"
#define NFD_PREDICTED_VALUES
#define NFD_PREDICTED_ONLY
#define NFD_PREDICTED_WRITTEN
layout(std430, binding = NFD_B_PREDICTED) buffer Predicted { vec4 predicted[]; };
#include "extract.glsl"
layout(std430, binding = NFD_B_FLOOD_VISITED) buffer Visited { uint visited[]; };
layout(std430, binding = NFD_B_FLOOD_FRESH) buffer Fresh { uint fresh[]; };
layout(std430, binding = NFD_B_FLOOD_NEXT) buffer Next { uint next_fresh[]; };
layout(std430, binding = NFD_B_FLOOD_CLAIMED) buffer Claimed { uint claimed[]; };
layout(std430, binding = NFD_B_FLOOD_POINTS) buffer ClaimedPoints { uint claimed_points[]; };
layout(std430, binding = NFD_B_FLOOD_FRONTIER) buffer Frontier { uint frontier[]; };
layout(std430, binding = NFD_B_FLOOD_RESULTS) readonly buffer Results { vec4 results[]; };
layout(std430, binding = NFD_B_POINTS) writeonly buffer Points { float points[]; };
#if MODE == 4
// The near cells (udf_near.comp's test, which a flooded level skips): every visited child is fresh
// in one wave exactly, when this mode reads its corners anyway.
#include "mc.glsl"
layout(std430, binding = NFD_B_NEAR_MASKS) buffer NearMasks { uint near_masks[]; };
#endif

#ifndef MODE  // 0-6, from shaders/CMakeLists.txt: one kernel per mode
#error "udf_flood.comp needs MODE"
#endif
const uint SEEDED = 1u << 31;  // in a parent's claimed word: a seed came from its edges
// Of a 3^3 child grid's local points (local_index bits): the corners of the child at the origin
// (shift by a child's lowest corner for the others), and the parent's own corners.
const uint kChildCorners = 0x361Bu;     // locals 0, 1, 3, 4, 9, 10, 12, 13
const uint kParentCorners = 0x5140145u; // locals 0, 2, 6, 8, 18, 20, 24, 26

// The edges on face 2 axis + side of a cell (grid_follow.cpp's kFaceEdges).
uint face_edges(uint face) {
    uint axis = face / 2u, side = face & 1u, mask = 0u;
    for (uint e = 0u; e < 12u; ++e)
        if (e / 4u != axis && corner_offset(edge_start_corner(e))[axis] == side) mask |= 1u << e;
    return mask;
}

// The valid-edge limits of grid.h (udf_edge_limit, kUdfFloodEdge) from the fine cell edge, in
// the CPU's f32 operations.
float parent_edge_limit() {
    precise float h2 = push.step * 2.0;
    precise float limit = 1.5 * h2;
    return limit;
}
float fine_edge_limit() {
    precise float limit = 1.5 * push.step;
    return limit;
}
float flood_edge_limit() {
    precise float limit = 2.0 * push.step;
    return limit;
}
void parent_corners(uint k, out float f[8]) {
    for (uint i = 0u; i < 8u; ++i) f[i] = corners[8u * k + i];
}

// Claims point l of kept parent p's (rank k) child grid, not one of p's corners, for evaluation.
void claim(uvec3 p, uint k, uint around, uvec3 l) {
    uint ko;
    uvec3 o = local_owner(p, k, around, l, 3u, push.parent_cells, ko);
    uint local = local_index(2u * p + l - 2u * o), bit = 1u << local;
    if ((atomicOr(claimed[ko], bit) & bit) != 0u) return;
    claimed_points[atomicAdd(counters[push.tally_slot], 1u)] = ko << 5 | local;
}
// Claims the points `wanted` (local_index bits, none of p's corners) of kept parent p's (rank k)
// child grid: those p owns (own_mask) with one atomic each for the bits and the count.
void claim_points(uvec3 p, uint k, uint around, uint wanted, uint own_mask) {
    uint own = wanted & own_mask;
    uint added = own & ~atomicOr(claimed[k], own);
    if (added != 0u) {
        uint at = atomicAdd(counters[push.tally_slot], bitCount(added));
        for (; added != 0u; added &= added - 1u) claimed_points[at++] = k << 5 | uint(findLSB(added));
    }
    for (uint rest = wanted & ~own; rest != 0u; rest &= rest - 1u) {
        uint l = uint(findLSB(rest));
        claim(p, k, around, uvec3(l % 3u, (l / 3u) % 3u, l / 9u));
    }
}
// The value at point l (not a corner) of kept parent p's (rank k) child grid, p's own points
// through its mask and offset.
float point_value(uvec3 p, uint k, uint around, uvec3 l, uint own_mask, uint own_offset) {
    uint bit = 1u << local_index(l);
    if ((own_mask & bit) != 0u)
        return predicted[own_offset + bitCount(own_mask & (bit - 1u))].x;
    return child_grid_value(p, k, around, l, push.parent_cells);
}
// Visits children `bits` of kept parent rank k, the first time each: fresh in the next wave
// (`into_next`: the faces' visits), or in the first one (the seeds').
void visit(uint k, uint bits, bool into_next) {
    uint added = bits & ~atomicOr(visited[k], bits);
    if (added == 0u) return;
    uint before = into_next ? atomicOr(next_fresh[k], added) : atomicOr(fresh[k], added);
    if (before == 0u) frontier[atomicAdd(counters[push.tally_slot + 1u], 1u)] = k;
}
// The children of p that exist (those starting past the grid's last vertex are dropped).
uint existing_children(uvec3 p) {
    uint bits = 0u;
    for (uint c = 0u; c < 8u; ++c)
        if (child_cell_exists(2u * p + corner_offset(c))) bits |= 1u << c;
    return bits;
}
// Whether some kept parent among the 27 around p (`around`) satisfies `test` (1: seeded, 2: has a
// valid edge).
bool neighbour_has(uvec3 p, uint around, uint test) {
    uint r = push.parent_cells;
    for (uint n = 0u; n < 27u; ++n) {
        if ((around & (1u << n)) == 0u) continue;
        uint kn = kept_rank(cell_index(p + uvec3(n % 3u, (n / 3u) % 3u, n / 9u) - 1u, r));
        if (test == 1u && (claimed[kn] & SEEDED) != 0u) return true;
        if (test == 2u) {
            float f[8];
            parent_corners(kn, f);
            if (valid_edge_mask(f, parent_edge_limit()) != 0u) return true;
        }
    }
    return false;
}

#if MODE == 5 || MODE == 6
// Per claimed point of a chunk [push.first, push.first + count).
void main() {
    uint i = push.first + global_invocation_index(gl_WorkGroupSize.x);
    if (i - push.first >= item_count()) return;
    uint entry = claimed_points[i], k = entry >> 5, l = entry & 31u;
#if MODE == 5
    uvec3 p = cell_coords(kept_cells[k], push.parent_cells);
    vec3 u = child_point(2u * p + uvec3(l % 3u, (l / 3u) % 3u, l / 9u));
    uint j = i - push.first;
    points[3u * j] = u.x;
    points[3u * j + 1u] = u.y;
    points[3u * j + 2u] = u.z;
#else
    uint bit = 1u << l;
    predicted[predicted_offsets[k] + bitCount(predicted_owned[k] & (bit - 1u))] =
        results[i - push.first];
#endif
}
#else
// Per kept parent (modes 0-2) or frontier entry (3, 4).
void main() {
    uint i = push.first + global_invocation_index(gl_WorkGroupSize.x);
    if (i - push.first >= item_count()) return;
    uint r = push.parent_cells;
#if MODE <= 2
    uint k = i;
#else
    uint k = frontier[i];
#endif
    float f[8];
    parent_corners(k, f);
#if MODE <= 2
    uint valid = valid_edge_mask(f, parent_edge_limit());
#if MODE <= 1
    if (valid == 0u) return;  // most parents: no seed, no kept_around's loads
#endif
#endif
    uvec3 p = cell_coords(kept_cells[k], r);
    uint around = kept_around(p, r);
#if MODE <= 2
#if MODE == 2
    bool isolated = valid != 0u ? (claimed[k] & SEEDED) == 0u && !neighbour_has(p, around, 1u)
                                : !neighbour_has(p, around, 2u);
    if (isolated) visit(k, existing_children(p), false);
#else
    uint seeds = 0u, middles = 0u;
    bool seeded = false;
    uint own_mask = predicted_owned[k];
#if MODE == 1
    uint own_offset = predicted_offsets[k];
#endif
    for (uint e = 0u; e < 12u; ++e) {
        if ((valid & (1u << e)) == 0u) continue;
        uint axis = e / 4u, a = edge_start_corner(e), b = a + (1u << axis);
        uvec3 middle = 2u * corner_offset(a) + unit_axis(axis);
        // Past the level's last vertex (an odd cell count): the halves' cells are dropped.
        if (!child_point_exists(2u * p + middle)) continue;
#if MODE == 0
        middles |= 1u << local_index(middle);
#else
        float f_middle = point_value(p, k, around, middle, own_mask, own_offset);
        precise float lower_sum = f[a] + f_middle;
        precise float upper_sum = f_middle + f[b];
        bool lower = lower_sum <= fine_edge_limit(), upper = upper_sum <= fine_edge_limit();
        if (lower) seeds |= 1u << a;
        if (upper) seeds |= 1u << b;
        seeded = seeded || lower || upper;
#endif
    }
#if MODE == 0
    claim_points(p, k, around, middles, own_mask);
#else
    if (seeded) atomicOr(claimed[k], SEEDED);
    visit(k, seeds & existing_children(p), false);
#endif
#endif
#else
    // Frontier modes: the fresh children of parent k, and the points of its child grid that are
    // their corners, but for its own (known) corners. p's own points take its mask and offset,
    // loaded once, and one claim; the loops are unrolled so that on llvmpipe the arrays below
    // stay in registers (a loop counter's index is an 8-lane gather).
    uint bits = fresh[k];
    uint corners_of = 0u;
    [[unroll]] for (uint c = 0u; c < 8u; ++c)
        if ((bits & (1u << c)) != 0u) corners_of |= kChildCorners << local_index(corner_offset(c));
    uint wanted = corners_of & ~kParentCorners;
    uint own_mask = predicted_owned[k], own = wanted & own_mask;
#if MODE == 3
    claim_points(p, k, around, wanted, own_mask);
#else
    float grid[27];
    uint own_offset = predicted_offsets[k];
    [[dont_unroll]] for (uint l = 0u; l < 27u; ++l) {
        uint bit = 1u << l;
        uvec3 lv = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        grid[l] = 0.0;
        if ((corners_of & bit) == 0u) continue;
        if (is_corner(lv))
            grid[l] = f[corner_index(lv)];
        else if ((own & bit) != 0u)
            grid[l] = predicted[own_offset + bitCount(own_mask & (bit - 1u))].x;
        else
            grid[l] = child_grid_value(p, k, around, lv, r);
    }
    // The children reached across floodable faces, by parent: p itself (`inside`) and the one
    // behind each of its faces (`beside`), so that each gets one visit.
    uint inside = 0u, near = 0u;
    uint beside[6] = uint[6](0u, 0u, 0u, 0u, 0u, 0u);
    for (uint c = 0u; c < 8u; ++c) {
        if ((bits & (1u << c)) == 0u) continue;
        uvec3 d = corner_offset(c);
        float g[8];
        [[unroll]] for (uint j = 0u; j < 8u; ++j) g[j] = grid[local_index(d + corner_offset(j))];
        if (udf_cell_is_near(g, fine_edge_limit())) near |= 1u << c;
        uint floodable = valid_edge_mask(g, flood_edge_limit());
        [[unroll]] for (uint face = 0u; face < 6u; ++face) {
            if ((floodable & face_edges(face)) == 0u) continue;
            uint axis = face / 2u, side = face & 1u, child = c ^ (1u << axis);
            if (d[axis] == side) beside[face] |= 1u << child;  // across p's own face
            else inside |= 1u << child;
        }
    }
    if (near != 0u) near_masks[k] |= near;  // one frontier entry per parent and wave
    visit(k, inside & existing_children(p), true);
    [[unroll]] for (uint face = 0u; face < 6u; ++face) {
        if (beside[face] == 0u) continue;
        uint axis = face / 2u;
        uvec3 offset = uvec3(1u);  // of the neighbour, + 1 (kept_around's bits)
        offset[axis] = 2u * (face & 1u);
        if ((around & (1u << local_index(offset))) == 0u) continue;  // outside, or not kept
        uvec3 q = p + offset - 1u;
        visit(kept_rank(cell_index(q, r)), beside[face] & existing_children(q), true);
    }
    fresh[k] = 0u;
#endif
#endif
}
#endif
