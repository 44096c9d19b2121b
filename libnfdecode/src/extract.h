// Sparse coarse-to-fine field sampling and marching cubes: the definitions shared by the CPU
// reference (extract_cpu.cpp) and the GPU path (gpu/), so that both visit the same cells.
#pragma once
#include <cstdint>

#include "mesh.h"
#include "network.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

// Grid of `resolution` cells per axis over the unit frame [-1, 1]^3: vertex i sits at
// -1 + 2 i / resolution. Refinement halves the cell size from coarse_resolution() up.
uint32_t coarse_resolution(uint32_t resolution);

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

// CPU reference: coarse-to-fine evaluation + marching cubes, welded vertices, normals from the
// field gradient (central differences), positions mapped to the original frame.
nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats);

}  // namespace nfd
