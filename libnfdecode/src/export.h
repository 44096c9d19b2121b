// File writers. Each returns NFD_ERROR_IO when the file cannot be opened or fully written.
#pragma once
#include <cstddef>

#include "mesh.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

// Binary glTF 2.0: one scene, node and mesh; POSITION (with min/max), NORMAL, UNSIGNED_INT
// indices. An empty mesh gives a valid asset with an empty scene (glTF forbids empty accessors).
nfd_result write_glb(const MeshData& mesh, const char* path);

// Binary little-endian PLY: vertex x y z nx ny nz (float), face vertex_indices (uchar count, uint).
nfd_result write_mesh_ply(const MeshData& mesh, const char* path);

// Binary little-endian PLY point set: x y z, plus nx ny nz when normals is not null.
nfd_result write_points_ply(const float* points, const float* normals, size_t count,
                            const char* path);

}  // namespace nfd
