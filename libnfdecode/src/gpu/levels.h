// Internal to gpu/: the sparse levels on the device (levels.cpp, the GPU side of grid.cpp) and
// the meshers that consume the finest of them (mesh_sdf.cpp, mesh_udf.cpp; the GPU sides of
// mesh_sdf_cpu.cpp and mesh_udf_cpu.cpp). Layouts: shaders/extract.glsl's long comment.
#pragma once
#include <cstdint>

#include "../extract.h"
#include "device.h"

namespace nfd::gpu {

// extract.glsl's LevelPush.
struct LevelPush {
    float center[4] = {0, 0, 0, 0};
    uint32_t parent_cells = 0, child_cells = 0, count = 0, child_level = 0;
    float step = 0, threshold = 0, scale = 1, edge_limit = 0;
    uint32_t first_parent = 0;
};
static_assert(sizeof(LevelPush) == NFD_LEVEL_PUSH_BYTES, "extract.glsl's LevelPush");

// The kept cells of one level: a bitmap over its cells with the prefix of its words' popcounts,
// the sorted list, and 8 corner values per kept cell.
struct Level {
    explicit Level(Context& vk) : buffers(vk) {}
    uint32_t cells = 0;  // per axis
    uint32_t kept = 0;
    Buffers buffers;
    Buffer *bits = nullptr, *prefix = nullptr, *list = nullptr, *corners = nullptr;
    uint32_t words() const { return div_up(uint64_t(cells) * cells * cells, 32); }
};

// A list of child-grid points owned by a level's kept parents (extract.glsl): per parent the
// mask of its local points in the list and the offset of its first one, and the points' values.
struct PointList {
    Buffer *owned = nullptr, *offsets = nullptr, *values = nullptr;
    uint32_t count = 0;
};

// The finest level as the meshers see it: the kept cells of level 1 (`parents`), the new values
// of their child grids (whose cells are the finest level's), and the push constants that
// describe them (child level 0).
struct FinestLevel {
    explicit FinestLevel(Context& vk) : parents(vk), buffers(vk) {}
    Level parents;
    PointList grid;
    LevelPush push;
    Buffers buffers;  // grid's
    uint64_t points_evaluated = 0;
};

// Records the evaluation of a point list of `parents` (its masks and offsets, offsets readable
// on the host) into `results` (as record_field): refine_points and the field kernel, by chunks
// of parents with a bounded points buffer from `scratch`.
nfd_result record_list(Device& device, DeviceNetwork& net, const Level& parents,
                       const PointList& list, const Buffer& results, bool gradient,
                       const LevelPush& push, Buffers& scratch);

// Coarse-to-fine evaluation down to the finest level, with the keep rule of grid.h.
nfd_result build_levels(Device& device, DeviceNetwork& net, const Geometry& geometry,
                        uint32_t resolution, FinestLevel* out);

// The bindings of extract.glsl's level (kept bits, prefix, cells), and with them its child grids
// (the level's corners, the new points' masks, offsets and values).
std::vector<Bind> level_bindings(const Level& level);
std::vector<Bind> child_grid_bindings(const Level& parent, const PointList& g);

// Marching cubes of an SDF (mesh_sdf.cpp) and the UDF mesher (mesh_udf.cpp): original-frame mesh.
// Both release the finest level's storage before the mesh is read back (peak memory).
nfd_result mesh_sdf(Device& device, FinestLevel& finest, MeshData* mesh, ExtractStats* stats);
nfd_result mesh_udf(Device& device, DeviceNetwork& net, FinestLevel& finest, MeshData* mesh,
                    ExtractStats* stats);

// What a classify kernel (mc_classify.comp, udf_classify.comp) writes per level-1 parent, and
// the prefix sums of its counts: the input of emit_mesh.
struct Classified {
    explicit Classified(Context& vk) : buffers(vk) {}
    Buffers buffers;
    Buffer *cases = nullptr;           // uvec4: cube cases, emitted-triangle masks
    Buffer *edge_masks = nullptr;      // uvec2: owned edges that carry a vertex
    Buffer *vertex_offsets = nullptr;  // per edge-mask word
    Buffer *triangle_counts = nullptr, *triangle_offsets = nullptr, *active = nullptr;
    // Makes the buffers for `parents` kept parents, 0 in `active`.
    nfd_result make(uint32_t parents);
    // Records the two scans once the classify kernel is recorded.
    nfd_result record_scans(Device& device, Buffers& scratch, uint32_t parents);
};

// The shared back half of both meshers (marching.cpp, as marching.h on the CPU): mc_emit.comp
// writes each parent's vertex edges and welded triangles, then `vertices` (McVertices or
// UdfVertices, bound with `inputs` and the vertex buffers) places each vertex; `classified`'s,
// `finest`'s and `input_buffers` are released as soon as they are not needed, then the mesh is
// read back.
nfd_result emit_mesh(Device& device, FinestLevel& finest, Classified& classified, Kernel vertices,
                     std::vector<Bind> inputs, Buffers& input_buffers, MeshData* mesh,
                     ExtractStats* stats);

}  // namespace nfd::gpu
