// Sparse coarse-to-fine field sampling and marching cubes: the definitions shared by the CPU
// reference (extract_cpu.cpp) and the GPU path (gpu/), so that both visit the same cells.
#pragma once
#include <cstdint>

#include "mesh.h"
#include "network.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

// Grid of `resolution` cells per axis over the unit frame [-1, 1]^3: vertex i sits at
// -1 + 2 i / resolution (computed in f32 as -1.0f + float(i) * (2.0f / float(resolution))).
// Refinement halves the cell size from coarse_resolution() up: level l (0 = finest, up to
// refinement_levels()) has ceil(resolution / 2^l) cells per axis, each 2^l fine cells wide, and
// its vertices are the fine vertices whose indices are multiples of 2^l. When 2^l does not divide
// the resolution the last cell reaches past u = 1, where the field is still defined; children
// starting at or past fine index `resolution` are dropped, so level 0 is exactly the fine grid.
// Any resolution works (not only c * 2^k), and no level is denser than the coarsest one needs.
uint32_t coarse_resolution(uint32_t resolution);  // ceil(resolution / 2^refinement_levels())
// The largest l with ceil(resolution / 2^l) >= 32, else 0: coarser grids would prune nothing for
// d* = 0.1, since the keep test below only rejects cells whose half-diagonal is well under d*.
uint32_t refinement_levels(uint32_t resolution);

// A cell of edge length h (unit frame) is kept for refinement when its corner values change sign
// or when min |f| over its corners <= kLipschitzMargin * h * sqrt(3) / 2: a surface point inside the
// cell is within h*sqrt(3)/2 of its nearest corner, and the margin covers a network whose gradient
// norm exceeds 1 (a true distance field has exactly 1).
constexpr float kLipschitzMargin = 2.0f;
bool cell_may_contain_surface(const float corner_values[8], float h);

struct ExtractStats {
    uint64_t points_evaluated = 0;  // field evaluations over all levels
    uint64_t active_cells = 0;      // cells with a sign change at the final level
    double seconds_field = 0;       // coarse-to-fine evaluation
    double seconds_mesh = 0;        // marching cubes, welding, normals
};

// Normals are the normalised gradient of the grid values, with no field evaluation of their own:
// a crossed edge from vertex v along axis a (crossed at t) is shared by four cells that all have a
// sign change, so the grid values around it were evaluated. Along a it is f(v + e_a) - f(v); across
// (axis b) it is the derivative at v and at v + e_a lerped by t, each (f(w + e_b) - f(w - e_b)) / 2,
// or one-sided where only one neighbour was evaluated (domain boundary, a cell outside the band),
// or 0 where neither was. All in units of 1 / cell. Where the gradient vanishes: the direction of
// the edge from its inside to its outside end.

// CPU reference: coarse-to-fine evaluation + marching cubes (mc_tables.h) on the final-level cells
// with a sign change, one welded vertex per crossed grid edge, normals as above, positions mapped
// to the original frame (u * scale + center). `threads` as for evaluate_cpu.
nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats, unsigned threads = 0);

}  // namespace nfd
