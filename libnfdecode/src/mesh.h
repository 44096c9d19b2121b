// The decoder's in-memory triangle mesh, in the original coordinates of the encoded shape.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "host_memory.h"

namespace nfd {

struct MeshData {
    nfd::vector<float> positions;   // xyz per vertex, original frame relative to `offset`
    nfd::vector<float> normals;     // xyz per vertex, unit length, pointing outside (towards +SDF)
    nfd::vector<uint32_t> indices;  // 3 per triangle, counter-clockwise seen from outside
    nfd::vector<float> colours;     // rgb in [0, 1] per vertex (colour.h), or empty: no colour
    std::array<double, 3> offset{};  // Geometry::offset: original = offset + position
    size_t vertex_count() const { return positions.size() / 3; }
    size_t triangle_count() const { return indices.size() / 3; }
};

}  // namespace nfd
