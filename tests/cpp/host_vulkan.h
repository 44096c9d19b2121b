// A host engine's Vulkan objects for the tests and benches that play one (test_adopt.cpp,
// test_record.cpp, bench/recording.cpp): an instance and a device with one queue of a
// compute-capable family, made with the loader, lent to libnfdecode through nfd_vulkan_device, and
// host-visible buffers for the host's own copies.
#pragma once
#include <vulkan/vulkan.h>

#include <string>
#include <vector>

#include "nfdecode/nfdecode.h"

namespace nfd::test {

// What an engine owns: an instance, a device with one queue of a compute-capable family.
struct HostVulkan {
    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    uint32_t family = 0;
    uint32_t family_count = 0;

    // Empty string on success, else why there is no device.
    std::string create() {
        VkApplicationInfo app{};
        app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
        app.pApplicationName = "nfdecode adopt test";
        app.apiVersion = VK_API_VERSION_1_1;
        VkInstanceCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
        info.pApplicationInfo = &app;
        if (vkCreateInstance(&info, nullptr, &instance) != VK_SUCCESS)
            return "vkCreateInstance failed";
        uint32_t count = 0;
        vkEnumeratePhysicalDevices(instance, &count, nullptr);
        std::vector<VkPhysicalDevice> devices(count);
        vkEnumeratePhysicalDevices(instance, &count, devices.data());
        devices.resize(count);
        for (VkPhysicalDevice candidate : devices) {
            VkPhysicalDeviceProperties properties;
            vkGetPhysicalDeviceProperties(candidate, &properties);
            if (properties.apiVersion < VK_API_VERSION_1_1) continue;
            uint32_t families = 0;
            vkGetPhysicalDeviceQueueFamilyProperties(candidate, &families, nullptr);
            std::vector<VkQueueFamilyProperties> props(families);
            vkGetPhysicalDeviceQueueFamilyProperties(candidate, &families, props.data());
            for (uint32_t i = 0; i < families && !physical; ++i)
                if (props[i].queueFlags & VK_QUEUE_COMPUTE_BIT) physical = candidate, family = i;
            if (physical) {
                family_count = families;
                break;
            }
        }
        if (!physical) return "no Vulkan 1.1 device with a compute queue";
        const float priority = 1.0f;
        VkDeviceQueueCreateInfo queue_info{};
        queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        queue_info.queueFamilyIndex = family;
        queue_info.queueCount = 1;
        queue_info.pQueuePriorities = &priority;
        VkDeviceCreateInfo device_info{};
        device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        device_info.queueCreateInfoCount = 1;
        device_info.pQueueCreateInfos = &queue_info;
        if (vkCreateDevice(physical, &device_info, nullptr, &device) != VK_SUCCESS)
            return "vkCreateDevice failed";
        vkGetDeviceQueue(device, family, 0, &queue);
        return "";
    }

    ~HostVulkan() {
        if (device) vkDestroyDevice(device, nullptr);
        if (instance) vkDestroyInstance(instance, nullptr);
    }

    // A buffer in host-visible memory the host maps, for copies of the library's buffers.
    struct HostBuffer {
        VkBuffer buffer = VK_NULL_HANDLE;
        VkDeviceMemory memory = VK_NULL_HANDLE;
        void* data = nullptr;
    };
    bool make_host_buffer(VkDeviceSize size, HostBuffer* out) const {
        VkBufferCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        info.size = size;
        info.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        if (vkCreateBuffer(device, &info, nullptr, &out->buffer) != VK_SUCCESS) return false;
        VkMemoryRequirements req;
        vkGetBufferMemoryRequirements(device, out->buffer, &req);
        VkPhysicalDeviceMemoryProperties memory;
        vkGetPhysicalDeviceMemoryProperties(physical, &memory);
        const VkMemoryPropertyFlags need =
            VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        for (uint32_t i = 0; i < memory.memoryTypeCount; ++i) {
            if (!(req.memoryTypeBits >> i & 1) ||
                (memory.memoryTypes[i].propertyFlags & need) != need)
                continue;
            VkMemoryAllocateInfo alloc{};
            alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
            alloc.allocationSize = req.size;
            alloc.memoryTypeIndex = i;
            return vkAllocateMemory(device, &alloc, nullptr, &out->memory) == VK_SUCCESS &&
                   vkBindBufferMemory(device, out->buffer, out->memory, 0) == VK_SUCCESS &&
                   vkMapMemory(device, out->memory, 0, VK_WHOLE_SIZE, 0, &out->data) == VK_SUCCESS;
        }
        return false;
    }
    void destroy(HostBuffer& b) const {
        if (b.buffer) vkDestroyBuffer(device, b.buffer, nullptr);
        if (b.memory) vkFreeMemory(device, b.memory, nullptr);
        b = HostBuffer{};
    }

    // A primary command buffer of `pool`, begun for one submission (VK_NULL_HANDLE on failure).
    VkCommandBuffer begin_commands(VkCommandPool pool) const {
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        VkCommandBuffer commands = VK_NULL_HANDLE;
        if (vkAllocateCommandBuffers(device, &alloc, &commands) != VK_SUCCESS) return VK_NULL_HANDLE;
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        vkBeginCommandBuffer(commands, &begin);
        return commands;
    }
    // Ends `commands`, submits them on the queue and waits for them; false on any failure.
    bool submit_and_wait(VkCommandBuffer commands) const {
        if (vkEndCommandBuffer(commands) != VK_SUCCESS) return false;
        VkFenceCreateInfo fence_info{};
        fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VkFence fence = VK_NULL_HANDLE;
        if (vkCreateFence(device, &fence_info, nullptr, &fence) != VK_SUCCESS) return false;
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &commands;
        const bool ok = vkQueueSubmit(queue, 1, &submit, fence) == VK_SUCCESS &&
                        vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX) == VK_SUCCESS;
        vkDestroyFence(device, fence, nullptr);
        return ok;
    }

    nfd_vulkan_device lend() const {
        nfd_vulkan_device d{};
        d.instance = instance;
        d.physical_device = physical;
        d.device = device;
        d.queue = queue;
        d.queue_family_index = family;
        return d;
    }
};

}  // namespace nfd::test
