#include "vk_device.h"

#include <cstring>
#include <stdexcept>
#include <vector>

namespace nfc_viewer {
namespace {

// The lock of the one VkDeviceContext whose device is lent (the viewer has one).
std::mutex* g_lent_queue_mutex = nullptr;

VKAPI_ATTR VkResult VKAPI_CALL locked_queue_submit(VkQueue queue, uint32_t count,
                                                   const VkSubmitInfo* submits, VkFence fence) {
    std::lock_guard<std::mutex> lock(*g_lent_queue_mutex);
    return vkQueueSubmit(queue, count, submits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL locked_queue_wait_idle(VkQueue queue) {
    std::lock_guard<std::mutex> lock(*g_lent_queue_mutex);
    return vkQueueWaitIdle(queue);
}

PFN_vkVoidFunction queue_entry_point(const char* name) {
    if (std::strcmp(name, "vkQueueSubmit") == 0)
        return reinterpret_cast<PFN_vkVoidFunction>(&locked_queue_submit);
    if (std::strcmp(name, "vkQueueWaitIdle") == 0)
        return reinterpret_cast<PFN_vkVoidFunction>(&locked_queue_wait_idle);
    return nullptr;
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL lent_get_device_proc_addr(VkDevice device,
                                                                   const char* name) {
    if (PFN_vkVoidFunction f = queue_entry_point(name)) return f;
    return vkGetDeviceProcAddr(device, name);
}

// What libnfdecode resolves every entry point through (nfd_vulkan_device.get_instance_proc_addr):
// the loader's, except the queue functions and vkGetDeviceProcAddr, which lead to the wrappers.
VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL lent_get_instance_proc_addr(VkInstance instance,
                                                                     const char* name) {
    if (PFN_vkVoidFunction f = queue_entry_point(name)) return f;
    if (std::strcmp(name, "vkGetDeviceProcAddr") == 0)
        return reinterpret_cast<PFN_vkVoidFunction>(&lent_get_device_proc_addr);
    return vkGetInstanceProcAddr(instance, name);
}

}  // namespace

void vk_check(VkResult result, const char* what) {
    if (result != VK_SUCCESS)
        throw std::runtime_error(std::string(what) + " failed (VkResult " +
                                 std::to_string(int(result)) + ")");
}

VkDeviceContext::VkDeviceContext(int width, int height, const char* title) {
    if (!glfwInit())
        throw std::runtime_error("cannot open a window: no display (headless: run under xvfb-run -a)");
    if (!glfwVulkanSupported()) throw std::runtime_error("no Vulkan loader or driver for a window");
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    window_ = glfwCreateWindow(width, height, title, nullptr, nullptr);
    if (!window_) throw std::runtime_error("cannot create a window");

    uint32_t extension_count = 0;
    const char** extensions = glfwGetRequiredInstanceExtensions(&extension_count);
    if (!extensions) throw std::runtime_error("no Vulkan surface extensions for this display");
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "nfc-viewer";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    info.pApplicationInfo = &app;
    info.enabledExtensionCount = extension_count;
    info.ppEnabledExtensionNames = extensions;
    vk_check(vkCreateInstance(&info, nullptr, &instance_), "vkCreateInstance");
    vk_check(glfwCreateWindowSurface(instance_, window_, nullptr, &surface_),
             "glfwCreateWindowSurface");

    // The first device (discrete before the rest) with a queue family that draws, computes
    // (libnfdecode's kernels) and presents to the window.
    uint32_t count = 0;
    vkEnumeratePhysicalDevices(instance_, &count, nullptr);
    std::vector<VkPhysicalDevice> devices(count);
    vkEnumeratePhysicalDevices(instance_, &count, devices.data());
    int best_rank = -1;
    for (VkPhysicalDevice candidate : devices) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(candidate, &p);
        if (p.apiVersion < VK_API_VERSION_1_1) continue;
        const int rank = p.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU     ? 3
                         : p.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ? 2
                         : p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU            ? 0
                                                                                  : 1;
        uint32_t families = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(candidate, &families, nullptr);
        std::vector<VkQueueFamilyProperties> props(families);
        vkGetPhysicalDeviceQueueFamilyProperties(candidate, &families, props.data());
        for (uint32_t i = 0; i < families; ++i) {
            VkBool32 present = VK_FALSE;
            vkGetPhysicalDeviceSurfaceSupportKHR(candidate, i, surface_, &present);
            const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
            if (present && (props[i].queueFlags & need) == need && rank > best_rank) {
                best_rank = rank, physical_ = candidate, family_ = i;
                break;
            }
        }
    }
    if (!physical_) throw std::runtime_error("no Vulkan device draws, computes and presents here");
    vkGetPhysicalDeviceProperties(physical_, &properties_);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
    VkPhysicalDeviceFeatures supported{}, enabled{};
    vkGetPhysicalDeviceFeatures(physical_, &supported);
    wireframe_ = supported.fillModeNonSolid == VK_TRUE;
    enabled.fillModeNonSolid = supported.fillModeNonSolid;

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue_info{};
    queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue_info.queueFamilyIndex = family_;
    queue_info.queueCount = 1;
    queue_info.pQueuePriorities = &priority;
    const char* swapchain = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    VkDeviceCreateInfo device_info{};
    device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    device_info.queueCreateInfoCount = 1;
    device_info.pQueueCreateInfos = &queue_info;
    device_info.enabledExtensionCount = 1;
    device_info.ppEnabledExtensionNames = &swapchain;
    device_info.pEnabledFeatures = &enabled;
    vk_check(vkCreateDevice(physical_, &device_info, nullptr, &device_), "vkCreateDevice");
    vkGetDeviceQueue(device_, family_, 0, &queue_);
}

VkDeviceContext::~VkDeviceContext() {
    if (g_lent_queue_mutex == &queue_mutex_) g_lent_queue_mutex = nullptr;
    if (device_) vkDestroyDevice(device_, nullptr);
    if (surface_) vkDestroySurfaceKHR(instance_, surface_, nullptr);
    if (instance_) vkDestroyInstance(instance_, nullptr);
    if (window_) glfwDestroyWindow(window_);
    glfwTerminate();
}

uint32_t VkDeviceContext::memory_type(uint32_t type_bits, VkMemoryPropertyFlags flags) const {
    for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & flags) == flags)
            return i;
    throw std::runtime_error("no Vulkan memory type with the flags the viewer needs");
}

void VkDeviceContext::create_host_buffer(VkDeviceSize size, VkBufferUsageFlags usage,
                                         VkBuffer* buffer, VkDeviceMemory* memory) const {
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    vk_check(vkCreateBuffer(device_, &info, nullptr, buffer), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device_, *buffer, &req);
    *memory = allocate(req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    vk_check(vkBindBufferMemory(device_, *buffer, *memory, 0), "vkBindBufferMemory");
}

VkDeviceMemory VkDeviceContext::allocate(const VkMemoryRequirements& req,
                                         VkMemoryPropertyFlags flags) const {
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = memory_type(req.memoryTypeBits, flags);
    VkDeviceMemory memory;
    vk_check(vkAllocateMemory(device_, &alloc, nullptr, &memory), "vkAllocateMemory");
    return memory;
}

VkCommandPool VkDeviceContext::create_command_pool(VkCommandPoolCreateFlags flags) const {
    VkCommandPoolCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    info.flags = flags;
    info.queueFamilyIndex = family_;
    VkCommandPool pool;
    vk_check(vkCreateCommandPool(device_, &info, nullptr, &pool), "vkCreateCommandPool");
    return pool;
}

VkCommandBuffer VkDeviceContext::allocate_command_buffer(VkCommandPool pool) const {
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd;
    vk_check(vkAllocateCommandBuffers(device_, &alloc, &cmd), "vkAllocateCommandBuffers");
    return cmd;
}

nfd_vulkan_device VkDeviceContext::lend() {
    g_lent_queue_mutex = &queue_mutex_;
    nfd_vulkan_device d{};
    d.instance = instance_;
    d.physical_device = physical_;
    d.device = device_;
    d.queue = queue_;
    d.queue_family_index = family_;
    d.get_instance_proc_addr = reinterpret_cast<void*>(&lent_get_instance_proc_addr);
    return d;
}

void VkDeviceContext::submit_and_wait(VkCommandBuffer cmd) {
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence;
    vk_check(vkCreateFence(device_, &fence_info, nullptr, &fence), "vkCreateFence");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    VkResult r;
    {
        auto lock = lock_queue();
        r = vkQueueSubmit(queue_, 1, &submit, fence);
    }
    if (r == VK_SUCCESS) r = vkWaitForFences(device_, 1, &fence, VK_TRUE, UINT64_MAX);
    vkDestroyFence(device_, fence, nullptr);
    vk_check(r, "vkQueueSubmit (one-off)");
}

}  // namespace nfc_viewer
