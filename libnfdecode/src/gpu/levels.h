// Internal to gpu/: the sparse levels on the device (levels.cpp, the GPU side of grid.cpp) and
// the meshers that consume the finest of them (mesh_sdf.cpp, mesh_udf.cpp; the GPU sides of
// mesh_sdf_cpu.cpp and mesh_udf_cpu.cpp). Layouts: shaders/extract.glsl's long comment.
#pragma once
#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "../extract.h"
#include "device.h"
#include "gpu_decode.h"

namespace nfd::gpu {

// extract.glsl's LevelPush.
struct LevelPush {
    float center[4] = {0, 0, 0, 0};
    uint32_t parent_cells = 0, child_cells = 0, count = 0, child_level = 0;
    float step = 0, threshold = 0, scale = 1, edge_limit = 0;
    uint32_t first = 0, count_slot = NFD_NO_COUNTER;
    uint32_t tally_slot = NFD_NO_COUNTER;
    uint32_t list_first = 0;
    void set(Count c) {
        count = c.capacity;
        count_slot = c.slot;
        first = c.first;
    }
};
static_assert(sizeof(LevelPush) == NFD_LEVEL_PUSH_BYTES, "extract.glsl's LevelPush");

// The sizes of a decode recorded into a host's command buffer (nfd_recording), where no count
// is read back before the host's wait: its Capacities (gpu_decode.h; `cells` those of level 1,
// the meshers' parents) spread over the levels. A total beyond its capacity sets the overflow
// flag (counters.glsl).
struct Plan : Capacities {
    // Level l's capacity: `cells` scaled by the surface's 4^(1-l) with a factor 2 of margin,
    // never more than the level's cells.
    uint32_t level_cells(uint32_t level, uint32_t cells_per_axis) const;
};

// The kept cells of one level: a bitmap over its cells with the prefix of its words' popcounts,
// the sorted list, 8 corner values and the kept-neighbour bits (extract.glsl's kept_arounds) per
// kept cell. The list holds `capacity` cells, and counter `slot` their number on the device
// (NFD_NO_COUNTER: exactly `capacity`); `kept` is that number on the host, once known (own jobs:
// after the level's batch).
struct Level {
    explicit Level(Context& vk) : buffers(vk) {}
    uint32_t cells = 0;  // per axis
    uint32_t capacity = 0, slot = NFD_NO_COUNTER, kept = 0;
    Buffers buffers;
    Buffer *bits = nullptr, *prefix = nullptr, *list = nullptr, *corners = nullptr;
    Buffer* around = nullptr;
    uint32_t words() const { return div_up(uint64_t(cells) * cells * cells, 32); }
    Count count() const { return {capacity, slot}; }
};

// A list of child-grid points owned by a level's kept parents (extract.glsl): per parent the
// mask of its local points in the list and the offset of its first one, and the points' values;
// `capacity` points at most, as many as counter `slot` says (`count` on the host once known).
struct PointList {
    Buffer *owned = nullptr, *offsets = nullptr, *values = nullptr;
    uint32_t capacity = 0, slot = NFD_NO_COUNTER, count = 0;
};

// The coarsest level evaluated on the host (LevelBuilder::step): its values at all of its
// side^3 vertices in raster order (grid.h's evaluate_coarsest_level: evaluated, or filled where
// the probe keeps no cell), in a host-visible buffer, which its point lists copy
// (Kernel::DenseValues) instead of running the network's pipelines. So a decode's first level
// needs none of them (a stream's first level does not wait for their compile), and the C++
// evaluator gives the UDF mesher the gradients there too (top_gradients).
struct HostTop {
    const Network* network = nullptr;
    Buffer* values = nullptr;
    uint32_t side = 0, level = 0;  // vertices per axis; vertex v is fine vertex v << level
    float step = 0;                // fine cell edge
    unsigned threads = 0;          // the evaluator's (Device::host_threads)
    // Vertex (x, y, z)'s place in `values` (raster order, x fastest) and unit-frame position, as
    // grid.h's GridLevel::coord.
    size_t index(uint32_t x, uint32_t y, uint32_t z) const {
        return (size_t(z) * side + y) * side + x;
    }
    size_t vertices() const { return size_t(side) * side * side; }
    float coord(uint32_t v) const { return -1.0f + float(v << level) * step; }
};

struct DeviceMesh;  // below

// What a classify kernel (mc_classify, udf_classify.comp) writes per level-1 parent, and the
// prefix sums of its counts: the input of emit_mesh. Sized for the parents' capacity and zero
// past their count, so that the scans and totals run on capacities.
struct Classified {
    explicit Classified(Context& vk) : buffers(vk) {}
    Buffers buffers;
    Buffer *cases = nullptr;           // uvec4: cube cases, emitted-triangle masks
    Buffer *edge_masks = nullptr;      // uvec2: owned edges that carry a vertex
    Buffer *vertex_offsets = nullptr;  // per edge-mask word
    Buffer *triangle_counts = nullptr, *triangle_offsets = nullptr;
    // Per parent its children that emit a triangle, and the prefix of their counts, whose total
    // is counter `emitting_slot` (the mesh's active cells): mc_emit's list of cells.
    Buffer *emitting = nullptr, *emitting_offsets = nullptr;
    uint32_t emitting_slot = NFD_NO_COUNTER;
    uint32_t parents = 0;              // capacity
    // Makes the buffers for `parents` kept parents (the emitting cells' counter the mesh's when
    // it stays on the device) and records their clearing.
    nfd_result make(Job& job, uint32_t parents, DeviceMesh* device);
    // Records the three scans and the mesh's totals (counters `vertex_slot`, `triangle_slot`,
    // with the given capacities, and emitting_slot) once the classify kernel is recorded.
    nfd_result record_scans(Job& job, Buffers& scratch, uint32_t vertex_slot,
                            uint32_t vertex_capacity, uint32_t triangle_slot,
                            uint32_t triangle_capacity);
    // What the classify kernel writes: cases, edge masks, triangle counts, emitting children.
    std::vector<Bind> classify_bindings() const;
    // The most emitting cells: 8 per parent, and no more than the triangles' capacity.
    uint32_t emitting_capacity(uint32_t triangle_capacity) const {
        return uint32_t(std::min<uint64_t>(8ull * parents, triangle_capacity));
    }
    void release() {
        buffers.release();
        cases = edge_masks = vertex_offsets = triangle_counts = triangle_offsets = nullptr;
        emitting = emitting_offsets = nullptr;
        emitting_slot = NFD_NO_COUNTER;
        parents = 0;
    }
};

// A level as the meshers see it, the finest or a coarser one meshed as if it were (progressive.h):
// the kept cells of the level above (`parents`), the new values of their child grids (whose cells
// are this level's), and the push constants that describe them as a finest level (child level 0,
// `step` this level's cell edge: the same f32 coordinates, grid.h's GridLevel::coord; the count
// that of the parents).
struct FinestLevel {
    explicit FinestLevel(Context& vk)
        : parents(vk), buffers(vk), predicted_buffers(vk), near_buffers(vk), classified(vk) {}
    Level parents;
    PointList grid;
    LevelPush push;
    Buffers buffers;  // grid's
    // A meshed UDF level in own jobs (LevelBuilder::evaluate_predicted): the new points that
    // udf_predict.comp expects to be near-cell corners, with their (value, gradient) as vec4s,
    // which `grid` then lacks on the finest level; a level above it (`keep`) has them in `grid`
    // too (udf_predict.comp's join), where the next level's refinement reads them. Empty (no
    // `owned`) otherwise. The UDF mesher copies its gradients (and on the finest level reads its
    // values there), then frees it.
    PointList predicted;
    Buffers predicted_buffers;
    // After surface following (LevelBuilder::evaluate_finest_flood), per parent: its near children
    // (udf_near.comp's masks, found by the flood, which read the corners of every child it
    // visited; the others have none evaluated), for the UDF mesher; on a meshed UDF level above
    // the finest, found with the keep rule (refine_cells.comp's NFD_NEAR_MASKS); else null.
    Buffers near_buffers;
    Buffer* near = nullptr;
    // What the SDF mesher's first step wrote: on a meshed level above the finest, its
    // refinement's (the mc_classify kernel with the keep rule, one read of the child grids), so
    // that the mesher starts after it; no buffers (`parents` 0) otherwise.
    Classified classified;
    uint64_t points_evaluated = 0;  // own jobs; recorded ones: LevelBuilder::point_slots()
    HostTop top;                    // the coarsest level's (its values in `buffers`), else empty
    // The meshers free the level's storage as soon as they have read it (peak memory), unless
    // `keep`: a coarser level whose kept cells the next step refines.
    bool keep = false;
};

// A UDF level's gradient list carried to the next finer level of a progressive extraction, as
// grid.cpp's evaluate_udf_gradients does on the CPU: that level's parents are this level's kept
// cells, and its even child-grid points their corners, whose (value, gradient) this list may
// hold. mesh_udf fills the list; the next step's gather (LevelBuilder::step) finds, for each
// corner of each newly kept cell, its index in the list (`corners`, NFD_NOT_LISTED if absent),
// and the next mesh_udf copies those instead of evaluating them again.
struct CarriedGradients {
    explicit CarriedGradients(Context& vk) : buffers(vk) {}
    Buffers buffers;
    Buffer *owned = nullptr, *offsets = nullptr, *gradients = nullptr;  // the list
    Buffer* corners = nullptr;  // 8 uints per parent of the next level
};

// Coarse-to-fine evaluation one level per step(), the GPU twin of grid.h's GridBuilder:
// extract_mesh (gpu_decode.cpp) steps it to the finest level, a progressive extraction
// (progressive.cpp) meshes the levels between, a recording (recording.cpp) records every step
// into a host's command buffer. The top step evaluates the coarsest level on the host (HostTop)
// and makes it the child grids of the level above, every cell of which is kept, so that every
// level, the coarsest included, is a FinestLevel. Own jobs run each step in the context's
// batches (two: the kept list of the level before, then the level's values and keep rule; a
// UDF's finest level follows the surface in a batch per wave, or reads its predicted count
// between two) and read its counts after them; with a plan (recorded jobs) the sizes are the
// plan's and nothing is read.
class LevelBuilder {
public:
    // `band`: a UDF's finest level by the keep rule too (nfd_mesh_options.sample_band), where it
    // otherwise follows the surface within the kept parents (evaluate_finest_flood).
    // `meshed_levels` (bit l: level l, progressive extractions): the coarser levels the caller
    // meshes, whose new points a UDF's own job splits as the finest level's (evaluate_predicted)
    // so that their likely near-cell corners are evaluated once, with their gradients. Only
    // where the gradient kernel is built when the level starts: a level that would wait for its
    // compile (the first meshed device level of a new network shape, on lavapipe ~60 ms with
    // one core idle) evaluates values only, and its mesher the near corners' gradients, by which
    // time the compile has run beside the level's value work. The meshes are the same either
    // way (the gradient kernel's values are the value kernel's); the counts of values and
    // gradients evaluated differ.
    LevelBuilder(Job& job, DeviceNetwork& net, const Geometry& geometry, uint32_t resolution,
                 const Plan* plan = nullptr, bool band = false, uint32_t meshed_levels = 0);
    // Evaluates the next level (its kept list and corners first from the level before), then,
    // unless it is the finest, the keep rule on its cells. `carried`: the previous level's
    // gradient list, whose corners of the newly kept cells the step finds.
    nfd_result step(CarriedGradients* carried = nullptr);
    bool done() const { return stepped_ && current_ == 0; }
    uint32_t current() const { return current_; }
    FinestLevel& level() { return level_; }  // the current level, `keep` set unless the finest
    // The counters of each level's new points, and of each kept level's cells (level, slot).
    const std::vector<uint32_t>& point_slots() const { return point_slots_; }
    const std::vector<std::pair<uint32_t, uint32_t>>& kept_slots() const { return kept_slots_; }
    // An upper bound of the device bytes the next step() and, with `mesh`, its mesher allocate;
    // `carried`: the UDF mesher copies gradients from the level before (CarriedGradients).
    uint64_t next_step_device_bytes(bool mesh, bool udf, bool carried = false) const;
    uint64_t next_step_host_bytes(bool mesh) const;  // the mesh read back

private:
    LevelPush refine_push(uint32_t child_level, uint32_t parent_cells, Count parents) const;
    nfd_result evaluate_top_on_host();
    nfd_result evaluate_finest_udf(const LevelPush& push, Buffers& scratch);
    nfd_result evaluate_predicted(const LevelPush& push, Buffers& scratch);
    nfd_result join_predicted(const LevelPush& push);
    nfd_result evaluate_finest_flood(const LevelPush& push, Buffers& scratch);
    nfd_result gather_kept(CarriedGradients* carried);

    Job& job_;
    DeviceNetwork& net_;
    const Network& network_;  // the host's copy, for the coarsest level
    const Plan* plan_;
    const uint32_t resolution_, top_;
    const float step_;
    const FieldType field_;  // the keep rule's margin
    const bool follow_finest_;  // a UDF's finest level follows the surface (own jobs)
    const uint32_t meshed_levels_;
    LevelPush base_;  // center, scale, step
    uint32_t current_;
    bool stepped_ = false;
    FinestLevel level_;
    Level kept_;  // the current level's kept cells (bits and prefix; list and corners next step)
    std::vector<uint32_t> point_slots_;
    std::vector<std::pair<uint32_t, uint32_t>> kept_slots_;
};

// Records the evaluation of a point list of `parents` into `results` (as record_field):
// refine_points and the field kernel by chunks of points, a bounded points buffer from
// `scratch`, as many chunks as the list's capacity needs (those past its count launch nothing).
// With `dense` (the coarsest level's values, or with `gradient` its values and gradients, on the
// host: HostTop), the list copies them instead.
nfd_result record_list(Job& job, DeviceNetwork& net, const Level& parents, const PointList& list,
                       const Buffer& results, bool gradient, const LevelPush& push,
                       Buffers& scratch, const Buffer* dense = nullptr);

// The value and gradient (4 floats, as the gradient kernel writes them) at every corner of the
// coarsest level's near cells (grid.h, udf_cell_is_near with cell edge `h`), by the C++
// evaluator, into a side^3 buffer of `buffers` (zero elsewhere): what DenseGradients copies into
// the UDF mesher's gradient list.
nfd_result top_gradients(const HostTop& top, float h, Buffers& buffers, Buffer** out);

// The bindings of extract.glsl's level: its kept cells (bits, prefix, list), with their
// kept-neighbour bits, and with those its child grids (the level's corners, the new points'
// masks, offsets and values).
std::vector<Bind> level_cells_bindings(const Level& level);
std::vector<Bind> level_bindings(const Level& level);
std::vector<Bind> child_grid_bindings(const Level& parent, const PointList& g);

// A mesh left on the device (recorded jobs, nfd_recording): buffers of the plan's capacities,
// which the host's graphics pipeline binds as they are, the indirect draw record, and the
// counters of its sizes.
struct DeviceMesh {
    explicit DeviceMesh(Context& vk) : buffers(vk) {}
    Buffers buffers;
    Buffer *positions = nullptr, *normals = nullptr, *indices = nullptr, *draw = nullptr;
    uint32_t vertex_capacity = 0, triangle_capacity = 0;
    uint32_t vertex_slot = NFD_NO_COUNTER, triangle_slot = NFD_NO_COUNTER;
    uint32_t emitting_slot = NFD_NO_COUNTER;  // the cells with triangles
    uint32_t gradient_slot = NFD_NO_COUNTER;  // UDF
    // Makes the buffers of the capacities set above.
    nfd_result make();
};

// Where a mesher's results go: read back to `host` (own jobs; device buffers of the exact sizes,
// freed as soon as copied) or left in `device` (recorded jobs).
struct MeshTarget {
    MeshData* host = nullptr;
    DeviceMesh* device = nullptr;
};

// Marching cubes of an SDF (mesh_sdf.cpp) and the UDF mesher (mesh_udf.cpp): original-frame mesh.
// Both release the level's storage before the mesh is read back (peak memory) unless it `keep`s.
nfd_result mesh_sdf(Job& job, FinestLevel& finest, MeshTarget target, ExtractStats* stats);
// mesh_udf's gradient list: with `above` (own jobs), the corners it lists are copied; with
// `carry`, the list is kept there for the next level.
struct GradientCarry {
    const CarriedGradients* above = nullptr;
    CarriedGradients* carry = nullptr;
};
nfd_result mesh_udf(Job& job, DeviceNetwork& net, FinestLevel& finest, const Plan* plan,
                    MeshTarget target, ExtractStats* stats, GradientCarry carried = {});

// The mesher of the field type on `level`, positions in the original frame; `stats` gets the
// mesher's time, active cells and (UDF) gradients added (own jobs). NFD_ERROR_LIMIT_EXCEEDED past
// what mc_emit's records address.
nfd_result mesh_level(Job& job, DeviceNetwork& net, FieldType field, FinestLevel& level,
                      const Plan* plan, MeshTarget target, ExtractStats* stats,
                      GradientCarry carried = {});

// The shared back half of both meshers (marching.cpp, as marching.h on the CPU): the emitting
// cells listed, mc_vertex_edges.comp writes each parent's vertex edges and mc_emit.comp each
// emitting cell's welded triangles, then `vertices` (McVertices or UdfVertices, bound with
// `inputs` and the vertex buffers) places each vertex; `classified`'s, `finest`'s and
// `input_buffers` are released as soon as they are not needed, then the mesh is read back (own
// jobs) or its draw record written (device targets).
nfd_result emit_mesh(Job& job, FinestLevel& finest, Classified& classified, Kernel vertices,
                     std::vector<Bind> inputs, Buffers& input_buffers, MeshTarget target,
                     ExtractStats* stats);

}  // namespace nfd::gpu
