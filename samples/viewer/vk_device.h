// The viewer's window and Vulkan device: one instance, one device with one graphics + compute
// queue that also presents, lent to libnfdecode (nfd_context_options.adopt) when it decodes on
// Vulkan.
#pragma once

#include <nfdecode/nfdecode.h>
#include <vulkan/vulkan.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <mutex>
#include <string>

namespace nfc_viewer {

// Throws std::runtime_error("what: VkResult") when a Vulkan call fails; main turns it into one line.
void vk_check(VkResult result, const char* what);

class VkDeviceContext {
public:
    // Opens a width x height window (GLFW, no client API) and creates the instance, surface and
    // device. Throws std::runtime_error with a one-line reason (no display, no Vulkan device).
    VkDeviceContext(int width, int height, const char* title);
    ~VkDeviceContext();
    VkDeviceContext(const VkDeviceContext&) = delete;
    VkDeviceContext& operator=(const VkDeviceContext&) = delete;

    GLFWwindow* window() const { return window_; }
    VkInstance instance() const { return instance_; }
    VkPhysicalDevice physical() const { return physical_; }
    VkDevice device() const { return device_; }
    VkSurfaceKHR surface() const { return surface_; }
    VkQueue queue() const { return queue_; }
    uint32_t family() const { return family_; }
    const VkPhysicalDeviceProperties& properties() const { return properties_; }
    bool wireframe_supported() const { return wireframe_; }
    // A CPU implementation (lavapipe): rendering and compute share the host's cores.
    bool is_cpu_device() const { return properties_.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; }

    // A memory type among `type_bits` with all of `flags`; throws if none.
    uint32_t memory_type(uint32_t type_bits, VkMemoryPropertyFlags flags) const;
    // Memory for `req` of a type with all of `flags`; throws if none or if it cannot be had.
    VkDeviceMemory allocate(const VkMemoryRequirements& req, VkMemoryPropertyFlags flags) const;
    // A buffer with its own host-visible, coherent memory.
    void create_host_buffer(VkDeviceSize size, VkBufferUsageFlags usage, VkBuffer* buffer,
                            VkDeviceMemory* memory) const;

    // The device has one queue here (lavapipe has a single queue family of one queue), used by
    // the render thread and, when libnfdecode adopts the device, by the decode queue's worker.
    // Vulkan requires external synchronisation of vkQueueSubmit / vkQueuePresentKHR /
    // vkQueueWaitIdle on one queue: the viewer takes this lock around its own calls, and the
    // device it lends to libnfdecode resolves those entry points to wrappers taking it too.
    std::unique_lock<std::mutex> lock_queue() { return std::unique_lock<std::mutex>(queue_mutex_); }
    // The device as libnfdecode adopts it (valid while this object lives).
    nfd_vulkan_device lend();

    // A command pool of the queue's family, and a primary command buffer of it.
    VkCommandPool create_command_pool(VkCommandPoolCreateFlags flags) const;
    VkCommandBuffer allocate_command_buffer(VkCommandPool pool) const;

    // Submits and waits: one-off work (font upload, screenshot readback) outside the frame loop.
    void submit_and_wait(VkCommandBuffer cmd);

private:
    GLFWwindow* window_ = nullptr;
    VkInstance instance_ = VK_NULL_HANDLE;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    uint32_t family_ = 0;
    VkPhysicalDeviceProperties properties_{};
    VkPhysicalDeviceMemoryProperties memory_{};
    bool wireframe_ = false;
    std::mutex queue_mutex_;
};

}  // namespace nfc_viewer
