// The small Vulkan layer under gpu_decode.cpp: a compute device (created headless or adopted from
// the host), buffers in device-local or host-visible memory with staging copies between them,
// compute pipelines with specialization constants, and recording of dispatches (direct, or
// indirect from records the device wrote) into batches: a batch's own command buffer, submitted
// synchronously, or a host's command buffer.
//
// Entry points are loaded at run time from the Vulkan loader (libvulkan.so.1, or the host's
// vkGetInstanceProcAddr), so a machine without Vulkan still runs the CPU path: creation then
// reports NFD_ERROR_DEVICE_UNAVAILABLE. No function here throws, exits or aborts.
//
// Why a table of our own and not volk (Debian libvulkan-volk-dev 1.3.239): volk keeps the
// instance-level entry points in process-wide globals (volkLoadInstance), and engines that link
// libnfdecode commonly use volk themselves. Linked statically, both copies define the same
// symbols; either way one side's volkLoadInstance rebinds the other's instance functions, and a
// context adopting the host's device through its own vkGetInstanceProcAddr next to a headless one
// (test_adopt) needs two sets at once. The per-context table below is volk's
// VolkDeviceTable idea applied to the ~50 functions this layer calls, at both levels.
#pragma once
#define VK_NO_PROTOTYPES
#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "faults.h"
#include "nfd_shaders.h"
#include "nfdecode/nfdecode.h"
#include "../pipeline_cache.h"
#include "range_allocator.h"

namespace nfd::gpu {

#define NFD_VK_INSTANCE_FUNCTIONS(X)                                                          \
    X(vkDestroyInstance) X(vkEnumeratePhysicalDevices) X(vkGetPhysicalDeviceProperties)       \
    X(vkGetPhysicalDeviceQueueFamilyProperties) X(vkGetPhysicalDeviceMemoryProperties)        \
    X(vkCreateDevice) X(vkGetDeviceProcAddr)

#define NFD_VK_DEVICE_FUNCTIONS(X)                                                            \
    X(vkDestroyDevice) X(vkGetDeviceQueue) X(vkCreateBuffer) X(vkDestroyBuffer)               \
    X(vkGetBufferMemoryRequirements) X(vkAllocateMemory) X(vkFreeMemory) X(vkBindBufferMemory) \
    X(vkMapMemory) X(vkUnmapMemory) X(vkCreateShaderModule) X(vkDestroyShaderModule)          \
    X(vkCreateDescriptorSetLayout) X(vkDestroyDescriptorSetLayout) X(vkCreatePipelineLayout)  \
    X(vkDestroyPipelineLayout) X(vkCreateComputePipelines) X(vkDestroyPipeline)               \
    X(vkCreatePipelineCache) X(vkDestroyPipelineCache) X(vkGetPipelineCacheData)            \
    X(vkCreateDescriptorPool)                                                                 \
    X(vkDestroyDescriptorPool) X(vkResetDescriptorPool) X(vkAllocateDescriptorSets)           \
    X(vkUpdateDescriptorSets) X(vkCreateCommandPool) X(vkDestroyCommandPool)                  \
    X(vkAllocateCommandBuffers) X(vkResetCommandPool) X(vkBeginCommandBuffer)                 \
    X(vkEndCommandBuffer) X(vkCmdBindPipeline) X(vkCmdBindDescriptorSets) X(vkCmdPushConstants) \
    X(vkCmdDispatch) X(vkCmdDispatchIndirect) X(vkCmdPipelineBarrier) X(vkCmdFillBuffer)      \
    X(vkCmdCopyBuffer) X(vkQueueSubmit)                                                       \
    X(vkCreateFence) X(vkDestroyFence) X(vkWaitForFences) X(vkResetFences) X(vkDeviceWaitIdle)

nfd_result to_result(VkResult result);

// Where a buffer lives. Device: device-local memory, mapped only where memory is unified (CPU
// implementations, integrated GPUs), else reached by the host through staging copies
// (Context::upload/download). Host: host-visible memory, always mapped, for small buffers the
// host writes while recording (the top level, a job's chunks of points) or reads often.
enum class Memory { Device, Host };

// The memory types a context takes, from the device's memory properties alone (so that tests can
// give it the layouts of drivers they do not run on). Device: a device-local type of the largest
// device-local heap (the VRAM of a discrete GPU, not its 256 MB BAR window). `unified` (every
// buffer mapped, nothing staged) when that type is host-visible, coherent and cached too (CPU
// implementations, integrated GPUs). A discrete GPU's mappable VRAM (resizable BAR) is not cached:
// each CPU read of it crosses the bus alone, which read an H200's meshes back at ~30 MB/s, so
// such a device's buffers are staged. Host (staging, read-backs, what the host writes and reads
// itself): host-visible and coherent, cached where a type is. False where no type is host-visible
// and coherent.
struct MemoryTypes {
    uint32_t device = UINT32_MAX, host = UINT32_MAX;
    bool unified = false;
};
bool choose_memory_types(const VkPhysicalDeviceMemoryProperties& memory, MemoryTypes* out);

// Device memory that small buffers share (Context::create_buffer).
struct MemoryBlock {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    uint32_t type = 0;           // memory type index
    void* mapped = nullptr;      // its mapping, for buffers that are mapped (blocks of a type
                                 // that serves both kinds are not shared between them)
    RangeAllocator ranges{0};    // where its buffers are
};

// A buffer and its memory; `data` is its mapping, or null where the host reaches it by staging.
// A small buffer lives at `offset` in a block that other buffers share (`block` set); a larger
// one has a VkDeviceMemory of its own.
struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    void* data = nullptr;
    VkDeviceSize size = 0;
    VkDeviceSize allocated = 0;  // bytes it takes in `memory`, counted in Context::live_bytes()
    VkDeviceSize offset = 0;
    MemoryBlock* block = nullptr;
    template <typename T>
    T* as() const { return static_cast<T*>(data); }
};

// What a dispatch binds at one binding: a buffer range, as a storage or uniform descriptor.
struct BufferRange {
    const Buffer* buffer = nullptr;
    VkDeviceSize offset = 0;
    VkDeviceSize range = VK_WHOLE_SIZE;
    BufferRange(const Buffer& b) : buffer(&b) {}  // NOLINT: whole buffers bind implicitly
    BufferRange(const Buffer& b, VkDeviceSize off, VkDeviceSize len)
        : buffer(&b), offset(off), range(len) {}
};
struct Bind {
    uint32_t binding;  // shaders/bindings.h
    BufferRange buffer;
};

constexpr uint32_t kNoCounters = UINT32_MAX;
// Bit b: binding b (shaders/bindings.h numbers them below 64).
using BindingMask = uint64_t;
constexpr uint32_t kBindingNumbers = 64;

// A pipeline's descriptor set holds the bindings of two masks (bit b: binding b), nothing else.
struct Pipeline {
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
    BindingMask storage_bindings = 0, uniform_bindings = 0;
    uint32_t push_constant_bytes = 0;
    uint32_t local_size = 0;  // invocations per workgroup (x only)
    uint32_t counters_binding = kNoCounters;  // where the job's counters bind (device.h, Job)
};

constexpr uint32_t kFixedLocalSize = UINT32_MAX;

// Descriptor pools that grow by a pool at a time and are reset together: the descriptor sets of
// one batch, which live as long as its commands may run.
struct DescriptorArena {
    std::vector<VkDescriptorPool> pools;
    size_t current = 0;  // the pool allocations are tried from
};

// One decode's recording (device.h's Job owns one): a command pool and buffer of its own, a fence
// and descriptor sets, so that decodes on several threads record and run at once. Recording a
// host's command buffer (begin_external), it records there instead, and keeps the buffers that
// the stages release meanwhile (the host's commands still use them) until Context::destroy(Batch&),
// which must come after the host's wait.
struct Batch {
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer own = VK_NULL_HANDLE, commands = VK_NULL_HANDLE;  // commands: where it records
    VkFence fence = VK_NULL_HANDLE;
    DescriptorArena arena;
    std::vector<Buffer> retired;
    bool recording = false, external = false;
};

struct PipelineDesc {
    const shaders::Spirv* spirv = nullptr;
    BindingMask storage_bindings = 0, uniform_bindings = 0;
    uint32_t push_constant_bytes = 0;
    uint32_t local_size = 64;                  // must match the shader's local_size_x
    uint32_t local_size_id = kFixedLocalSize;  // constant_id of local_size_x, if specialized
    std::vector<uint32_t> specialization;      // value of constant_id i (floats bit-cast)
    uint32_t counters_binding = kNoCounters;
};

class Context {
public:
    // `cache`/`cache_size`: an earlier context's pipeline_cache() (may be NULL/0); ignored
    // unless it is an intact envelope made on this device (pipeline_cache.h).
    static nfd_result create(const nfd_vulkan_device* adopt, bool enable_validation,
                             const void* cache, size_t cache_size, std::unique_ptr<Context>* out);
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    const std::string& name() const { return name_; }
    // The pipelines compiled so far (and those the cache was created with), in their envelope.
    // Safe beside compiles on other threads: a pipeline cache is synchronised by the driver.
    nfd_result pipeline_cache(std::vector<uint8_t>* out) const;
    const VkPhysicalDeviceLimits& limits() const { return properties_.limits; }

    // Buffers of at most kPooledBytes share blocks of kBlockBytes (one vkAllocateMemory for
    // tens of them; a block is freed when its last buffer is): a decode's counters, scan sums and
    // per-level tables are most of its buffers, and a driver's allocations are slow and limited
    // in number (maxMemoryAllocationCount, 4096 on some). live_bytes() counts each buffer's own
    // bytes, so the device holds up to the blocks' free space more.
    static constexpr VkDeviceSize kPooledBytes = VkDeviceSize(1) << 20;
    static constexpr VkDeviceSize kBlockBytes = VkDeviceSize(8) << 20;
    nfd_result create_buffer(VkDeviceSize size, Buffer* out, Memory memory = Memory::Device);
    // Destroys it, or while a host's command buffer is being recorded, keeps it until
    // its batch is destroyed (those commands may use it).
    void destroy(Buffer& buffer);
    bool unified() const { return memory_types_.unified; }
    bool cpu_implementation() const {
        return properties_.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    }
    // Invocations of a compute subgroup where the device has subgroup shuffles in compute
    // shaders (Vulkan 1.1's subgroup properties), else 0.
    uint32_t compute_shuffle_subgroup_size() const { return compute_shuffle_subgroup_size_; }
    // Host <-> buffer copies: memcpy where the buffer is mapped, else through a staging buffer
    // and a copy the context submits and waits for (in a command buffer of its own, under a
    // lock; the copy must not race with a batch in flight that writes the same buffer).
    nfd_result upload(const Buffer& to, VkDeviceSize offset, const void* data, VkDeviceSize bytes);
    nfd_result download(const Buffer& from, VkDeviceSize offset, void* data, VkDeviceSize bytes);
    // Device memory of the live buffers, and its peak since reset_peak(): what the memory bounds
    // (nfd_extraction_level.next_device_bytes, the queue's device budget) are checked against.
    VkDeviceSize live_bytes() const { return live_bytes_; }
    // Buffers and VkDeviceMemory objects (blocks and own memory) made so far, and the latter now.
    uint64_t buffers_created() const { return buffers_created_; }
    uint64_t memory_allocations() const { return memory_allocations_; }
    uint64_t live_allocations() const { return live_allocations_; }
    VkDeviceSize peak_bytes() const { return peak_bytes_; }
    void reset_peak() { peak_bytes_ = live_bytes_.load(); }
    nfd_result create_pipeline(const PipelineDesc& desc, Pipeline* out);
    void destroy(Pipeline& pipeline);

    // Recording, into a Batch: begin() starts the batch's own command buffer, begin_external() a
    // host's (end_external() closes it with a barrier toward vertex input, index, indirect,
    // shader, transfer and host reads). dispatch() binds (each of the pipeline's bindings exactly
    // once, else NFD_ERROR_INTERNAL), pushes and launches `invocations` invocations (rounded up
    // to workgroups, folded into 2D past maxComputeWorkGroupCount[0]) and is followed by a
    // barrier so the next dispatch (or indirect dispatch) sees its writes; zero invocations
    // record nothing. dispatch_indirect() launches what VkDispatchIndirectCommand `record` of
    // `args` holds when it runs. submit() runs the batch's own buffer on the queue and waits.
    // Batches of different threads record and run concurrently: the queue is taken under a lock
    // for each submission (an adopted queue must not be used by the host meanwhile).
    nfd_result create(Batch* batch);
    void destroy(Batch& batch);  // after its commands have run; frees what it kept
    nfd_result begin(Batch& batch);
    nfd_result begin_external(Batch& batch, VkCommandBuffer commands);
    void end_external(Batch& batch);
    nfd_result dispatch(Batch& batch, const Pipeline& pipeline, const Bind* buffers, size_t count,
                        const void* push, uint64_t invocations);
    nfd_result dispatch(Batch& batch, const Pipeline& pipeline, const std::vector<Bind>& buffers,
                        const void* push, uint64_t invocations) {
        return dispatch(batch, pipeline, buffers.data(), buffers.size(), push, invocations);
    }
    nfd_result dispatch_indirect(Batch& batch, const Pipeline& pipeline,
                                 const std::vector<Bind>& buffers, const void* push,
                                 const Buffer& args, uint32_t record);
    void fill(Batch& batch, const Buffer& buffer, uint32_t value);  // whole buffer, then a barrier
    nfd_result submit(Batch& batch);

private:
    Context() = default;
    nfd_result init_functions(const nfd_vulkan_device* adopt);
    nfd_result create_instance(bool enable_validation);
    nfd_result pick_physical_device();
    nfd_result create_logical_device();
    nfd_result create_command_objects(const void* cache, size_t cache_size);
    nfd_result load_functions(bool device_level);
    PipelineCacheKey cache_key() const;
    nfd_result pick_memory_types();
    nfd_result command_buffer(VkCommandPool* pool, VkCommandBuffer* commands, VkFence* fence);
    nfd_result submit_and_wait(VkCommandBuffer commands, VkFence fence);
    nfd_result copy_now(VkBuffer from, VkDeviceSize from_offset, VkBuffer to,
                        VkDeviceSize to_offset, VkDeviceSize bytes);
    void destroy_now(Buffer& buffer);
    // A place for a buffer of these requirements in a block of memory type `type`, mapped or not
    // (a new block when none has room).
    VkResult place_in_block(const VkMemoryRequirements& requirements, uint32_t type, bool mapped,
                            Buffer* b);
    VkResult allocate_memory(VkDeviceSize bytes, uint32_t type, VkDeviceMemory* out);
    void free_memory(VkDeviceMemory memory);
    void barrier(VkCommandBuffer commands);  // between a batch's dispatches
    // A global barrier from shader and transfer writes to `access` in `stages`.
    void after_writes(VkCommandBuffer commands, VkPipelineStageFlags stages, VkAccessFlags access);
    nfd_result bind(Batch& batch, const Pipeline& pipeline, const Bind* buffers, size_t count,
                    const void* push);
    nfd_result allocate_set(DescriptorArena& arena, VkDescriptorSetLayout layout,
                            VkDescriptorSet* out);
    nfd_result reset(DescriptorArena& arena);
    void destroy(DescriptorArena& arena);

    void* library_ = nullptr;  // dlopen handle of the loader, when we opened it
    PFN_vkGetInstanceProcAddr get_instance_proc_addr_ = nullptr;
    PFN_vkCreateInstance vkCreateInstance = nullptr;
    PFN_vkEnumerateInstanceLayerProperties vkEnumerateInstanceLayerProperties = nullptr;
#define NFD_VK_DECLARE(name) PFN_##name name = nullptr;
    NFD_VK_INSTANCE_FUNCTIONS(NFD_VK_DECLARE)
    NFD_VK_DEVICE_FUNCTIONS(NFD_VK_DECLARE)
#undef NFD_VK_DECLARE

    bool owns_device_ = true;
    VkInstance instance_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    uint32_t queue_family_ = 0;
    VkPhysicalDeviceProperties properties_{};
    uint32_t compute_shuffle_subgroup_size_ = 0;
    VkPhysicalDeviceMemoryProperties memory_{};
    MemoryTypes memory_types_;  // pick_memory_types()
    std::atomic<VkDeviceSize> live_bytes_{0}, peak_bytes_{0};
    std::atomic<uint64_t> buffers_created_{0}, memory_allocations_{0}, live_allocations_{0};
    std::mutex blocks_mutex_;  // blocks_, and the ranges of each block
    std::vector<std::unique_ptr<MemoryBlock>> blocks_;
    std::atomic<bool> lost_{false};  // a submission reported VK_ERROR_DEVICE_LOST: for good
    std::mutex queue_mutex_;     // vkQueueSubmit: the queue is externally synchronized
    std::mutex transfer_mutex_;  // upload/download's command buffer and fence
    std::string name_;

    VkPipelineCache cache_ = VK_NULL_HANDLE;
    VkCommandPool transfer_pool_ = VK_NULL_HANDLE;  // upload/download's staging copies
    VkCommandBuffer transfer_ = VK_NULL_HANDLE;
    VkFence transfer_fence_ = VK_NULL_HANDLE;
};

}  // namespace nfd::gpu
