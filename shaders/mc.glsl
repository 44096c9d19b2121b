// Marching cubes on the finest level, shared by mc_classify.comp and mc_emit.comp. The parents
// are the kept cells of level 1 (bindings 0-6 of extract.glsl); the cells that marching cubes
// visits are all their (existing) children, whose corners are the parents' child grids.
//
// A vertex is made for every crossed edge of the child grid (one whose end points differ in
// sign: f < 0 inside, as mc_tables.h defines). An edge is shared by up to four visited cells,
// possibly of different parents; it belongs to the kept parent with the smallest linear index
// whose closed box contains it, found like child-grid points (owner_cell) from its midpoint in
// quarter-cell units. The 54 edges of a 3x3x3 grid are numbered axis by axis:
// id = 18 a + (index of the start point s, s[a] in {0, 1}, the other two in {0, 1, 2}).
#ifndef NFD_MC_GLSL
#define NFD_MC_GLSL

// mc_tables.h as uploaded by gpu_decode.cpp: triangles[256][16] (edge ids, -1 padded), then
// triangle_count[256], then kEdgeCorners[12][2].
layout(std430, binding = 7) readonly buffer Tables { int mc_tables[]; };
layout(std430, binding = 8) buffer EdgeMasks { uvec2 edge_masks[]; };  // owned crossed edges

int mc_triangle_edge(uint cube_case, uint i) { return mc_tables[16u * cube_case + i]; }
uint mc_triangle_count(uint cube_case) { return uint(mc_tables[4096u + cube_case]); }
uint mc_edge_start_corner(uint e) { return uint(mc_tables[4096u + 256u + 2u * e]); }

uvec3 unit_axis(uint a) { return uvec3(a == 0u ? 1u : 0u, a == 1u ? 1u : 0u, a == 2u ? 1u : 0u); }

uint edge_id(uint a, uvec3 s) {
    if (a == 0u) return s.x + 2u * s.y + 6u * s.z;
    if (a == 1u) return 18u + s.x + 3u * s.y + 6u * s.z;
    return 36u + s.x + 3u * s.y + 9u * s.z;
}
void edge_from_id(uint id, out uint a, out uvec3 s) {
    a = id / 18u;
    uint i = id % 18u;
    if (a == 0u) s = uvec3(i % 2u, (i / 2u) % 3u, i / 6u);
    else if (a == 1u) s = uvec3(i % 3u, (i / 3u) % 2u, i / 6u);
    else s = uvec3(i % 3u, (i / 3u) % 3u, i / 9u);
}
bool mask_has(uvec2 mask, uint id) {
    return id < 32u ? (mask.x & (1u << id)) != 0u : (mask.y & (1u << (id - 32u))) != 0u;
}
uint mask_rank(uvec2 mask, uint id) {  // set bits below id
    if (id < 32u) return bitCount(mask.x & ((1u << id) - 1u));
    return bitCount(mask.x) + bitCount(mask.y & ((1u << (id - 32u)) - 1u));
}

float grid[27];  // the current parent's child grid (0 where a point does not exist)
void load_grid(uvec3 p, uint k, uint r) {
    for (uint l = 0u; l < 27u; ++l) {
        uvec3 lv = uvec3(l % 3u, (l / 3u) % 3u, l / 9u);
        grid[l] = child_point_exists(2u * p + lv) ? child_grid_value(p, k, lv, r) : 0.0;
    }
}
bool inside(uvec3 l) { return grid[local_index(l)] < 0.0; }

uint cube_case(uvec3 d) {  // child d of the current parent
    uint c = 0u;
    for (uint i = 0u; i < 8u; ++i)
        if (inside(d + corner_offset(i))) c |= 1u << i;
    return c;
}

// The kept parent owning the finest-level edge from grid point v (level 2r) along axis a.
uvec3 edge_owner(uvec3 v, uint a, uint r) { return owner_cell(2u * v + unit_axis(a), 4u, r); }

#endif
