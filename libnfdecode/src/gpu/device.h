// Internal to gpu/: the device (context, the kernel table's pipelines, the marching-cubes tables,
// the cached networks), shared by the jobs of several threads; a job (one decode's batch,
// counters and indirect records; job.cpp); buffers; the network as the field kernels read it; the
// prefix scan: what every stage (field.cpp, levels.cpp, mesh_sdf.cpp, mesh_udf.cpp) builds on.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "../network.h"
#include "bindings.h"
#include "vk_context.h"

namespace nfd::gpu {

#define NFD_TRY(expr)                                 \
    do {                                              \
        const nfd_result nfd_try_ = (expr);           \
        if (nfd_try_ != NFD_SUCCESS) return nfd_try_; \
    } while (0)

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}
inline uint32_t div_up(uint64_t a, uint64_t b) { return uint32_t((a + b - 1) / b); }

// ---- the kernel table (kernels.cpp): every compute kernel, declared once -----------------------
enum class Kernel : uint32_t {
    FieldEval, FieldEvalStorage, FieldGradient, FieldGradientStorage,  // specialized per network
    FieldEvalShared, FieldGradientShared,  // the same for GPUs (field.cpp, prepare_field)
    FieldEvalLanes, FieldGradientLanes,  // CPU implementations (field.cpp, field_kernel)
    Scan, ScanPopcount, ScanAdd, BitmapCompact,
    CountTotal, CountTotalPopcount, DispatchArgs, DrawArgs, DenseValues, DenseGradients,
    RefineCount, RefinePoints, RefineCells, RefineCellsNear, GatherCorners,
    GatherCornersGradients, LevelAround,
    McClassify, McVertexEdges, McEmit, McVertices,
    UdfPredict, UdfPredictJoin, UdfNear, UdfNearPredicted,
    UdfFloodSeedMidpoints, UdfFloodSeedChildren, UdfFloodSeedIsolated, UdfFloodClaimCorners,
    UdfFloodFaces, UdfFloodListPoints, UdfFloodStoreValues,  // udf_flood.comp's modes 0-6
    UdfGradientCount, UdfGradientCountPredicted, UdfGradientMerge, UdfGradientMergePredicted,
    UdfClassify, UdfVertices,
    Count
};
constexpr size_t kKernelCount = size_t(Kernel::Count);

struct DeviceNetwork;  // below

// The pipeline description of a kernel; `specialization` completes a field kernel's (its network
// shape, field_eval.comp's constant ids 0-14, and 16 for the shared-memory variants), and must be
// empty for the others.
PipelineDesc kernel_pipeline(Kernel kernel, std::vector<uint32_t> specialization = {});

class Device {
public:
    std::unique_ptr<Context> vk;
    Pipeline kernels[kKernelCount];  // all but the field kernels, created with the device
    // Field kernels, one per (variant, network shape); a list: DeviceNetwork keeps pointers.
    // An entry exists from the moment a thread starts compiling it (`ready` false), so that
    // others needing it wait on `field_pipeline_ready` instead of compiling it again (field.cpp).
    struct FieldPipeline {
        Kernel kernel;
        std::vector<uint32_t> specialization;
        Pipeline pipeline;
        bool ready = false;
    };
    std::list<FieldPipeline> field_pipelines;
    std::condition_variable field_pipeline_ready;
    // Threads compiling field pipelines ahead of their first use (field.cpp,
    // compile_in_background), joined by the destructor before anything is destroyed.
    struct Warmer {
        std::thread thread;
        std::atomic<bool> done{false};
    };
    std::list<Warmer> warmers;
    Buffer mc_tables;  // mc.glsl's layout of mc_tables.h
    // Uploaded networks (field.cpp, device_network), most recently used first, with the network
    // they hold (compared in full: a cached upload serves exactly that content).
    struct CachedNetwork {
        Network network;
        std::shared_ptr<DeviceNetwork> uploaded;
    };
    std::list<CachedNetwork> networks;
    uint64_t networks_uploaded = 0;
    // The field kernels' shape for GPUs (one point per invocation, weights in shared memory), not
    // for CPU implementations, whose SIMD lanes want several points per invocation. Tests set
    // NFD_FORCE_SHARED_WEIGHTS to run it on lavapipe.
    bool shared_weight_kernels = false;
    // field_eval_lanes.comp for the values and gradients of networks up to 48 wide: on CPU
    // implementations whose compute subgroups are NFD_FIELD_LANES invocations with shuffles
    // (lavapipe), where it runs ~5x faster than field_eval.comp (bench/RESULTS.md, "0.13.13",
    // "0.13.16").
    bool lane_kernels = false;
    unsigned host_threads = 0;  // gpu_decode.h, set_host_threads
    // The largest predicted list of a UDF's finest level (levels.h, FinestLevel::predicted; 16
    // bytes a point, 8M points): above it (at 1024, a surface larger than the dragon's) that level
    // is evaluated as the others are, and its gradients after it, so that the decode's peak grows
    // by a bounded amount (at 1024 on lavapipe: bunny UDF 389 -> 400 MB, dragon 413 -> 447 MB, for
    // 11% less time). Tests set 0 to run that path at small resolutions.
    uint64_t predicted_list_bytes = 128ull << 20;
    // Jobs on several threads share the device: the field pipelines, the networks and their
    // pipeline choices are made under this lock (field.cpp).
    std::mutex mutex;

    const Pipeline& operator[](Kernel k) const { return kernels[size_t(k)]; }
    ~Device();
    // Joins the warmers (all, or those done) and drops them from the list. Without d.mutex when
    // not `finished_only`: a running warmer takes it.
    void join_warmers(bool finished_only);
};

// Buffers that live as long as this object (one refinement level, one stage of work).
class Buffers {
public:
    explicit Buffers(Context& vk) : vk_(&vk) {}
    ~Buffers() { release(); }
    Buffers(Buffers&& other) noexcept : vk_(other.vk_), list_(std::move(other.list_)) {}
    Buffers& operator=(Buffers&& other) noexcept;
    nfd_result make(VkDeviceSize bytes, Buffer** out, Memory memory = Memory::Device);
    void release();

private:
    Context* vk_;
    std::vector<std::unique_ptr<Buffer>> list_;
};


// ---- one decode's counts on the device (job.cpp; counters.glsl) -------------------------------
// The items of a counted dispatch: at most `capacity` (what its buffers hold) from item `first`
// on, as many as counter `slot` says when it runs (NFD_NO_COUNTER: exactly `capacity`).
struct Count {
    uint32_t capacity = 0;
    uint32_t slot = NFD_NO_COUNTER;
    uint32_t first = 0;
};

// The counters and indirect-dispatch records of one decode. Item counts stay on the device:
// count_total writes them, dispatch_args turns them into the next kernels' workgroup counts, so
// a level is recorded without knowing its sizes. An own job runs in the context's batches and
// may read a counter after a submit (sync); a recorded job writes into a host's command buffer
// (nfd_recording), with the capacities of a plan, and is read only after the host's wait.
class Job {
public:
    Job(Device& d, bool own_batches) : device(d), own(own_batches), buffers_(*d.vk) {}
    ~Job();  // a recorded job: after the host's wait
    Job(const Job&) = delete;
    Job& operator=(const Job&) = delete;
    nfd_result init();  // the batch, the counters (zeroed)
    Device& device;
    const bool own;

    nfd_result new_slot(uint32_t* slot);  // NFD_ERROR_INTERNAL past NFD_COUNTER_SLOTS
    // What the device wrote, as of the last refresh(): own jobs refresh after each submit.
    uint32_t counter(uint32_t slot) const { return mirror_[slot]; }
    nfd_result refresh();
    bool overflowed() const { return counter(NFD_COUNTER_OVERFLOW) != 0; }
    const Buffer& counters() const { return *counters_; }
    Batch& batch() { return batch_; }  // what the job records into
    void release_batch() { device.vk->destroy(batch_); }  // and what it kept; after its wait

    // Launches `pipeline` over `count`'s items, `per_invocation` to an invocation, the counters
    // bound where its kernel family has them; its push constants must describe the same count.
    nfd_result dispatch(const Pipeline& pipeline, std::vector<Bind> buffers, const void* push,
                        Count count, uint32_t per_invocation = 1);
    nfd_result dispatch(Kernel kernel, std::vector<Bind> buffers, const void* push, Count count) {
        return dispatch(device[kernel], std::move(buffers), push, count);
    }
    // Counter `slot` := the total of `elements` entries of `in` (their popcounts) whose exclusive
    // prefix sum is `prefix`; the overflow flag when it exceeds `capacity`.
    nfd_result total(const Buffer& in, const Buffer& prefix, uint32_t elements, bool popcount,
                     uint32_t slot, uint32_t capacity);
    void fill(const Buffer& buffer, uint32_t value) { device.vk->fill(batch_, buffer, value); }

    // Own jobs: begin() and submit() are the context's (records are reused after a submit), sync()
    // submits and begins again so that counters can be read. Recorded jobs: no-ops.
    nfd_result begin();
    nfd_result submit();
    nfd_result sync();

private:
    Batch batch_;
    Buffers buffers_;
    Buffer* counters_ = nullptr;
    uint32_t mirror_[NFD_COUNTER_SLOTS] = {};  // the host's copy of *counters_
    std::vector<Buffer*> args_;  // kRecordsPerBuffer VkDispatchIndirectCommand records each
    uint32_t records_ = 0, next_slot_ = NFD_COUNTER_OVERFLOW + 1;
};

class Job;
// Records an exclusive prefix sum of `count` words of `in` (or of their popcounts) into `out`.
nfd_result record_scan(Job& job, Buffers& scratch, const Buffer& in, const Buffer& out,
                       uint32_t count, bool popcount);

// ---- the network as field_eval.comp reads it (field.cpp) ---------------------------------------
// Per layer, rows of in4 vec4s (the output padded to a multiple of 4 with zero rows, layer 0's
// columns permuted to the shader's encoding order), then the bias, at offsets aligned for uniform
// (or, for layers past a uniform block, storage) binding.
struct DeviceNetwork {
    Device* device = nullptr;
    Buffer weights, frequencies;
    VkDeviceSize offset[NFD_GPU_MAX_LAYERS] = {}, range[NFD_GPU_MAX_LAYERS] = {};
    bool storage = false;
    uint32_t max4 = 0;                     // widest layer input/output, in vec4s
    uint32_t widest4 = 0;                  // widest layer output, in vec4s
    uint32_t weight_vec4s = 0;             // every layer's block, back to back (no alignment)
    bool transposed = false;               // blocks end in field_eval_lanes.comp's transposes
    VkDeviceSize bytes = 0;                // of `weights`, the aligned blocks
    std::vector<uint32_t> specialization;  // field_eval.comp's constants 0-13
    ShapeBall ball;                        // the network's: what its grid evaluations pass
    struct Variant {
        const Pipeline* pipeline = nullptr;  // created on first use
        uint32_t points_per_invocation = 1;
    } values, gradients;
    DeviceNetwork() = default;
    DeviceNetwork(const DeviceNetwork&) = delete;
    ~DeviceNetwork();
};

// The network on the device: uploaded once per device and shared by every decode of a network
// with the same content (Device::networks, the most recently used kCachedNetworks kept), so that
// the levels of a progressive decode, a decode after an evaluation, or the same asset decoded
// again at another resolution do not upload it again. NFD_ERROR_UNSUPPORTED_FEATURE for a network
// beyond the shader's caps.
nfd_result device_network(Device& d, const Network& net, std::shared_ptr<DeviceNetwork>* out);
// Records the evaluation of `count`'s points (xyz, from index 0 of `points`) into `results` from
// index count.first on: output_width() floats each, or with `gradient` (one output) one vec4
// each (value, d/dx, d/dy, d/dz); values beyond `ball` raised to its floor (grid points pass the
// network's, net.ball; the field itself an unbounded one).
nfd_result record_field(Job& job, DeviceNetwork& net, const Buffer& points, const Buffer& results,
                        Count count, bool gradient, const ShapeBall& ball);
// Creates the pipeline record_field will use (it does so itself on first use): compiling on a
// CPU implementation takes tens of MB for a while, better spent before the big buffers exist.
nfd_result prepare_field(Device& d, DeviceNetwork& net, bool gradient);
// Whether that pipeline is built (by prepare_field or a compile of prepare_fields), so that
// recording the kernel would not wait for a compile. Compiles nothing.
bool field_ready(Device& d, const DeviceNetwork& net, bool gradient);
// Starts compiling the pipelines a decode of this field type needs, on one thread of the device:
// the value kernel's, then for a UDF the gradient kernel's. Neither is waited for here: the
// coarsest level is evaluated on the host meanwhile (levels.h, HostTop), and record_field waits
// for each when it is first recorded. On 2-core lavapipe each takes 25-120 ms: a progressive
// decode's first level waited for the value kernel before the host evaluated it, and two threads
// compiling at once (one per kernel) slowed a UDF's first level by ~25 ms (bench/RESULTS.md).
nfd_result prepare_fields(Device& d, DeviceNetwork& net, FieldType field);

}  // namespace nfd::gpu
