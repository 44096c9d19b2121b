// Marching-cubes case tables, shared by the CPU extractor and (uploaded as-is) the GPU shaders.
//
// Numbering (the same everywhere in libnfdecode):
//   corner c (0..7) sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) from the cell origin;
//   edge e (0..11) runs along axis a = e / 4 from corner kEdgeCorners[e][0] (the one with the
//     smaller coordinate along a) to kEdgeCorners[e][1]; e % 4 picks the edge among the four
//     parallel ones: bit 0 = offset along the lower remaining axis, bit 1 = along the higher one;
//   case index: bit c is set when f(corner c) < 0 (inside; f >= 0 counts as outside).
//
// A crossing on edge e of the cell with origin vertex v therefore lies on the grid edge that starts
// at v + kCornerOffset[kEdgeCorners[e][0]] and runs along axis e / 4: the key used to weld vertices.
//
// The triangle table is not typed in: it is generated (mc_tables.cpp) by tracing the iso-contour
// over the six cube faces and triangulating each closed loop. Faces with two diagonal inside
// corners always separate the inside corners; the rule depends only on the face's own corner
// signs, so the two cells sharing a face cut it the same way and the mesh has no cracks. Triangles
// are counter-clockwise seen from outside (f > 0).
#pragma once
#include <cstdint>

namespace nfd::mc {

inline constexpr uint8_t kCornerOffset[8][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0},
                                                {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};

inline constexpr uint8_t kEdgeCorners[12][2] = {
    {0, 1}, {2, 3}, {4, 5}, {6, 7},  // along x: (y, z) = (0,0) (1,0) (0,1) (1,1)
    {0, 2}, {1, 3}, {4, 6}, {5, 7},  // along y: (x, z) = (0,0) (1,0) (0,1) (1,1)
    {0, 4}, {1, 5}, {2, 6}, {3, 7},  // along z: (x, y) = (0,0) (1,0) (0,1) (1,1)
};

inline constexpr int kMaxTrianglesPerCase = 5;

struct Tables {
    // Edge ids, three per triangle, terminated by -1 (and padded with -1 to 16).
    int8_t triangles[256][16];
    uint8_t triangle_count[256];
    // Bit m (word m / 32, bit m % 32) of the 12-bit edge masks: set when the edges in m include
    // all three edges of some triangle of the table, i.e. when a cell whose usable edges are m
    // can emit a triangle in some case (the UDF mesher's near cells, grid.h).
    uint32_t holds_triangle[4096 / 32];
};

// Built on first use (thread-safe), then immutable.
const Tables& tables();

}  // namespace nfd::mc
