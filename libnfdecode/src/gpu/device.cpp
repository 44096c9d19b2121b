// The device and its one kernel table: each compute kernel's SPIR-V, bindings, push-constant size
// and local size, all from shaders/bindings.h, which the shaders include too. A new kernel is one
// row here, one line in shaders/CMakeLists.txt and nfd_shaders.h, and its .comp file.
#include "device.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <new>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <dirent.h>
#endif

#include "../mc_tables.h"
#include "gpu_decode.h"
#include "nfdecode/nfdecode.h"

namespace nfd::gpu {

// The shaders' caps are the format's: a file the parser accepts fits the kernels.
static_assert(NFD_GPU_MAX_LAYERS == NFD_MAX_LAYERS, "one weight binding per layer");
static_assert(NFD_GPU_MAX_FREQUENCIES == NFD_MAX_FREQUENCIES, "the Frequencies uniform block");
static_assert(NFD_GPU_MAX_WIDTH >= NFD_MAX_WIDTH, "field_eval.comp's activation arrays");
static_assert(NFD_GPU_MAX_FREQUENCIES % 4 == 0, "frequencies are read as vec4s");
// Linear cell indices of the finest level (resolution^3) fit in 32 bits, level coordinates in
// the 11 bits of grid.h's packing, and edge midpoints in quarter-cell units of level 1.
static_assert(uint64_t(NFD_MAX_RESOLUTION) * NFD_MAX_RESOLUTION * NFD_MAX_RESOLUTION <= 1ull << 32,
              "cell indices");
static_assert(NFD_MAX_RESOLUTION <= 1024, "11-bit coordinates");
static_assert(NFD_SCAN_BLOCK % NFD_SCAN_LOCAL_SIZE == 0, "scan.comp's per-invocation elements");
// A recording's mesher parents are addressed as k << 6 | edge in mc_emit's 32-bit records.
static_assert(uint64_t(NFD_MAX_RECORDING_CELLS) < 1ull << 26, "mc_emit's parent ranks");

namespace {

constexpr BindingMask B(uint32_t binding) { return BindingMask(1) << binding; }
// A level's kept cells (level_cells_bindings), and with their kept-neighbour bits (level_bindings).
constexpr BindingMask kLevelCells =
    B(NFD_B_KEPT_BITS) | B(NFD_B_KEPT_PREFIX) | B(NFD_B_KEPT_CELLS) | B(NFD_B_COUNTERS);
constexpr BindingMask kLevel = kLevelCells | B(NFD_B_KEPT_AROUND);
constexpr BindingMask kChildGrid = kLevel | B(NFD_B_CORNERS) | B(NFD_B_OWNED) | B(NFD_B_OFFSETS);
// What a mesher's classify kernel writes (levels.h, Classified::classify_bindings).
constexpr BindingMask kClassified = B(NFD_B_CASES) | B(NFD_B_EDGE_MASKS) |
                                    B(NFD_B_TRIANGLE_COUNTS) | B(NFD_B_EMITTING);
constexpr BindingMask kGradients =
    B(NFD_B_GRADIENT_OWNED) | B(NFD_B_GRADIENT_OFFSETS) | B(NFD_B_GRADIENTS);
// The UDF gradient list's masks; NFD_B_OWNED and NFD_B_CORNER_GRADIENTS serve copying from other
// lists (udf_gradient_count.comp).
constexpr BindingMask kGradientCount = kLevel | B(NFD_B_NEAR_MASKS) | B(NFD_B_GRADIENT_OWNED) |
                                    B(NFD_B_OWNED) | B(NFD_B_CORNER_GRADIENTS);
// A meshed UDF level's predicted list (udf_predict.comp).
constexpr BindingMask kPredicted =
    B(NFD_B_PREDICTED_OWNED) | B(NFD_B_PREDICTED_OFFSETS) | B(NFD_B_PREDICTED);
constexpr BindingMask kUdfNear =
    kChildGrid | B(NFD_B_VALUES) | B(NFD_B_MC_TABLES) | B(NFD_B_NEAR_MASKS);
// A UDF finest level's surface following (udf_flood.comp), the level's values in the predicted
// list alone: the claiming and evaluating modes' roles (16, the most a pipeline has: these
// compute their parents' kept-neighbour bits rather than bind a 17th), and the faces mode's,
// which writes the near masks in place of the claims.
constexpr BindingMask kFloodFrontier = kLevelCells | B(NFD_B_CORNERS) | kPredicted |
                                       B(NFD_B_FLOOD_VISITED) | B(NFD_B_FLOOD_FRESH) |
                                       B(NFD_B_FLOOD_NEXT) | B(NFD_B_FLOOD_FRONTIER);
constexpr BindingMask kFlood = kFloodFrontier | B(NFD_B_FLOOD_CLAIMED) | B(NFD_B_FLOOD_POINTS) |
                               B(NFD_B_FLOOD_RESULTS) | B(NFD_B_POINTS);
constexpr BindingMask kFloodFaces = kFloodFrontier | B(NFD_B_NEAR_MASKS) | B(NFD_B_MC_TABLES);
constexpr BindingMask kGradientMerge = B(NFD_B_COUNTERS) | kGradients | B(NFD_B_OWNED) |
                                       B(NFD_B_OFFSETS) | B(NFD_B_CORNER_GRADIENTS) |
                                       B(NFD_B_ABOVE_GRADIENTS) | B(NFD_B_FRESH_GRADIENTS);
constexpr BindingMask kFieldLayers = ((1u << NFD_GPU_MAX_LAYERS) - 1) << NFD_B_FIELD_LAYER0;
constexpr BindingMask kField =
    B(NFD_B_FIELD_POINTS) | B(NFD_B_FIELD_VALUES) | B(NFD_B_FIELD_COUNTERS);
constexpr BindingMask kDenseLookup = B(NFD_B_KEPT_CELLS) | B(NFD_B_OWNED) | B(NFD_B_OFFSETS) |
                                  B(NFD_B_DENSE_VALUES) | B(NFD_B_POINTS) | B(NFD_B_COUNTERS);
constexpr BindingMask kTotal = B(NFD_B_SCAN_IN) | B(NFD_B_SCAN_OUT) | B(NFD_B_SCAN_COUNTERS);
constexpr BindingMask kArgs = B(NFD_B_SCAN_COUNTERS) | B(NFD_B_ARGS);
static_assert(NFD_B_FIELD_COUNTERS >= NFD_B_FIELD_LAYER0 + NFD_GPU_MAX_LAYERS, "after the layers");
constexpr uint32_t kNoSpecialization = UINT32_MAX;

constexpr bool is_field_kernel(Kernel kernel) { return kernel <= Kernel::FieldGradientLanes; }

// Where each kernel family binds the job's counters (counters.glsl): the field kernels after
// their layers, the small list kernels after the scan's bindings, the level kernels (extract.glsl)
// at NFD_B_COUNTERS; the scans run on capacities and have none.
constexpr uint32_t counters_binding(Kernel kernel) {
    if (is_field_kernel(kernel)) return NFD_B_FIELD_COUNTERS;
    switch (kernel) {
        case Kernel::Scan:
        case Kernel::ScanPopcount:
        case Kernel::ScanAdd: return kNoCounters;
        case Kernel::BitmapCompact:
        case Kernel::CountTotal:
        case Kernel::CountTotalPopcount:
        case Kernel::DispatchArgs:
        case Kernel::DrawArgs: return NFD_B_SCAN_COUNTERS;
        default: return NFD_B_COUNTERS;
    }
}

struct KernelDesc {
    Kernel kernel;  // the row's own index, checked below
    const shaders::Spirv& spirv;
    BindingMask storage, uniform;
    uint32_t push_bytes, local_size;
    uint32_t constant0 = kNoSpecialization;  // value of constant_id 0, if the kernel has one
};
// A row of udf_flood.comp's modes: the level kernels' push and local size.
constexpr KernelDesc flood_kernel(Kernel kernel, const shaders::Spirv& spirv,
                                  BindingMask roles = kFlood) {
    return {kernel, spirv, roles, 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE};
}

constexpr KernelDesc kKernels[] = {
    // Field: the network's sizes are specialization constants, its local size too.
    {Kernel::FieldEval, shaders::field_eval, kField, B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers,
     NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldEvalStorage, shaders::field_eval_storage, kField | kFieldLayers,
     B(NFD_B_FIELD_FREQUENCIES), NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldGradient, shaders::field_gradient, kField,
     B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers, NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldGradientStorage, shaders::field_gradient_storage, kField | kFieldLayers,
     B(NFD_B_FIELD_FREQUENCIES), NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldEvalShared, shaders::field_eval_shared, kField,
     B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers, NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldGradientShared, shaders::field_gradient_shared, kField,
     B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers, NFD_FIELD_PUSH_BYTES, NFD_FIELD_LOCAL_SIZE},
    {Kernel::FieldEvalLanes, shaders::field_eval_lanes, kField,
     B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers, NFD_FIELD_PUSH_BYTES, NFD_FIELD_LANES},
    {Kernel::FieldGradientLanes, shaders::field_gradient_lanes, kField,
     B(NFD_B_FIELD_FREQUENCIES) | kFieldLayers, NFD_FIELD_PUSH_BYTES, NFD_FIELD_LANES},
    // Prefix scans and compaction.
    {Kernel::Scan, shaders::scan, B(NFD_B_SCAN_IN) | B(NFD_B_SCAN_OUT) | B(NFD_B_SCAN_SUMS), 0,
     NFD_COUNT_PUSH_BYTES, NFD_SCAN_LOCAL_SIZE, 0},
    {Kernel::ScanPopcount, shaders::scan, B(NFD_B_SCAN_IN) | B(NFD_B_SCAN_OUT) | B(NFD_B_SCAN_SUMS),
     0, NFD_COUNT_PUSH_BYTES, NFD_SCAN_LOCAL_SIZE, 1},
    {Kernel::ScanAdd, shaders::scan_add, B(NFD_B_SCAN_OUT) | B(NFD_B_SCAN_SUMS), 0,
     NFD_COUNT_PUSH_BYTES, NFD_SCAN_LOCAL_SIZE},
    {Kernel::BitmapCompact, shaders::bitmap_compact,
     B(NFD_B_KEPT_BITS) | B(NFD_B_KEPT_PREFIX) | B(NFD_B_KEPT_CELLS) | B(NFD_B_SCAN_COUNTERS), 0,
     NFD_COUNT_PUSH_BYTES, NFD_LOCAL_SIZE},
    // Counts on the device (counters.glsl): totals, indirect dispatch and draw records.
    {Kernel::CountTotal, shaders::count_total, kTotal, 0, NFD_TOTAL_PUSH_BYTES, 1, 0},
    {Kernel::CountTotalPopcount, shaders::count_total, kTotal, 0, NFD_TOTAL_PUSH_BYTES, 1, 1},
    {Kernel::DispatchArgs, shaders::dispatch_args, kArgs, 0, NFD_ARGS_PUSH_BYTES, 1},
    {Kernel::DrawArgs, shaders::draw_args, kArgs, 0, NFD_DRAW_PUSH_BYTES, 1},
    // The coarsest level's point lists from the host's values, or values and gradients.
    {Kernel::DenseValues, shaders::dense_lookup, kDenseLookup, 0, NFD_LEVEL_PUSH_BYTES,
     NFD_LOCAL_SIZE, 1},
    {Kernel::DenseGradients, shaders::dense_lookup, kDenseLookup, 0, NFD_LEVEL_PUSH_BYTES,
     NFD_LOCAL_SIZE, 4},
    // Refinement (extract.glsl). RefinePoints also lists the UDF's gradient points: the caller
    // binds that list's masks and offsets at NFD_B_OWNED and NFD_B_OFFSETS.
    {Kernel::RefineCount, shaders::refine_count, kLevel | B(NFD_B_OWNED), 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::RefinePoints, shaders::refine_points,
     B(NFD_B_KEPT_CELLS) | B(NFD_B_OWNED) | B(NFD_B_OFFSETS) | B(NFD_B_POINTS) |
         B(NFD_B_COUNTERS),
     0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::RefineCells, shaders::refine_cells,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_CHILD_BITS), 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::RefineCellsNear, shaders::refine_cells_near,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_CHILD_BITS) | B(NFD_B_MC_TABLES) |
         B(NFD_B_NEAR_MASKS),
     0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::GatherCorners, shaders::gather_corners,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_CHILD_CELLS) | B(NFD_B_CHILD_CORNERS), 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::GatherCornersGradients, shaders::gather_corners_gradients,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_CHILD_CELLS) | B(NFD_B_CHILD_CORNERS) |
         B(NFD_B_GRADIENT_OWNED) | B(NFD_B_GRADIENT_OFFSETS) | B(NFD_B_CORNER_GRADIENTS),
     0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::LevelAround, shaders::level_around, kLevel, 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    // Marching cubes over the level-1 parents (mc.glsl); McEmit serves SDF and UDF.
    {Kernel::McClassify, shaders::mc_classify,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_CHILD_BITS) | B(NFD_B_MC_TABLES) | kClassified, 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::McVertexEdges, shaders::mc_vertex_edges,
     B(NFD_B_COUNTERS) | B(NFD_B_EDGE_MASKS) | B(NFD_B_VERTEX_OFFSETS) | B(NFD_B_VERTEX_EDGES), 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::McEmit, shaders::mc_emit,
     kLevel | B(NFD_B_MC_TABLES) | B(NFD_B_CASES) | B(NFD_B_EDGE_MASKS) |
         B(NFD_B_VERTEX_OFFSETS) | B(NFD_B_TRIANGLE_OFFSETS) | B(NFD_B_NEAR_CELLS) |
         B(NFD_B_INDICES),
     0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::McVertices, shaders::mc_vertices,
     kChildGrid | B(NFD_B_VALUES) | B(NFD_B_VERTEX_EDGES) | B(NFD_B_POSITIONS) | B(NFD_B_NORMALS),
     0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    // UDF (udf.glsl).
    {Kernel::UdfPredict, shaders::udf_predict,
     B(NFD_B_COUNTERS) | B(NFD_B_CORNERS) | B(NFD_B_OWNED) | B(NFD_B_PREDICTED_OWNED), 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfPredictJoin, shaders::udf_predict_join,
     B(NFD_B_COUNTERS) | B(NFD_B_OWNED) | B(NFD_B_OFFSETS) | B(NFD_B_VALUES) | kPredicted |
         B(NFD_B_JOINED_VALUES),
     0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfNear, shaders::udf_near, kUdfNear, 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfNearPredicted, shaders::udf_near_predicted,
     kUdfNear | kPredicted, 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    // Surface following on a UDF's finest level: udf_flood.comp's modes.
    flood_kernel(Kernel::UdfFloodSeedMidpoints, shaders::udf_flood_seed_midpoints),
    flood_kernel(Kernel::UdfFloodSeedChildren, shaders::udf_flood_seed_children),
    flood_kernel(Kernel::UdfFloodSeedIsolated, shaders::udf_flood_seed_isolated),
    flood_kernel(Kernel::UdfFloodClaimCorners, shaders::udf_flood_claim_corners),
    flood_kernel(Kernel::UdfFloodFaces, shaders::udf_flood_faces, kFloodFaces),
    flood_kernel(Kernel::UdfFloodListPoints, shaders::udf_flood_list_points),
    flood_kernel(Kernel::UdfFloodStoreValues, shaders::udf_flood_store_values),
    // Copying from the level above's list (progressive levels: the corners it has for this one)
    // and, Predicted, from the meshed level's predicted list (udf.glsl).
    {Kernel::UdfGradientCount, shaders::udf_gradient_count, kGradientCount, 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfGradientCountPredicted, shaders::udf_gradient_count_predicted,
     kGradientCount | B(NFD_B_PREDICTED_OWNED), 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfGradientMerge, shaders::udf_gradient_merge, kGradientMerge, 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfGradientMergePredicted, shaders::udf_gradient_merge_predicted,
     kGradientMerge | kPredicted, 0, NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfClassify, shaders::udf_classify,
     kLevel | kGradients | B(NFD_B_MC_TABLES) | B(NFD_B_NEAR_CELLS) | kClassified, 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
    {Kernel::UdfVertices, shaders::udf_vertices,
     kLevel | kGradients | B(NFD_B_VERTEX_EDGES) | B(NFD_B_POSITIONS) | B(NFD_B_NORMALS), 0,
     NFD_LEVEL_PUSH_BYTES, NFD_LOCAL_SIZE},
};

constexpr bool rows_in_enum_order() {
    for (size_t i = 0; i < kKernelCount; ++i)
        if (kKernels[i].kernel != Kernel(i)) return false;
    return true;
}
static_assert(sizeof(kKernels) / sizeof(kKernels[0]) == kKernelCount, "one row per kernel");
static_assert(rows_in_enum_order(), "kKernels[k] describes Kernel k");
constexpr bool rows_bind_their_counters() {
    for (const KernelDesc& k : kKernels) {
        const uint32_t b = counters_binding(k.kernel);
        if (b != kNoCounters && !(k.storage >> b & 1)) return false;
    }
    return true;
}
static_assert(rows_bind_their_counters(), "a kernel with counters has them in its storage mask");


// The marching-cubes tables, exactly as the CPU reference uses them (mc.glsl's layout).
nfd_result upload_mc_tables(Device& d) {
    const mc::Tables& t = mc::tables();
    std::vector<int32_t> table(256 * 16 + 256 + 24 + 4096 / 32 + 256 * 2);
    for (int c = 0; c < 256; ++c) {
        for (int i = 0; i < 16; ++i) table[16 * c + i] = t.triangles[c][i];
        table[4096 + c] = t.triangle_count[c];
    }
    for (int e = 0; e < 12; ++e)
        for (int j = 0; j < 2; ++j) table[4096 + 256 + 2 * e + j] = mc::kEdgeCorners[e][j];
    for (int w = 0; w < 4096 / 32; ++w) table[4096 + 256 + 24 + w] = int32_t(t.holds_triangle[w]);
    for (int c = 0; c < 256; ++c) {  // triangle i's 12-bit edge mask at bit 12 i of a pair
        uint64_t masks = 0;
        for (int i = 0; i < t.triangle_count[c]; ++i)
            for (int j = 0; j < 3; ++j) masks |= uint64_t(1) << (12 * i + t.triangles[c][3 * i + j]);
        table[4096 + 256 + 24 + 128 + 2 * c] = int32_t(uint32_t(masks));
        table[4096 + 256 + 24 + 128 + 2 * c + 1] = int32_t(uint32_t(masks >> 32));
    }
    NFD_TRY(d.vk->create_buffer(table.size() * 4, &d.mc_tables));
    return d.vk->upload(d.mc_tables, 0, table.data(), table.size() * 4);
}

// lavapipe builds a pipeline's machine code at its first dispatch of a workgroup, not when it is
// created: the first decode of a context paid for every kernel it met (~5 ms of a first level
// on 2 cores, bench/RESULTS.md). One dispatch of one workgroup per kernel here, every binding on
// a zeroed buffer and zero push constants (no items: each returns at once), moves that to the
// context's creation, before any asset arrives. Other drivers compile at creation; it costs them
// a submit.
nfd_result warm_kernels(Device& d) {
    Context& vk = *d.vk;
    Buffers buffers(vk);
    Buffer* zeros;
    NFD_TRY(buffers.make(1 << 16, &zeros));
    Batch batch;
    NFD_TRY(vk.create(&batch));
    nfd_result r = vk.begin(batch);
    if (r == NFD_SUCCESS) {
        vk.fill(batch, *zeros, 0);
        const uint8_t push[NFD_LEVEL_PUSH_BYTES] = {};
        for (size_t i = 0; i < kKernelCount && r == NFD_SUCCESS; ++i) {
            if (is_field_kernel(Kernel(i))) continue;
            std::vector<Bind> binds;
            const BindingMask mask = kKernels[i].storage | kKernels[i].uniform;
            for (uint32_t b = 0; b < kBindingNumbers; ++b)
                if (mask >> b & 1) binds.push_back({b, *zeros});
            r = vk.dispatch(batch, d.kernels[i], binds, push, 1);
        }
        if (r == NFD_SUCCESS) r = vk.submit(batch);
    }
    vk.destroy(batch);
    return r;
}

// Every kernel but the field's, on up to kKernelThreads threads (the caller's among them): a
// CPU implementation compiles each pipeline's machine code at its creation, ~200 ms for all of
// them on lavapipe one after another, and pipelines do not depend on each other. Other drivers
// compile at creation too.
constexpr unsigned kKernelThreads = 4;
nfd_result create_kernels(Device& d) {
    std::atomic<size_t> next{0};
    std::atomic<int> failed{NFD_SUCCESS};
    auto create = [&d, &next, &failed] {
        for (size_t i; failed.load() == NFD_SUCCESS && (i = next++) < kKernelCount;) {
            if (is_field_kernel(Kernel(i))) continue;
            try {
                const nfd_result r =
                    d.vk->create_pipeline(kernel_pipeline(Kernel(i)), &d.kernels[i]);
                if (r != NFD_SUCCESS) failed = r;
            } catch (const std::bad_alloc&) {
                failed = NFD_ERROR_OUT_OF_MEMORY;
            }
        }
    };
    std::vector<std::thread> helpers;
    const unsigned threads =
        std::min(kKernelThreads, std::max(1u, std::thread::hardware_concurrency()));
    try {
        while (helpers.size() + 1 < threads) helpers.emplace_back(create);
    } catch (...) {  // fewer threads: the caller's does the rest
    }
    create();
    for (std::thread& t : helpers) t.join();
    return nfd_result(failed.load());
}

}  // namespace

PipelineDesc kernel_pipeline(Kernel kernel, std::vector<uint32_t> specialization) {
    const KernelDesc& k = kKernels[size_t(kernel)];
    PipelineDesc desc;
    desc.spirv = &k.spirv;
    desc.storage_bindings = k.storage;
    desc.uniform_bindings = k.uniform;
    desc.push_constant_bytes = k.push_bytes;
    desc.local_size = k.local_size;
    desc.counters_binding = counters_binding(kernel);
    if (is_field_kernel(kernel)) desc.local_size_id = NFD_FIELD_LOCAL_SIZE_ID;
    desc.specialization = std::move(specialization);
    if (k.constant0 != kNoSpecialization) desc.specialization = {k.constant0};
    return desc;
}

Device::~Device() {
    join_warmers(false);
    if (!vk) return;
    for (FieldPipeline& f : field_pipelines) vk->destroy(f.pipeline);
    for (Pipeline& p : kernels) vk->destroy(p);
    vk->destroy(mc_tables);
}

void Device::join_warmers(bool finished_only) {
    for (auto it = warmers.begin(); it != warmers.end();) {
        if (finished_only && !it->done) {
            ++it;
            continue;
        }
        if (it->thread.joinable()) it->thread.join();
        it = warmers.erase(it);
    }
}

Buffers& Buffers::operator=(Buffers&& other) noexcept {
    release();
    vk_ = other.vk_;
    list_ = std::move(other.list_);
    return *this;
}

nfd_result Buffers::make(VkDeviceSize bytes, Buffer** out, Memory memory) {
    std::unique_ptr<Buffer> b(new (std::nothrow) Buffer());
    if (!b) return NFD_ERROR_OUT_OF_MEMORY;
    NFD_TRY(vk_->create_buffer(bytes, b.get(), memory));
    list_.push_back(std::move(b));
    *out = list_.back().get();
    return NFD_SUCCESS;
}

void Buffers::release() {
    for (auto& b : list_) vk_->destroy(*b);
    list_.clear();
}

nfd_result record_scan(Job& job, Buffers& scratch, const Buffer& in, const Buffer& out,
                       uint32_t count, bool popcount) {
    Device& d = job.device;
    if (count == 0) return NFD_SUCCESS;
    const uint32_t blocks = div_up(count, NFD_SCAN_BLOCK);
    const uint64_t invocations = uint64_t(blocks) * NFD_SCAN_LOCAL_SIZE;
    Buffer *sums, *scanned;
    NFD_TRY(scratch.make(VkDeviceSize(blocks) * 4, &sums));
    NFD_TRY(d.vk->dispatch(job.batch(), d[popcount ? Kernel::ScanPopcount : Kernel::Scan],
                           {{NFD_B_SCAN_IN, in}, {NFD_B_SCAN_OUT, out}, {NFD_B_SCAN_SUMS, *sums}},
                           &count, invocations));
    if (blocks == 1) return NFD_SUCCESS;
    NFD_TRY(scratch.make(VkDeviceSize(blocks) * 4, &scanned));
    NFD_TRY(record_scan(job, scratch, *sums, *scanned, blocks, false));
    return d.vk->dispatch(job.batch(), d[Kernel::ScanAdd], {{NFD_B_SCAN_OUT, out}, {NFD_B_SCAN_SUMS, *scanned}},
                          &count, invocations);
}

bool gpu_device_node_present() {
#if defined(__linux__) && !defined(__ANDROID__)
    auto any_entry = [](const char* dir, std::initializer_list<const char*> prefixes) {
        DIR* d = opendir(dir);
        if (!d) return false;
        bool found = false;
        for (dirent* e; !found && (e = readdir(d));)
            for (const char* p : prefixes) found = found || std::strncmp(e->d_name, p, std::strlen(p)) == 0;
        closedir(d);
        return found;
    };
    return any_entry("/dev/dri", {"renderD", "card"}) || any_entry("/dev", {"nvidia", "dxg", "kgsl", "mali"});
#else
    return true;
#endif
}

nfd_result create_device(const nfd_vulkan_device* adopt, bool enable_validation,
                         std::unique_ptr<Device>* out, bool hardware_only, std::string* declined,
                         const void* pipeline_cache, size_t pipeline_cache_size) {
    hardware_only = hardware_only && !adopt;
    if (hardware_only && !gpu_device_node_present()) {
        if (declined) *declined = "no GPU device node (/dev/dri, /dev/nvidia*), so no GPU";
        return NFD_ERROR_DEVICE_UNAVAILABLE;
    }
    std::unique_ptr<Device> d(new (std::nothrow) Device());
    if (!d) return NFD_ERROR_OUT_OF_MEMORY;
    NFD_TRY(Context::create(adopt, enable_validation, pipeline_cache, pipeline_cache_size, &d->vk));
    d->shared_weight_kernels = !d->vk->cpu_implementation() || std::getenv("NFD_FORCE_SHARED_WEIGHTS");
    d->lane_kernels = d->vk->cpu_implementation() &&
                      d->vk->compute_shuffle_subgroup_size() == NFD_FIELD_LANES;
    if (hardware_only && d->vk->cpu_implementation()) {
        if (declined)
            *declined = "the only Vulkan device, " + d->vk->name() +
                        ", is a CPU implementation (slower than this path)";
        return NFD_ERROR_DEVICE_UNAVAILABLE;
    }
    NFD_TRY(create_kernels(*d));
    NFD_TRY(upload_mc_tables(*d));
    NFD_TRY(warm_kernels(*d));
    *out = std::move(d);
    return NFD_SUCCESS;
}

void destroy_device(Device* device) { delete device; }

const char* device_name(const Device& device) { return device.vk->name().c_str(); }

void set_host_threads(Device& device, unsigned threads) { device.host_threads = threads; }

nfd_result pipeline_cache(const Device& device, std::vector<uint8_t>* out) {
    return device.vk->pipeline_cache(out);
}

DeviceMemory device_memory(const Device& device) {
    return {device.vk->live_bytes(), device.vk->peak_bytes(), device.vk->buffers_created(),
            device.vk->memory_allocations(), device.vk->live_allocations()};
}
void reset_device_memory_peak(Device& device) { device.vk->reset_peak(); }
uint64_t networks_uploaded(const Device& device) { return device.networks_uploaded; }
bool unified_memory(const Device& device) { return device.vk->unified(); }

}  // namespace nfd::gpu
