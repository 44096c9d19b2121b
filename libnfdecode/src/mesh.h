// The decoder's in-memory triangle mesh, in the original coordinates of the encoded shape.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "host_memory.h"

namespace nfd {

// The three geometry arrays are sized by the meshers and the GPU read-back before every element is
// written (a pass on threads, a download), so `resize` leaves their bytes as they are: zeroing them
// first, on one thread, was 7-9% of the CPU mesh stage of an SDF at 512 (bench/RESULTS.md, 0.13.6).
// Where the CPU meshers put a vertex of unit-frame position u: u * scale + center (the geometry's
// original frame less MeshData::offset; Geometry::scale and emit_center).
struct OutputFrame {
    float scale = 1.0f;
    float center[3] = {0.0f, 0.0f, 0.0f};
};

struct MeshData {
    nfd::uninitialized_vector<float> positions;   // xyz per vertex, original frame - `offset`
    nfd::uninitialized_vector<float> normals;     // xyz per vertex, unit, outwards (towards +SDF)
    nfd::uninitialized_vector<uint32_t> indices;  // 3 per triangle, counter-clockwise from outside
    nfd::vector<float> colours;  // rgb in [0, 1] per vertex (colour.h), or empty: no colour
    std::array<double, 3> offset{};  // Geometry::offset: original = offset + position
    size_t vertex_count() const { return positions.size() / 3; }
    size_t triangle_count() const { return indices.size() / 3; }
};

}  // namespace nfd
