// File writers. Each returns NFD_ERROR_IO when the file cannot be opened or fully written.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>

#include "mesh.h"
#include "nfdecode/nfdecode.h"

namespace nfd {

// Binary glTF 2.0: one scene, node and mesh; POSITION (with min/max), NORMAL, COLOR_0 (float
// VEC3) when the mesh has colours, UNSIGNED_INT indices; a non-zero offset is the node's
// translation. An empty mesh gives a valid asset with an empty scene (glTF forbids empty
// accessors).
nfd_result write_glb(const MeshData& mesh, const char* path);

// Binary little-endian PLY: vertex x y z nx ny nz (float), red green blue (uchar) when the mesh
// has colours, face vertex_indices (uchar count, uint). With a non-zero offset x y z are double,
// offset + position (exact: the f32 position and the offset added in f64).
nfd_result write_mesh_ply(const MeshData& mesh, const char* path);

// Binary little-endian PLY point set: x y z (as for write_mesh_ply, with `offset`), plus nx ny nz
// when normals is not null, plus red green blue (uchar) when colours (rgb in [0, 1]) is not null.
nfd_result write_points_ply(const float* points, const float* normals, const float* colours,
                            size_t count, const std::array<double, 3>& offset, const char* path);

// An rgb component in [0, 1] as 8 bits, as FORMAT.md ("colr") rounds it.
uint8_t colour_byte(float c);

}  // namespace nfd
