#include "vk_context.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace nfd::gpu {

// The batch this thread records into a host's command buffer (begin_external to end_external),
// and its context: buffers destroyed meanwhile are kept for the host's commands (destroy).
thread_local Batch* t_external = nullptr;
thread_local const Context* t_external_context = nullptr;

// Descriptor sets are allocated per dispatch from an arena's pools of this many sets; a batch
// of the library's own (one level) records about a hundred dispatches, a host's recording of a
// whole decode a few hundred.
constexpr uint32_t kSetsPerPool = 256;
constexpr uint32_t kMaxBindings = 16;  // per pipeline (the pools are sized for it)

nfd_result to_result(VkResult result) {
    switch (result) {
        case VK_SUCCESS: return NFD_SUCCESS;
        case VK_ERROR_OUT_OF_HOST_MEMORY:
        case VK_ERROR_OUT_OF_DEVICE_MEMORY:
        case VK_ERROR_OUT_OF_POOL_MEMORY:
        case VK_ERROR_FRAGMENTED_POOL:
        case VK_ERROR_FRAGMENTATION: return NFD_ERROR_OUT_OF_MEMORY;
        case VK_ERROR_INITIALIZATION_FAILED:
        case VK_ERROR_INCOMPATIBLE_DRIVER:
        case VK_ERROR_EXTENSION_NOT_PRESENT:
        case VK_ERROR_LAYER_NOT_PRESENT:
        case VK_ERROR_FEATURE_NOT_PRESENT: return NFD_ERROR_DEVICE_UNAVAILABLE;
        default: return NFD_ERROR_DEVICE;  // device lost, timeouts, anything unexpected
    }
}

namespace {

std::atomic<int> g_fault_countdown[int(Fault::Count)];

// Whether the armed fault of `kind` strikes at this call (its countdown reaching 1).
bool fault_now(Fault kind) {
    std::atomic<int>& countdown = g_fault_countdown[int(kind)];
    int left = countdown.load(std::memory_order_relaxed);
    while (left > 0 && !countdown.compare_exchange_weak(left, left - 1)) {
    }
    return left == 1;
}

}  // namespace

void inject_fault(Fault kind, int after) { g_fault_countdown[int(kind)] = after > 0 ? after : 0; }

#define NFD_VK_TRY(call)                                             \
    do {                                                             \
        VkResult vk_result_ = (call);                                \
        if (vk_result_ != VK_SUCCESS) return to_result(vk_result_); \
    } while (0)
#define NFD_TRY_RESULT(expr)                          \
    do {                                              \
        const nfd_result nfd_try_ = (expr);           \
        if (nfd_try_ != NFD_SUCCESS) return nfd_try_; \
    } while (0)

nfd_result Context::create(const nfd_vulkan_device* adopt, bool enable_validation,
                           const void* cache, size_t cache_size, std::unique_ptr<Context>* out) {
    std::unique_ptr<Context> context(new (std::nothrow) Context());
    if (!context) return NFD_ERROR_OUT_OF_MEMORY;
    nfd_result r = context->init_functions(adopt);
    if (r == NFD_SUCCESS && adopt) {
        if (!adopt->instance || !adopt->physical_device || !adopt->device || !adopt->queue)
            return NFD_ERROR_INVALID_ARGUMENT;
        context->owns_device_ = false;
        context->instance_ = static_cast<VkInstance>(adopt->instance);
        context->physical_ = static_cast<VkPhysicalDevice>(adopt->physical_device);
        context->device_ = static_cast<VkDevice>(adopt->device);
        context->queue_ = static_cast<VkQueue>(adopt->queue);
        context->queue_family_ = adopt->queue_family_index;
    }
    if (r == NFD_SUCCESS && !adopt) r = context->create_instance(enable_validation);
    if (r == NFD_SUCCESS && !adopt) r = context->pick_physical_device();
    if (r == NFD_SUCCESS && !adopt) r = context->create_logical_device();
    if (r == NFD_SUCCESS) r = context->create_command_objects(cache, cache_size);
    if (r != NFD_SUCCESS) return r;
    *out = std::move(context);
    return NFD_SUCCESS;
}

nfd_result Context::init_functions(const nfd_vulkan_device* adopt) {
    if (adopt && adopt->get_instance_proc_addr) {
        get_instance_proc_addr_ =
            reinterpret_cast<PFN_vkGetInstanceProcAddr>(adopt->get_instance_proc_addr);
    } else {
        library_ = dlopen("libvulkan.so.1", RTLD_NOW | RTLD_LOCAL);
        if (!library_) return NFD_ERROR_DEVICE_UNAVAILABLE;
        get_instance_proc_addr_ = reinterpret_cast<PFN_vkGetInstanceProcAddr>(
            dlsym(library_, "vkGetInstanceProcAddr"));
    }
    if (!get_instance_proc_addr_) return NFD_ERROR_DEVICE_UNAVAILABLE;
    vkCreateInstance = reinterpret_cast<PFN_vkCreateInstance>(
        get_instance_proc_addr_(VK_NULL_HANDLE, "vkCreateInstance"));
    vkEnumerateInstanceLayerProperties = reinterpret_cast<PFN_vkEnumerateInstanceLayerProperties>(
        get_instance_proc_addr_(VK_NULL_HANDLE, "vkEnumerateInstanceLayerProperties"));
    if (!vkCreateInstance) return NFD_ERROR_DEVICE_UNAVAILABLE;
    return NFD_SUCCESS;
}

nfd_result Context::create_instance(bool enable_validation) {
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "libnfdecode";
    app.pEngineName = "libnfdecode";
    app.apiVersion = VK_API_VERSION_1_1;
    const char* validation = "VK_LAYER_KHRONOS_validation";
    bool have_validation = false;
    if (enable_validation && vkEnumerateInstanceLayerProperties) {
        uint32_t count = 0;
        vkEnumerateInstanceLayerProperties(&count, nullptr);
        std::vector<VkLayerProperties> layers(count);
        vkEnumerateInstanceLayerProperties(&count, layers.data());
        for (const VkLayerProperties& layer : layers)
            have_validation |= std::strcmp(layer.layerName, validation) == 0;
    }
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;
    info.enabledLayerCount = have_validation ? 1 : 0;
    info.ppEnabledLayerNames = &validation;
    NFD_VK_TRY(vkCreateInstance(&info, nullptr, &instance_));
    return load_functions(false);
}

// Resolves the instance-level (`device_level` false, through vkGetInstanceProcAddr) or device-level
// (through vkGetDeviceProcAddr) entry points; a missing one means no usable device.
nfd_result Context::load_functions(bool device_level) {
    bool all = true;
#define NFD_VK_LOAD_THROUGH(getter, handle, name)                                            \
    name = reinterpret_cast<PFN_##name>(getter(handle, #name));                              \
    all &= name != nullptr;
#define NFD_VK_LOAD_INSTANCE(name) NFD_VK_LOAD_THROUGH(get_instance_proc_addr_, instance_, name)
#define NFD_VK_LOAD_DEVICE(name) NFD_VK_LOAD_THROUGH(vkGetDeviceProcAddr, device_, name)
    if (device_level) {
        NFD_VK_DEVICE_FUNCTIONS(NFD_VK_LOAD_DEVICE)
    } else {
        NFD_VK_INSTANCE_FUNCTIONS(NFD_VK_LOAD_INSTANCE)
    }
#undef NFD_VK_LOAD_DEVICE
#undef NFD_VK_LOAD_INSTANCE
#undef NFD_VK_LOAD_THROUGH
    return all ? NFD_SUCCESS : NFD_ERROR_DEVICE_UNAVAILABLE;
}

nfd_result Context::pick_physical_device() {
    uint32_t count = 0;
    NFD_VK_TRY(vkEnumeratePhysicalDevices(instance_, &count, nullptr));
    std::vector<VkPhysicalDevice> devices(count);
    VkResult listed = vkEnumeratePhysicalDevices(instance_, &count, devices.data());
    if (listed != VK_SUCCESS && listed != VK_INCOMPLETE) return to_result(listed);
    devices.resize(count);
    // Discrete GPU first, then integrated, virtual, and CPU implementations (lavapipe) last.
    auto rank = [](VkPhysicalDeviceType type) {
        switch (type) {
            case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
            case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
            case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
            case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
            default: return 4;
        }
    };
    int best = 5;
    for (VkPhysicalDevice device : devices) {
        VkPhysicalDeviceProperties properties;
        vkGetPhysicalDeviceProperties(device, &properties);
        if (properties.apiVersion < VK_API_VERSION_1_1 || rank(properties.deviceType) >= best)
            continue;
        uint32_t families = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(device, &families, nullptr);
        std::vector<VkQueueFamilyProperties> family(families);
        vkGetPhysicalDeviceQueueFamilyProperties(device, &families, family.data());
        for (uint32_t i = 0; i < families; ++i) {
            if (family[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
                physical_ = device;
                queue_family_ = i;
                best = rank(properties.deviceType);
                break;
            }
        }
    }
    return physical_ ? NFD_SUCCESS : NFD_ERROR_DEVICE_UNAVAILABLE;
}

nfd_result Context::create_logical_device() {
    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue{};
    queue.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue.queueFamilyIndex = queue_family_;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    VkDeviceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queue;
    if (fault_now(Fault::DeviceCreation)) return to_result(VK_ERROR_INITIALIZATION_FAILED);
    NFD_VK_TRY(vkCreateDevice(physical_, &info, nullptr, &device_));
    return NFD_SUCCESS;
}

bool choose_memory_types(const VkPhysicalDeviceMemoryProperties& memory, MemoryTypes* out) {
    const VkMemoryPropertyFlags host =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    const VkMemoryPropertyFlags cached = host | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    const VkMemoryPropertyFlags local = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    const uint32_t heaps = std::min(memory.memoryHeapCount, uint32_t(VK_MAX_MEMORY_HEAPS));
    const uint32_t types = std::min(memory.memoryTypeCount, uint32_t(VK_MAX_MEMORY_TYPES));
    MemoryTypes m;
    uint32_t heap = UINT32_MAX;
    for (uint32_t h = 0; h < heaps; ++h)
        if ((memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) &&
            (heap == UINT32_MAX || memory.memoryHeaps[h].size > memory.memoryHeaps[heap].size))
            heap = h;
    for (uint32_t i = 0; i < types; ++i) {
        const VkMemoryType& t = memory.memoryTypes[i];
        if (t.heapIndex != heap || !(t.propertyFlags & local)) continue;
        const bool mappable = (t.propertyFlags & cached) == cached;
        if (m.device == UINT32_MAX || (mappable && !m.unified)) {
            m.device = i;
            m.unified = mappable;
        }
    }
    for (const VkMemoryPropertyFlags wanted : {cached, host})
        for (uint32_t i = 0; i < types && m.host == UINT32_MAX; ++i)
            if ((memory.memoryTypes[i].propertyFlags & wanted) == wanted) m.host = i;
    if (m.host == UINT32_MAX) return false;
    if (m.device == UINT32_MAX) {  // no device-local heap: host memory is all there is
        m.device = m.host;
        m.unified = true;
    }
    *out = m;
    return true;
}

// NFD_FORCE_STAGING: tests run the staged path on lavapipe, whose memory is unified.
nfd_result Context::pick_memory_types() {
    if (!choose_memory_types(memory_, &memory_types_)) return NFD_ERROR_DEVICE_UNAVAILABLE;
    const char* force = std::getenv("NFD_FORCE_STAGING");
    if (force && *force && *force != '0') memory_types_.unified = false;
    return NFD_SUCCESS;
}

nfd_result Context::create_command_objects(const void* cache_blob, size_t cache_size) {
    if (!owns_device_) {  // adopted: instance-level functions come from the host's instance
        if (const nfd_result r = load_functions(false); r != NFD_SUCCESS) return r;
        // The host's queue family index is used for our command pool: an index the device does
        // not have, or one without compute, is invalid usage that drivers need not catch.
        uint32_t families = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, nullptr);
        std::vector<VkQueueFamilyProperties> family(families);
        vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, family.data());
        if (queue_family_ >= families || !(family[queue_family_].queueFlags & VK_QUEUE_COMPUTE_BIT))
            return NFD_ERROR_INVALID_ARGUMENT;
    }
    if (const nfd_result r = load_functions(true); r != NFD_SUCCESS) return r;
    if (owns_device_) vkGetDeviceQueue(device_, queue_family_, 0, &queue_);

    vkGetPhysicalDeviceProperties(physical_, &properties_);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
    name_ = properties_.deviceName;
    // The kernels are SPIR-V 1.3 (Vulkan 1.1); an adopted 1.0 device could not create them.
    if (properties_.apiVersion < VK_API_VERSION_1_1) return NFD_ERROR_DEVICE_UNAVAILABLE;
    const auto properties2 = reinterpret_cast<PFN_vkGetPhysicalDeviceProperties2>(
        get_instance_proc_addr_(instance_, "vkGetPhysicalDeviceProperties2"));
    if (properties2) {
        VkPhysicalDeviceSubgroupProperties subgroup{};
        subgroup.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
        VkPhysicalDeviceProperties2 all{};
        all.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
        all.pNext = &subgroup;
        properties2(physical_, &all);
        if ((subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
            (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_SHUFFLE_BIT))
            compute_shuffle_subgroup_size_ = subgroup.subgroupSize;
    }
    NFD_TRY_RESULT(pick_memory_types());

    VkPipelineCacheCreateInfo cache{};
    cache.sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO;
    const uint8_t* driver_bytes = nullptr;
    size_t driver_size = 0;
    if (open_pipeline_cache(cache_key(), cache_blob, cache_size, &driver_bytes, &driver_size)) {
        cache.initialDataSize = driver_size;
        cache.pInitialData = driver_bytes;
    }
    NFD_VK_TRY(vkCreatePipelineCache(device_, &cache, nullptr, &cache_));
    return command_buffer(&transfer_pool_, &transfer_, &transfer_fence_);
}

PipelineCacheKey Context::cache_key() const {
    PipelineCacheKey key;
    key.vendor_id = properties_.vendorID;
    key.device_id = properties_.deviceID;
    key.driver_version = properties_.driverVersion;
    std::memcpy(key.cache_uuid, properties_.pipelineCacheUUID, sizeof key.cache_uuid);
    return key;
}

nfd_result Context::pipeline_cache(std::vector<uint8_t>* out) const {
    // The cache may grow between the size query and the copy (a compile on another thread):
    // VK_INCOMPLETE then, and the query again.
    std::vector<uint8_t> bytes;
    for (;;) {
        size_t size = 0;
        NFD_VK_TRY(vkGetPipelineCacheData(device_, cache_, &size, nullptr));
        bytes.resize(size);
        const VkResult r = vkGetPipelineCacheData(device_, cache_, &size, bytes.data());
        if (r == VK_INCOMPLETE) continue;
        if (r != VK_SUCCESS) return to_result(r);
        bytes.resize(size);
        break;
    }
    *out = wrap_pipeline_cache(cache_key(), bytes.data(), bytes.size());
    return NFD_SUCCESS;
}

nfd_result Context::command_buffer(VkCommandPool* pool, VkCommandBuffer* commands,
                                   VkFence* fence) {
    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.queueFamilyIndex = queue_family_;
    NFD_VK_TRY(vkCreateCommandPool(device_, &pool_info, nullptr, pool));
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = *pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    NFD_VK_TRY(vkAllocateCommandBuffers(device_, &alloc, commands));
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    NFD_VK_TRY(vkCreateFence(device_, &fence_info, nullptr, fence));
    return NFD_SUCCESS;
}

nfd_result Context::create(Batch* batch) {
    *batch = Batch{};
    return command_buffer(&batch->pool, &batch->own, &batch->fence);
}

void Context::destroy(Batch& batch) {
    for (Buffer& b : batch.retired) destroy_now(b);
    destroy(batch.arena);
    if (batch.fence) vkDestroyFence(device_, batch.fence, nullptr);
    if (batch.pool) vkDestroyCommandPool(device_, batch.pool, nullptr);  // frees its buffer
    batch = Batch{};
}

nfd_result Context::allocate_set(DescriptorArena& arena, VkDescriptorSetLayout layout,
                                 VkDescriptorSet* out) {
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &layout;
    for (; arena.current < arena.pools.size(); ++arena.current) {
        alloc.descriptorPool = arena.pools[arena.current];
        const VkResult r = vkAllocateDescriptorSets(device_, &alloc, out);
        if (r == VK_SUCCESS) return NFD_SUCCESS;
        if (r != VK_ERROR_OUT_OF_POOL_MEMORY && r != VK_ERROR_FRAGMENTED_POOL) return to_result(r);
    }
    VkDescriptorPoolSize sizes[2] = {
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kSetsPerPool * kMaxBindings},
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, kSetsPerPool * kMaxBindings}};
    VkDescriptorPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    info.maxSets = kSetsPerPool;
    info.poolSizeCount = 2;
    info.pPoolSizes = sizes;
    VkDescriptorPool pool;
    NFD_VK_TRY(vkCreateDescriptorPool(device_, &info, nullptr, &pool));
    try {
        arena.pools.push_back(pool);
    } catch (...) {
        vkDestroyDescriptorPool(device_, pool, nullptr);
        return NFD_ERROR_OUT_OF_MEMORY;
    }
    alloc.descriptorPool = pool;
    NFD_VK_TRY(vkAllocateDescriptorSets(device_, &alloc, out));
    return NFD_SUCCESS;
}

nfd_result Context::reset(DescriptorArena& arena) {
    for (VkDescriptorPool pool : arena.pools) NFD_VK_TRY(vkResetDescriptorPool(device_, pool, 0));
    arena.current = 0;
    return NFD_SUCCESS;
}

void Context::destroy(DescriptorArena& arena) {
    for (VkDescriptorPool pool : arena.pools) vkDestroyDescriptorPool(device_, pool, nullptr);
    arena = DescriptorArena{};
}

Context::~Context() {
    if (device_ && vkDeviceWaitIdle) {
        // An adopted device may be busy with the host's work; only our queue's work matters,
        // and submit() already waited for it.
        if (owns_device_) vkDeviceWaitIdle(device_);
        if (transfer_fence_) vkDestroyFence(device_, transfer_fence_, nullptr);
        if (transfer_pool_) vkDestroyCommandPool(device_, transfer_pool_, nullptr);
        if (cache_) vkDestroyPipelineCache(device_, cache_, nullptr);
        for (const auto& block : blocks_) vkFreeMemory(device_, block->memory, nullptr);
        if (owns_device_) vkDestroyDevice(device_, nullptr);
    } else if (device_ && owns_device_ && vkDestroyDevice) {
        vkDestroyDevice(device_, nullptr);
    }
    if (instance_ && owns_device_ && vkDestroyInstance) vkDestroyInstance(instance_, nullptr);
    if (library_) dlclose(library_);
}

nfd_result Context::create_buffer(VkDeviceSize size, Buffer* out, Memory memory) {
    *out = Buffer{};
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = std::max<VkDeviceSize>(size, 16);
    // Vertex, index and indirect usage: a recording's mesh buffers go to the host's graphics
    // pipeline as they are (nfd_recording), and dispatch_args records drive dispatches.
    info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT |
                 VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                 VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_VERTEX_BUFFER_BIT |
                 VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    Buffer b;
    b.size = info.size;
    NFD_VK_TRY(vkCreateBuffer(device_, &info, nullptr, &b.buffer));
    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(device_, b.buffer, &requirements);
    const uint32_t type = memory == Memory::Host ? memory_types_.host : memory_types_.device;
    if (!(requirements.memoryTypeBits & (1u << type))) {
        vkDestroyBuffer(device_, b.buffer, nullptr);
        return NFD_ERROR_DEVICE;
    }
    const bool mapped = memory == Memory::Host || memory_types_.unified;
    // An injected fault strikes buffers, pooled or not: each allocation of a decode can fail.
    VkResult r = VK_ERROR_OUT_OF_DEVICE_MEMORY;
    if (!fault_now(Fault::Allocation)) {
        if (requirements.size <= kPooledBytes) {
            r = place_in_block(requirements, type, mapped, &b);
        } else {
            r = allocate_memory(requirements.size, type, &b.memory);
            if (r == VK_SUCCESS) b.allocated = requirements.size;
        }
    }
    if (r == VK_SUCCESS) {
        const VkDeviceSize live = live_bytes_ += b.allocated;
        VkDeviceSize peak = peak_bytes_.load();
        while (live > peak && !peak_bytes_.compare_exchange_weak(peak, live)) {
        }
        r = vkBindBufferMemory(device_, b.buffer, b.memory, b.offset);
    }
    if (r == VK_SUCCESS && mapped && !b.block)
        r = vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.data);
    if (r != VK_SUCCESS) {
        destroy(b);
        return to_result(r);
    }
    ++buffers_created_;
    *out = b;
    return NFD_SUCCESS;
}

VkResult Context::allocate_memory(VkDeviceSize bytes, uint32_t type, VkDeviceMemory* out) {
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = bytes;
    alloc.memoryTypeIndex = type;
    const VkResult r = vkAllocateMemory(device_, &alloc, nullptr, out);
    if (r == VK_SUCCESS) {
        ++memory_allocations_;
        ++live_allocations_;
    }
    return r;
}

void Context::free_memory(VkDeviceMemory memory) {
    vkFreeMemory(device_, memory, nullptr);
    --live_allocations_;
}

VkResult Context::place_in_block(const VkMemoryRequirements& requirements, uint32_t type,
                                 bool mapped, Buffer* b) {
    std::lock_guard<std::mutex> lock(blocks_mutex_);
    MemoryBlock* block = nullptr;
    uint64_t offset = 0;
    for (const auto& candidate : blocks_)
        if (candidate->type == type && (candidate->mapped != nullptr) == mapped &&
            candidate->ranges.allocate(requirements.size, requirements.alignment, &offset)) {
            block = candidate.get();
            break;
        }
    if (!block) {
        std::unique_ptr<MemoryBlock> fresh;
        try {
            fresh = std::make_unique<MemoryBlock>();
            fresh->ranges = RangeAllocator(kBlockBytes);
            blocks_.reserve(blocks_.size() + 1);
        } catch (...) {
            return VK_ERROR_OUT_OF_HOST_MEMORY;
        }
        fresh->type = type;
        VkResult r = allocate_memory(kBlockBytes, type, &fresh->memory);
        if (r == VK_SUCCESS && mapped)
            r = vkMapMemory(device_, fresh->memory, 0, VK_WHOLE_SIZE, 0, &fresh->mapped);
        if (r != VK_SUCCESS) {
            if (fresh->memory) free_memory(fresh->memory);
            return r;
        }
        blocks_.push_back(std::move(fresh));  // reserved above: does not throw
        block = blocks_.back().get();
        // requirements.size <= kPooledBytes < kBlockBytes, and a fresh block is free from 0
        block->ranges.allocate(requirements.size, requirements.alignment, &offset);
    }
    b->memory = block->memory;
    b->block = block;
    b->offset = offset;
    b->allocated = requirements.size;
    if (block->mapped) b->data = static_cast<char*>(block->mapped) + offset;
    return VK_SUCCESS;
}

void Context::destroy_now(Buffer& b) {
    if (b.buffer) vkDestroyBuffer(device_, b.buffer, nullptr);
    if (b.block) {
        std::lock_guard<std::mutex> lock(blocks_mutex_);
        try {
            b.block->ranges.free(b.offset, b.allocated);
        } catch (...) {  // no memory for the free list: the range stays taken until the block goes
        }
        if (b.block->ranges.empty())
            for (auto it = blocks_.begin(); it != blocks_.end(); ++it)
                if (it->get() == b.block) {
                    free_memory(b.block->memory);  // implicitly unmaps
                    blocks_.erase(it);
                    break;
                }
    } else if (b.memory) {
        free_memory(b.memory);  // implicitly unmaps
    }
    live_bytes_ -= b.allocated;
    b = Buffer{};
}

void Context::destroy(Buffer& b) {
    if (t_external && t_external_context == this && b.buffer) {
        // The host's commands still use it: kept until its batch is destroyed. Without memory
        // for the list it is leaked rather than freed under a pending command.
        try {
            t_external->retired.push_back(b);
        } catch (...) {
        }
        b = Buffer{};
        return;
    }
    destroy_now(b);
}

nfd_result Context::create_pipeline(const PipelineDesc& desc, Pipeline* out) {
    *out = Pipeline{};
    if ((desc.storage_bindings & desc.uniform_bindings) ||
        __builtin_popcountll(desc.storage_bindings | desc.uniform_bindings) > int(kMaxBindings))
        return NFD_ERROR_INTERNAL;
    Pipeline p;
    p.storage_bindings = desc.storage_bindings;
    p.uniform_bindings = desc.uniform_bindings;
    p.push_constant_bytes = desc.push_constant_bytes;
    p.local_size = desc.local_size;
    p.counters_binding = desc.counters_binding;
    auto fail = [&](VkResult r) {
        destroy(p);
        return to_result(r);
    };
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    for (uint32_t b = 0; b < kBindingNumbers; ++b) {
        const bool storage = desc.storage_bindings >> b & 1;
        const bool uniform = desc.uniform_bindings >> b & 1;
        if (storage || uniform)
            bindings.push_back({b,
                                storage ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                        : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                                1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    }
    VkDescriptorSetLayoutCreateInfo set{};
    set.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    set.bindingCount = uint32_t(bindings.size());
    set.pBindings = bindings.data();
    VkResult r = vkCreateDescriptorSetLayout(device_, &set, nullptr, &p.set_layout);
    if (r != VK_SUCCESS) return fail(r);
    VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, desc.push_constant_bytes};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.setLayoutCount = 1;
    layout.pSetLayouts = &p.set_layout;
    layout.pushConstantRangeCount = desc.push_constant_bytes ? 1 : 0;
    layout.pPushConstantRanges = &push;
    r = vkCreatePipelineLayout(device_, &layout, nullptr, &p.layout);
    if (r != VK_SUCCESS) return fail(r);

    VkShaderModuleCreateInfo module_info{};

    module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    module_info.codeSize = desc.spirv->size_bytes;
    module_info.pCode = desc.spirv->code;
    VkShaderModule module = VK_NULL_HANDLE;
    r = vkCreateShaderModule(device_, &module_info, nullptr, &module);
    if (r != VK_SUCCESS) return fail(r);

    std::vector<uint32_t> values = desc.specialization;
    if (desc.local_size_id != kFixedLocalSize) {
        if (values.size() <= desc.local_size_id) values.resize(desc.local_size_id + 1, 0);
        values[desc.local_size_id] = desc.local_size;
    }
    std::vector<VkSpecializationMapEntry> entries(values.size());
    for (uint32_t i = 0; i < entries.size(); ++i) entries[i] = {i, 4 * i, 4};
    VkSpecializationInfo specialization{uint32_t(entries.size()), entries.data(),
                                        values.size() * 4, values.data()};
    VkComputePipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
    info.stage = {};
    info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = p.layout;
    r = vkCreateComputePipelines(device_, cache_, 1, &info, nullptr, &p.pipeline);
    vkDestroyShaderModule(device_, module, nullptr);
    if (r != VK_SUCCESS) return fail(r);
    *out = std::move(p);
    return NFD_SUCCESS;
}

void Context::destroy(Pipeline& p) {
    if (p.pipeline) vkDestroyPipeline(device_, p.pipeline, nullptr);
    if (p.layout) vkDestroyPipelineLayout(device_, p.layout, nullptr);
    if (p.set_layout) vkDestroyDescriptorSetLayout(device_, p.set_layout, nullptr);
    p = Pipeline{};
}

nfd_result Context::begin(Batch& batch) {
    if (batch.recording) return NFD_ERROR_INTERNAL;
    NFD_VK_TRY(vkResetCommandPool(device_, batch.pool, 0));
    NFD_TRY_RESULT(reset(batch.arena));
    VkCommandBufferBeginInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    NFD_VK_TRY(vkBeginCommandBuffer(batch.own, &info));
    batch.commands = batch.own;
    batch.recording = true;
    return NFD_SUCCESS;
}

nfd_result Context::begin_external(Batch& batch, VkCommandBuffer commands) {
    if (batch.recording || t_external || commands == VK_NULL_HANDLE) return NFD_ERROR_INTERNAL;
    batch.commands = commands;
    batch.recording = batch.external = true;
    // Buffers this thread destroys until end_external are the host's commands' to use still.
    // Host writes to our buffers (the network, the top level's points) are visible at the
    // host's submission; no earlier command of the host's touches a recording's buffers.
    t_external = &batch;
    t_external_context = this;
    return NFD_SUCCESS;
}

void Context::end_external(Batch& batch) {
    // The results are read by the host's vertex input, index fetch, indirect draw, copies or the
    // host after its wait (nfdecode.h, nfd_recording_record).
    after_writes(batch.commands,
                 VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT |
                     VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT |
                     VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                 VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDEX_READ_BIT |
                     VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_SHADER_READ_BIT |
                     VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT);
    batch.recording = false;
    batch.commands = VK_NULL_HANDLE;
    t_external = nullptr;
    t_external_context = nullptr;
}

void Context::after_writes(VkCommandBuffer commands, VkPipelineStageFlags stages,
                           VkAccessFlags access) {
    VkMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = access;
    vkCmdPipelineBarrier(commands,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         stages, 0, 1, &b, 0, nullptr, 0, nullptr);
}

void Context::barrier(VkCommandBuffer commands) {
    // Coarse but sufficient: every stage reads what the previous one wrote (dispatch_args'
    // records as indirect commands too); host reads happen after the fence, and host writes
    // before submission are made visible by the submit itself.
    after_writes(commands,
                 VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT |
                     VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                     VK_ACCESS_UNIFORM_READ_BIT | VK_ACCESS_HOST_READ_BIT |
                     VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
}

nfd_result Context::bind(Batch& batch, const Pipeline& pipeline, const Bind* buffers,
                         size_t count, const void* push) {
    if (!batch.recording) return NFD_ERROR_INTERNAL;
    BindingMask given = 0;
    for (const Bind* b = buffers; b != buffers + count; ++b) {
        if (b->binding >= kBindingNumbers || (given >> b->binding & 1)) return NFD_ERROR_INTERNAL;
        given |= BindingMask(1) << b->binding;
    }
    if (given != (pipeline.storage_bindings | pipeline.uniform_bindings)) return NFD_ERROR_INTERNAL;
    VkDescriptorSet set;
    NFD_TRY_RESULT(allocate_set(batch.arena, pipeline.set_layout, &set));
    VkDescriptorBufferInfo infos[kMaxBindings];
    VkWriteDescriptorSet writes[kMaxBindings];
    uint32_t i = 0;
    for (const Bind* b = buffers; b != buffers + count; ++b) {
        const BufferRange& r = b->buffer;
        infos[i] = {r.buffer->buffer, r.offset, r.range};
        writes[i] = {};
        writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        writes[i].dstSet = set;
        writes[i].dstBinding = b->binding;
        writes[i].descriptorCount = 1;
        writes[i].descriptorType = pipeline.storage_bindings >> b->binding & 1
                                       ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                       : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        writes[i].pBufferInfo = &infos[i];
        ++i;
    }
    vkUpdateDescriptorSets(device_, i, writes, 0, nullptr);
    vkCmdBindPipeline(batch.commands, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline);
    vkCmdBindDescriptorSets(batch.commands, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.layout, 0, 1,
                            &set, 0, nullptr);
    if (pipeline.push_constant_bytes)
        vkCmdPushConstants(batch.commands, pipeline.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0,
                           pipeline.push_constant_bytes, push);
    return NFD_SUCCESS;
}

nfd_result Context::dispatch(Batch& batch, const Pipeline& pipeline, const Bind* buffers,
                             size_t count, const void* push, uint64_t invocations) {
    if (invocations == 0) return batch.recording ? NFD_SUCCESS : NFD_ERROR_INTERNAL;
    uint64_t groups = (invocations + pipeline.local_size - 1) / pipeline.local_size;
    uint64_t max_x = properties_.limits.maxComputeWorkGroupCount[0];
    uint64_t y = (groups + max_x - 1) / max_x;
    uint64_t x = (groups + y - 1) / y;  // x * y >= groups; shaders skip the excess
    if (y > properties_.limits.maxComputeWorkGroupCount[1]) return NFD_ERROR_LIMIT_EXCEEDED;
    NFD_TRY_RESULT(bind(batch, pipeline, buffers, count, push));
    vkCmdDispatch(batch.commands, uint32_t(x), uint32_t(y), 1);
    barrier(batch.commands);
    return NFD_SUCCESS;
}

nfd_result Context::dispatch_indirect(Batch& batch, const Pipeline& pipeline,
                                      const std::vector<Bind>& buffers, const void* push,
                                      const Buffer& args, uint32_t record) {
    NFD_TRY_RESULT(bind(batch, pipeline, buffers.data(), buffers.size(), push));
    vkCmdDispatchIndirect(batch.commands, args.buffer, VkDeviceSize(record) * 12);
    barrier(batch.commands);
    return NFD_SUCCESS;
}

void Context::fill(Batch& batch, const Buffer& buffer, uint32_t value) {
    vkCmdFillBuffer(batch.commands, buffer.buffer, 0, VK_WHOLE_SIZE, value);
    barrier(batch.commands);
}

nfd_result Context::submit_and_wait(VkCommandBuffer commands, VkFence fence) {
    if (lost_) return to_result(VK_ERROR_DEVICE_LOST);
    VkSubmitInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    info.commandBufferCount = 1;
    info.pCommandBuffers = &commands;
    NFD_VK_TRY(vkResetFences(device_, 1, &fence));
    {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        NFD_VK_TRY(vkQueueSubmit(queue_, 1, &info, fence));
    }
    VkResult waited = vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX);
    if (waited == VK_SUCCESS && fault_now(Fault::Submission)) waited = VK_ERROR_DEVICE_LOST;
    if (waited == VK_ERROR_DEVICE_LOST) lost_ = true;
    return to_result(waited);
}

nfd_result Context::submit(Batch& batch) {
    if (!batch.recording || batch.external) return NFD_ERROR_DEVICE;
    batch.recording = false;
    NFD_VK_TRY(vkEndCommandBuffer(batch.own));
    return submit_and_wait(batch.own, batch.fence);
}

nfd_result Context::copy_now(VkBuffer from, VkDeviceSize from_offset, VkBuffer to,
                             VkDeviceSize to_offset, VkDeviceSize bytes) {
    // A command buffer of its own: a batch (or a host's buffer) may be half recorded.
    std::lock_guard<std::mutex> lock(transfer_mutex_);
    NFD_VK_TRY(vkResetCommandPool(device_, transfer_pool_, 0));
    VkCommandBufferBeginInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    NFD_VK_TRY(vkBeginCommandBuffer(transfer_, &info));
    const VkBufferCopy region{from_offset, to_offset, bytes};
    vkCmdCopyBuffer(transfer_, from, to, 1, &region);
    after_writes(transfer_, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                 VK_ACCESS_HOST_READ_BIT | VK_ACCESS_SHADER_READ_BIT);
    NFD_VK_TRY(vkEndCommandBuffer(transfer_));
    return submit_and_wait(transfer_, transfer_fence_);
}

nfd_result Context::upload(const Buffer& to, VkDeviceSize offset, const void* data,
                           VkDeviceSize bytes) {
    if (bytes == 0) return NFD_SUCCESS;
    if (offset + bytes > to.size) return NFD_ERROR_INTERNAL;
    if (to.data) {
        std::memcpy(static_cast<char*>(to.data) + offset, data, bytes);
        return NFD_SUCCESS;
    }
    Buffer staging;
    NFD_TRY_RESULT(create_buffer(bytes, &staging, Memory::Host));
    std::memcpy(staging.data, data, bytes);
    const nfd_result r = copy_now(staging.buffer, 0, to.buffer, offset, bytes);
    destroy_now(staging);
    return r;
}

nfd_result Context::download(const Buffer& from, VkDeviceSize offset, void* data,
                             VkDeviceSize bytes) {
    if (bytes == 0) return NFD_SUCCESS;
    if (offset + bytes > from.size) return NFD_ERROR_INTERNAL;
    if (from.data) {
        std::memcpy(data, static_cast<const char*>(from.data) + offset, bytes);
        return NFD_SUCCESS;
    }
    Buffer staging;
    NFD_TRY_RESULT(create_buffer(bytes, &staging, Memory::Host));
    const nfd_result r = copy_now(from.buffer, offset, staging.buffer, 0, bytes);
    if (r == NFD_SUCCESS) std::memcpy(data, staging.data, bytes);
    destroy_now(staging);
    return r;
}

}  // namespace nfd::gpu
