// Uniform point sampling on a triangle mesh.
#pragma once
#include <cstddef>
#include <cstdint>

#include "mesh.h"

namespace nfd {

// Writes `count` points (3 floats each) distributed uniformly by area over `mesh`, and their face
// normals when `normals` is not null. Deterministic for a seed on every platform: the generator
// (splitmix64) and the mapping to triangles are our own, not <random>'s implementation-defined
// distributions. Requires at least one triangle when count > 0.
void sample_points(const MeshData& mesh, size_t count, uint64_t seed, float* points,
                   float* normals);

}  // namespace nfd
