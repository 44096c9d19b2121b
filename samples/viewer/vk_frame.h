// Frames: the viewer draws into an image of its own (RGBA8 + depth, one render pass), then blits
// it to the swapchain image it presents, and, for a screenshot, copies it to host memory. Drawing
// off-swapchain makes the screenshot independent of the swapchain's format and usage flags.
// Two frames in flight; each frame slot runs the work retired into it (buffers of a replaced
// mesh) once its fence shows the GPU is done with them.
#pragma once

#include <functional>
#include <vector>

#include "vk_device.h"

namespace nfc_viewer {

class FrameTarget {
public:
    static constexpr uint32_t kFramesInFlight = 2;

    FrameTarget(VkDeviceContext* vk, int width, int height);
    ~FrameTarget();
    FrameTarget(const FrameTarget&) = delete;
    FrameTarget& operator=(const FrameTarget&) = delete;

    VkRenderPass render_pass() const { return render_pass_; }
    VkExtent2D extent() const { return extent_; }
    uint32_t swapchain_image_count() const { return uint32_t(swapchain_images_.size()); }

    // Waits for this slot's previous frame (its fence), runs what was retired into it, acquires
    // a swapchain image and begins the render pass (cleared to kBackground). Returns the command
    // buffer to record the frame's draws into.
    VkCommandBuffer begin_frame();
    // Ends the render pass, blits to the swapchain image, copies the image to host memory if
    // `readback`, submits and presents.
    void end_frame(bool readback);
    // After end_frame(true): waits for that frame and returns its pixels, RGBA8, rows top first.
    std::vector<unsigned char> read_pixels();
    // Runs `release` once the GPU has finished the frame being recorded (or at destruction).
    void retire(std::function<void()> release);
    void wait_idle();
    // Between frames: waits for every frame and runs everything retired (before what it frees
    // depends on goes, e.g. the context of a retired recording).
    void drain();

private:
    struct Slot {
        VkCommandBuffer cmd = VK_NULL_HANDLE;
        VkFence fence = VK_NULL_HANDLE;
        VkSemaphore image_available = VK_NULL_HANDLE;
        std::vector<std::function<void()>> retired;
    };
    void create_sized();   // swapchain, offscreen images, framebuffer, readback buffer
    void destroy_sized();
    void recreate();       // the window's framebuffer changed size or the swapchain is out of date
    void create_image(VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect,
                      VkImage* image, VkDeviceMemory* memory, VkImageView* view);
    void run_retired(Slot* slot);

    VkDeviceContext* vk_;
    VkExtent2D extent_{};
    VkRenderPass render_pass_ = VK_NULL_HANDLE;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    Slot slots_[kFramesInFlight];
    uint32_t slot_ = 0;
    bool recording_ = false;  // slot_'s frame has begun and is not submitted (its fence unsignalled)
    uint32_t image_index_ = 0;

    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    VkFormat swapchain_format_ = VK_FORMAT_UNDEFINED;
    std::vector<VkImage> swapchain_images_;
    std::vector<VkSemaphore> render_finished_;  // per swapchain image
    VkImage color_ = VK_NULL_HANDLE, depth_ = VK_NULL_HANDLE;
    VkDeviceMemory color_memory_ = VK_NULL_HANDLE, depth_memory_ = VK_NULL_HANDLE;
    VkImageView color_view_ = VK_NULL_HANDLE, depth_view_ = VK_NULL_HANDLE;
    VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
    VkBuffer readback_ = VK_NULL_HANDLE;
    VkDeviceMemory readback_memory_ = VK_NULL_HANDLE;
    int readback_slot_ = -1;  // the slot whose frame copied into readback_
};

}  // namespace nfc_viewer
