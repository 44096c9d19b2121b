// The meshers over the sparse grid (grid.h): marching cubes of an SDF, pseudo-signed marching
// cubes of a UDF. Shared definitions of the CPU reference (mesh_sdf_cpu.cpp, mesh_udf_cpu.cpp),
// the GPU path (gpu/) and the numpy reference (encoder_py/nfencode/reference.py): all three visit
// the same cells, use the same generated table (mc_tables.h) and produce the same topology.
#pragma once
#include <cstdint>

#include "grid.h"
#include "mesh.h"
#include "network.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

struct ExtractStats {
    uint64_t points_evaluated = 0;     // field evaluations over all levels (values only)
    // Value + gradient evaluations (UDF): the points of the mesher's gradient list not copied from
    // the level above, the same on every path (the Vulkan path's finest level evaluates most of
    // them, and ~13% more points, in its value pass: gpu/levels.h, FinestLevel::predicted).
    uint64_t gradients_evaluated = 0;
    uint64_t active_cells = 0;         // finest-level cells that produced triangles
    double seconds_field = 0;          // coarse-to-fine evaluation (the grid stage)
    double seconds_mesh = 0;           // marching cubes, welding, normals
};

// ---- SDF ----------------------------------------------------------------------------------------
// Marching cubes (mc_tables.h) on the finest cells with a sign change (case bit c set when
// f(corner c) < 0), one welded vertex per crossed grid edge at the linear crossing, triangles in
// the order of the cells (GridLevel::cells) and of the table, vertices numbered by first use.
//
// Normals are the normalised gradient of the grid values, with no field evaluation of their own:
// a crossed edge from vertex v along axis a (crossed at t) is shared by four cells that all have a
// sign change, so the grid values around it were evaluated. Along a it is f(v + e_a) - f(v); across
// (axis b) it is the derivative at v and at v + e_a lerped by t, each (f(w + e_b) - f(w - e_b)) / 2,
// or one-sided where only one neighbour was evaluated (domain boundary, a cell outside the band),
// or 0 where neither was. All in units of 1 / cell. Where the gradient vanishes: the direction of
// the edge from its inside to its outside end.
// `level` is the grid's finest, or a coarser one meshed as if it were (progressive.h); positions
// go to `mesh` in `frame`. `threads` as evaluate_cpu's run every pass (marching.h); the mesh does
// not depend on them.
nfd_result mesh_sdf_cpu(const GridLevel& level, const OutputFrame& frame, unsigned threads,
                        MeshData* mesh, uint64_t* active_cells);

// ---- UDF (MeshUDF-style, fully parallel per cell) -------------------------------------------------
// A UDF f >= 0 has no sign to mesh; MeshUDF (Guillard et al., ECCV 2022) recovers one locally from
// the gradient: corners on opposite sides of the surface have opposite gradient directions. Every
// step below depends on one cell or one grid edge only, so cells run independently (GPU) and the
// three implementations agree:
//  1. Near cells: finest cells whose valid edges (step 5) could hold a triangle of the table
//     (grid.h, udf_cell_is_near). Only they can carry triangles; the grid holds the analytic
//     gradient g at all their corners.
//  2. Cell orientation n: the gradient at the corner with the smallest value (lowest corner index
//     on ties), flipped so that its largest-magnitude component (lowest axis on ties) is > 0. A
//     cell whose n is zero or not finite produces nothing.
//  3. Pseudo-signs: corner c is "inside" (case bit c set) when dot(g_c, n) < 0. Marching cubes on
//     that case with the same table as the SDF; triangles face +n (the side the gradients at
//     "outside" corners point to).
//  4. Vertices: on a crossed edge a-b (pseudo-signs differ) at t = f_a / (f_a + f_b) from a (0.5
//     when the sum is 0): the minimum of the V-shaped |distance| along the edge. t depends on the
//     edge only, so neighbouring cells weld to the same vertex (keyed by grid edge, as for SDF).
//  5. Face filter: an edge is *valid* when f_a + f_b <= udf_edge_limit(h) (grid.h: a true
//     distance field crossing the edge has f_a + f_b <= h; the factor covers gradient norms up to
//     1.5). A triangle is emitted only when its three edges are valid: this removes the faces that
//     the pseudo-signs put where there is no surface (past an open boundary, where it bounds the
//     overshoot to about half a cell; across the medial axis). Validity depends on the edge only,
//     so the filter is the same in both cells of an edge. Measured and rejected: also requiring
//     dot(g_a, g_b) < 0 — a learned UDF's valley is blunt and its gradients near the floor turn
//     tangential, so that test dropped a third of the candidate faces, most of them on the surface
//     (T-shirt w24 at 256: CD 0.0127 with it, 0.0114 without; largest floating fragment 0.6% vs
//     0.15% of the area), and its sign sat within f32 rounding of zero (bench/RESULTS.md, "UDF
//     extractor: variants measured").
//  6. Normals: per vertex (edge), normalize(g_a - g_b) flipped by the rule of step 2 (largest
//     component > 0); the edge axis where that is zero or not finite. UDF meshes have no inside:
//     winding and normals agree with each other cell by cell, not globally.
//  7. Order: triangles in cell order then table order, vertices numbered by first use, as for SDF.
// The level must hold its gradients (GridBuilder::evaluate_udf_gradients), else
// NFD_ERROR_INTERNAL. `frame` and `threads` as for mesh_sdf_cpu.
nfd_result mesh_udf_cpu(const GridLevel& level, const OutputFrame& frame, unsigned threads,
                        MeshData* mesh, uint64_t* active_cells);

// An upper bound of the host bytes the mesher of either type allocates on a level of that size
// (its temporaries and the mesh, vectors at their largest capacity).
uint64_t mesh_bytes_bound(const LevelSize& level);

// The mesher of the geometry's field type on the builder's current level (its gradients
// evaluated first for a UDF), positions mapped to the original frame (u * scale + center);
// `stats` gets the grid's counts so far and the mesher's.
nfd_result mesh_level_cpu(const Geometry& geometry, GridBuilder& builder, MeshData* mesh,
                          ExtractStats* stats);

// Grid then mesh_level_cpu on its finest level. `threads` as for evaluate_cpu; `band` and
// `follow_finest` as for GridBuilder (with both, the GPU path's schedule, for its tests).
nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats, unsigned threads = 0, bool band = false,
                            bool follow_finest = false);

}  // namespace nfd
