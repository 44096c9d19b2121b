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

// A level as the meshers see it, the finest or a coarser one meshed as if it were (progressive.h):
// the kept cells of the level above (`parents`), the new values of their child grids (whose cells
// are this level's), and the push constants that describe them as a finest level (child level 0,
// `step` this level's cell edge: the same f32 coordinates, grid.h's GridLevel::coord).
struct FinestLevel {
    explicit FinestLevel(Context& vk) : parents(vk), buffers(vk) {}
    Level parents;
    PointList grid;
    LevelPush push;
    Buffers buffers;  // grid's
    uint64_t points_evaluated = 0;
    // The meshers free the level's storage as soon as they have read it (peak memory), unless
    // `keep`: a coarser level whose kept cells the next step refines.
    bool keep = false;
};

// Coarse-to-fine evaluation one level per step(), the GPU twin of grid.h's GridBuilder:
// extract_mesh (gpu_decode.cpp) steps it to the finest level, a progressive extraction
// (progressive.cpp) meshes the levels between.
// The top step evaluates the level above the coarsest densely with every cell kept, and the
// coarsest as its child grids, so that every level, the coarsest included, is a FinestLevel.
class LevelBuilder {
public:
    LevelBuilder(Device& device, DeviceNetwork& net, const Geometry& geometry, uint32_t resolution);
    // Evaluates the next level (its kept list and corners first from the level before), then,
    // unless it is the finest, the keep rule on its cells.
    nfd_result step();
    bool done() const { return stepped_ && current_ == 0; }
    uint32_t current() const { return current_; }
    FinestLevel& level() { return level_; }  // the current level, `keep` set unless the finest
    // An upper bound of the device bytes the next step() and, with `mesh`, its mesher allocate.
    uint64_t next_step_device_bytes(bool mesh, bool udf) const;
    uint64_t next_step_host_bytes(bool mesh) const;  // the mesh read back

private:
    LevelPush refine_push(uint32_t child_level, uint32_t parent_cells, uint32_t count) const;
    nfd_result evaluate_dense_top();
    nfd_result gather_kept();

    Device& device_;
    DeviceNetwork& net_;
    const uint32_t resolution_, top_;
    const float step_;
    LevelPush base_;  // center, scale, step
    uint32_t current_;
    bool stepped_ = false;
    FinestLevel level_;
    Level kept_;  // the current level's kept cells (bits and prefix; list and corners next step)
};

// Records the evaluation of a point list of `parents` (its masks and offsets, offsets readable
// on the host) into `results` (as record_field): refine_points and the field kernel, by chunks
// of parents with a bounded points buffer from `scratch`.
nfd_result record_list(Device& device, DeviceNetwork& net, const Level& parents,
                       const PointList& list, const Buffer& results, bool gradient,
                       const LevelPush& push, Buffers& scratch);

// The bindings of extract.glsl's level (kept bits, prefix, cells), and with them its child grids
// (the level's corners, the new points' masks, offsets and values).
std::vector<Bind> level_bindings(const Level& level);
std::vector<Bind> child_grid_bindings(const Level& parent, const PointList& g);

// Marching cubes of an SDF (mesh_sdf.cpp) and the UDF mesher (mesh_udf.cpp): original-frame mesh.
// Both release the level's storage before the mesh is read back (peak memory) unless it `keep`s.
nfd_result mesh_sdf(Device& device, FinestLevel& finest, MeshData* mesh, ExtractStats* stats);
nfd_result mesh_udf(Device& device, DeviceNetwork& net, FinestLevel& finest, MeshData* mesh,
                    ExtractStats* stats);

// The mesher of the field type on `level`, positions in the original frame; `stats` gets the
// mesher's time, active cells and (UDF) gradients added. NFD_ERROR_LIMIT_EXCEEDED past what
// mc_emit's records address.
nfd_result mesh_level(Device& device, DeviceNetwork& net, FieldType field, FinestLevel& level,
                      MeshData* mesh, ExtractStats* stats);

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
