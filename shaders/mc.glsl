// Marching cubes on the finest level, shared by the SDF (mc_*.comp) and UDF (udf_*.comp) kernels.
// The parents are the kept cells of level 1 (extract.glsl); the cells that marching cubes visits
// are all their (existing) children, whose corners are the parents' child grids. A classify
// kernel (mc_classify, udf_classify) writes per parent each child's cube case and which of its
// table triangles are emitted (`cases`), the owned edges that carry a vertex (`edge_masks`) and
// the triangle count; mc_emit.comp turns them into welded triangles for both field types.
//
// A vertex is made for every crossed edge of the child grid (one whose end points differ in
// sign: f < 0 inside, as mc_tables.h defines). An edge is shared by up to four visited cells,
// possibly of different parents; it belongs to the kept parent with the smallest linear index
// whose closed box contains it (the owner rule), found by extract.glsl's owner_around. The 54
// edges of a 3x3x3 grid are numbered axis by axis: id = 18 a + (index of the start point s, s[a]
// in {0, 1}, the other two in {0, 1, 2}).
// A vertex's index is the prefix of the edge masks' popcounts (`vertex_offsets`, per uint word
// of edge_masks) at its owner's first word plus its rank in the owner's mask.
#ifndef NFD_MC_GLSL
#define NFD_MC_GLSL

// mc_tables.h as uploaded by device.cpp: triangles[256][16] (edge ids, -1 padded), then
// triangle_count[256], then kEdgeCorners[12][2], then holds_triangle[128], then per case its
// triangles' edges as 12-bit masks (triangle t at bit 12 t of a pair of words).
layout(std430, binding = NFD_B_MC_TABLES) readonly buffer Tables { int mc_tables[]; };
// Byte i of cases[k] (i = 0..7 in .xy) is child i's cube case, byte 8 + i (.zw) the mask of its
// table triangles that are emitted.
layout(std430, binding = NFD_B_CASES) buffer Cases { uvec4 cases[]; };
layout(std430, binding = NFD_B_EDGE_MASKS) buffer EdgeMasks { uvec2 edge_masks[]; };
// Bit i: child i emits a triangle (its byte 8 + i of `cases` is not 0), for mc_emit's cell list.
layout(std430, binding = NFD_B_EMITTING) buffer Emitting { uint emitting[]; };

uint case_byte(uvec4 c, uint i) { return (c[i >> 2] >> (8u * (i & 3u))) & 0xffu; }
void set_case_byte(inout uvec4 c, uint i, uint value) { c[i >> 2] |= value << (8u * (i & 3u)); }

int mc_triangle_edge(uint cube_case, uint i) { return mc_tables[16u * cube_case + i]; }
uint mc_triangle_count(uint cube_case) { return uint(mc_tables[4096u + cube_case]); }
uint mc_edge_start_corner(uint e) { return uint(mc_tables[4096u + 256u + 2u * e]); }
uvec2 mc_triangle_edge_masks(uint cube_case) {
    uint at = 4096u + 256u + 24u + 128u + 2u * cube_case;
    return uvec2(mc_tables[at], mc_tables[at + 1u]);
}
// The edges of triangle t of a case whose masks (mc_triangle_edge_masks) are `masks`, as bits.
uint mc_triangle_edge_mask(uvec2 masks, uint t) {
    uint bit = 12u * t;
    uint low = bit < 32u ? masks.x >> bit : 0u;
    uint high = bit == 0u ? 0u : bit < 32u ? masks.y << (32u - bit) : masks.y >> (bit - 32u);
    return (low | high) & 0xfffu;
}
// Whether the edges in the 12-bit mask include all three edges of some triangle of the table.
bool mc_holds_triangle(uint edge_mask) {
    return (uint(mc_tables[4096u + 256u + 24u + edge_mask / 32u]) >> (edge_mask % 32u) & 1u) != 0u;
}
// A UDF's near cell (grid.h, udf_cell_is_near): corners finite, and valid edges (limit: the
// mesher's) holding some table triangle.
bool udf_cell_is_near(float f[8], float limit) {
    bool finite = true;
    [[unroll]] for (uint c = 0u; c < 8u; ++c) finite = finite && !isnan(f[c]) && !isinf(f[c]);
    return finite && mc_holds_triangle(valid_edge_mask(f, limit));
}

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
// The edges of a parent's child grid (bit edge_id) that lie in the closed box of its neighbour n
// (kept_around's bit n: offset + 1 = (n % 3, n / 3 % 3, n / 9)), for the 13 neighbours that
// the owner rule tries before the parent: those level with the parent along the edge's axis and,
// across it, below where the edge lies on the parent's low face (local 0), above where on its
// high face (local 2), level where in between. The four that touch the parent in a point hold
// none.
const uvec2 kEdgesInNeighbour[13] = uvec2[13](
    uvec2(0u, 0u), uvec2(0x3u, 0u), uvec2(0u, 0u), uvec2(0x240000u, 0u), uvec2(0xfc003fu, 0u),
    uvec2(0x900000u, 0u), uvec2(0u, 0u), uvec2(0x30u, 0u), uvec2(0u, 0u), uvec2(0u, 0x2010u),
    uvec2(0x30c3u, 0xe070u), uvec2(0u, 0x8040u), uvec2(0x49240000u, 0x92492u));

// The edges of a parent's child grid that belong to a kept neighbour (`around`: kept_around) and
// not to the parent: the owner rule on bits.
uvec2 edges_owned_elsewhere(uint around) {
    uvec2 taken = uvec2(0u);
    [[unroll]] for (uint n = 0u; n < 13u; ++n)
        if ((around & (1u << n)) != 0u) taken |= kEdgesInNeighbour[n];
    return taken;
}
bool mask_has(uvec2 mask, uint id) {
    return id < 32u ? (mask.x & (1u << id)) != 0u : (mask.y & (1u << (id - 32u))) != 0u;
}
uint mask_rank(uvec2 mask, uint id) {  // set bits below id
    if (id < 32u) return bitCount(mask.x & ((1u << id) - 1u));
    return bitCount(mask.x) + bitCount(mask.y & ((1u << (id - 32u)) - 1u));
}

// The current parent's child grid (0 where a point does not exist), from the level's sparse
// storage (extract.glsl). A dense copy per parent would make later lookups one load, but at
// resolution 1024 it is 108 bytes for each of ~1.8M parents, more than the sparse storage itself.
// Returns kept_around(p), which the kernel may use again for owners of edges.
float grid[27];
uint load_grid(uvec3 p, uint k, uint r) { return load_child_grid(p, k, r, grid); }

// The value at point l of kept parent p's (rank k) child grid, where l may lie one step beyond it
// (components -1..3), if it was evaluated: from p's corners, or from the point's owner among p and
// its neighbours (`around`, kept_around), found on bits by the owner rule.
bool grid_value(ivec3 l, uvec3 p, uint k, uint around, uint r, out float f) {
    ivec3 w = 2 * ivec3(p) + l;
    if (any(lessThan(w, ivec3(0))) || !child_point_exists(uvec3(w))) return false;
    bool inside_box = all(greaterThanEqual(l, ivec3(0))) && all(lessThanEqual(l, ivec3(2)));
    if (inside_box && is_corner(uvec3(l))) {
        f = corners[8u * k + corner_index(uvec3(l))];
        return true;
    }
    uvec3 o;  // offset + 1 from p; the cells whose closed box holds w along each axis
    if (!first_kept_around(around, uvec3((l + 1) / 2), uvec3((l + 2) / 2), o)) return false;
    bool own = all(equal(o, uvec3(1u)));
    uvec3 q = p + o - 1u;
    uint kq = own ? k : kept_rank(cell_index(q, r));
    uvec3 local = uvec3(w) - 2u * q;
    f = is_corner(local) ? corners[8u * kq + corner_index(local)] : owned_value(uvec3(w), q, kq);
    return true;
}

// extract.h's normal: derivative along axis b at local point l (value fl), in units of 1 / cell,
// central where both neighbours were evaluated, one-sided where one was, 0 where neither (as
// mesh_sdf_cpu.cpp).
float grid_derivative(ivec3 l, float fl, uint b, uvec3 p, uint k, uint around, uint r) {
    ivec3 e = ivec3(unit_axis(b));
    float hi, lo;
    bool has_hi = grid_value(l + e, p, k, around, r, hi);
    bool has_lo = grid_value(l - e, p, k, around, r, lo);
    precise float d = has_hi && has_lo ? 0.5 * (hi - lo) : has_hi ? hi - fl : has_lo ? fl - lo : 0.0;
    return d;
}

// The normal at the crossing (parameter t) of the edge from local point s of kept parent p's child
// grid along axis a, whose end values are fa and fb.
vec3 edge_normal(uvec3 s, uint a, float fa, float fb, float t, uvec3 p, uint k, uint around,
                 uint r) {
    vec3 g;
    g[a] = fb - fa;
    for (uint b = 0u; b < 3u; ++b) {
        if (b == a) continue;
        float d0 = grid_derivative(ivec3(s), fa, b, p, k, around, r);
        float d1 = grid_derivative(ivec3(s + unit_axis(a)), fb, b, p, k, around, r);
        precise float gb = d0 + t * (d1 - d0);
        g[b] = gb;
    }
    float len = sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
    if (len > 0.0 && !isinf(len) && !isnan(len)) return g / len;
    vec3 n = vec3(0.0);  // flat field at the vertex: its edge still tells inside from outside
    n[a] = fa < 0.0 ? 1.0 : -1.0;
    return n;
}

// The cube case of child d of a parent whose points inside (f < 0) are the set bits
// local_index(l) of `inside_bits`.
uint cube_case(uint inside_bits, uvec3 d) {
    uint c = 0u;
    [[unroll]] for (uint i = 0u; i < 8u; ++i)
        c |= (inside_bits >> local_index(d + corner_offset(i)) & 1u) << i;
    return c;
}

#endif
