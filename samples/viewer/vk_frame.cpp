#include "vk_frame.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "scene.h"

namespace nfc_viewer {
namespace {

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                   VkAccessFlags src_access, VkAccessFlags dst_access,
                   VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage) {
    VkImageMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = src_access;
    b.dstAccessMask = dst_access;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

VkRenderPass create_render_pass(VkDevice device) {
    VkAttachmentDescription attachments[2]{};
    attachments[0].format = kColorFormat;
    attachments[0].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[0].finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    attachments[1] = attachments[0];
    attachments[1].format = kDepthFormat;
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    VkAttachmentReference color_ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference depth_ref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &color_ref;
    subpass.pDepthStencilAttachment = &depth_ref;
    // In: the previous frame's blit/copy read the colour image, its depth test wrote depth.
    // Out: this frame's blit/copy read what the subpass wrote.
    VkSubpassDependency deps[2]{};
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                           VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
    deps[0].srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT;
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.attachmentCount = 2;
    info.pAttachments = attachments;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = deps;
    VkRenderPass pass;
    vk_check(vkCreateRenderPass(device, &info, nullptr, &pass), "vkCreateRenderPass");
    return pass;
}

}  // namespace

FrameTarget::FrameTarget(VkDeviceContext* vk, int width, int height) : vk_(vk) {
    extent_ = {uint32_t(width), uint32_t(height)};
    const VkDevice device = vk_->device();
    render_pass_ = create_render_pass(device);
    pool_ = vk_->create_command_pool(VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT);
    for (Slot& s : slots_) {
        s.cmd = vk_->allocate_command_buffer(pool_);
        VkFenceCreateInfo fence{};
        fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fence.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        vk_check(vkCreateFence(device, &fence, nullptr, &s.fence), "vkCreateFence");
        VkSemaphoreCreateInfo sem{};
        sem.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        vk_check(vkCreateSemaphore(device, &sem, nullptr, &s.image_available), "vkCreateSemaphore");
    }
    create_sized();
}

FrameTarget::~FrameTarget() {
    wait_idle();
    const VkDevice device = vk_->device();
    for (Slot& s : slots_) {
        run_retired(&s);
        vkDestroySemaphore(device, s.image_available, nullptr);
        vkDestroyFence(device, s.fence, nullptr);
    }
    destroy_sized();
    vkDestroyCommandPool(device, pool_, nullptr);
    vkDestroyRenderPass(device, render_pass_, nullptr);
}

void FrameTarget::wait_idle() {
    for (uint32_t i = 0; i < kFramesInFlight; ++i)
        if (!(recording_ && i == slot_))  // a frame begun and not submitted (a throw) never signals
            vkWaitForFences(vk_->device(), 1, &slots_[i].fence, VK_TRUE, UINT64_MAX);
}

void FrameTarget::drain() {
    wait_idle();
    for (Slot& s : slots_) run_retired(&s);
}

void FrameTarget::run_retired(Slot* slot) {
    for (auto& release : slot->retired) release();
    slot->retired.clear();
}

void FrameTarget::retire(std::function<void()> release) {
    slots_[slot_].retired.push_back(std::move(release));
}

void FrameTarget::create_image(VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect,
                               VkImage* image, VkDeviceMemory* memory, VkImageView* view) {
    const VkDevice device = vk_->device();
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {extent_.width, extent_.height, 1};
    info.mipLevels = info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    vk_check(vkCreateImage(device, &info, nullptr, image), "vkCreateImage");
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device, *image, &req);
    *memory = vk_->allocate(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    vk_check(vkBindImageMemory(device, *image, *memory, 0), "vkBindImageMemory");
    VkImageViewCreateInfo v{};
    v.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    v.image = *image;
    v.viewType = VK_IMAGE_VIEW_TYPE_2D;
    v.format = format;
    v.subresourceRange = {aspect, 0, 1, 0, 1};
    vk_check(vkCreateImageView(device, &v, nullptr, view), "vkCreateImageView");
}

void FrameTarget::create_sized() {
    const VkDevice device = vk_->device();
    VkSurfaceCapabilitiesKHR caps;
    vk_check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(vk_->physical(), vk_->surface(), &caps),
             "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
    if (caps.currentExtent.width != UINT32_MAX) extent_ = caps.currentExtent;
    extent_.width = std::clamp(extent_.width, std::max(1u, caps.minImageExtent.width),
                               caps.maxImageExtent.width);
    extent_.height = std::clamp(extent_.height, std::max(1u, caps.minImageExtent.height),
                                caps.maxImageExtent.height);
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
        throw std::runtime_error("the swapchain cannot be a transfer destination");
    uint32_t count = 0;
    vkGetPhysicalDeviceSurfaceFormatsKHR(vk_->physical(), vk_->surface(), &count, nullptr);
    std::vector<VkSurfaceFormatKHR> formats(count);
    vkGetPhysicalDeviceSurfaceFormatsKHR(vk_->physical(), vk_->surface(), &count, formats.data());
    if (formats.empty()) throw std::runtime_error("the window has no surface format");
    VkSurfaceFormatKHR chosen = formats[0];
    for (const VkSurfaceFormatKHR& f : formats)  // UNORM: the blit copies our values unchanged
        if (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) chosen = f;
    swapchain_format_ = chosen.format;
    // Mailbox or immediate when there is one: the frame loop paces itself (--fps), and a
    // blocking FIFO present would hide the frame's own time.
    vkGetPhysicalDeviceSurfacePresentModesKHR(vk_->physical(), vk_->surface(), &count, nullptr);
    std::vector<VkPresentModeKHR> modes(count);
    vkGetPhysicalDeviceSurfacePresentModesKHR(vk_->physical(), vk_->surface(), &count, modes.data());
    VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
    for (VkPresentModeKHR m : modes)
        if (m == VK_PRESENT_MODE_MAILBOX_KHR ||
            (m == VK_PRESENT_MODE_IMMEDIATE_KHR && mode == VK_PRESENT_MODE_FIFO_KHR))
            mode = m;
    VkSwapchainCreateInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
    info.surface = vk_->surface();
    info.minImageCount = std::max(caps.minImageCount, 2u);
    if (caps.maxImageCount) info.minImageCount = std::min(info.minImageCount, caps.maxImageCount);
    info.imageFormat = chosen.format;
    info.imageColorSpace = chosen.colorSpace;
    info.imageExtent = extent_;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    info.presentMode = mode;
    info.clipped = VK_TRUE;
    vk_check(vkCreateSwapchainKHR(device, &info, nullptr, &swapchain_), "vkCreateSwapchainKHR");
    vkGetSwapchainImagesKHR(device, swapchain_, &count, nullptr);
    swapchain_images_.resize(count);
    vkGetSwapchainImagesKHR(device, swapchain_, &count, swapchain_images_.data());
    render_finished_.resize(count);
    for (VkSemaphore& s : render_finished_) {
        VkSemaphoreCreateInfo sem{};
        sem.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        vk_check(vkCreateSemaphore(device, &sem, nullptr, &s), "vkCreateSemaphore");
    }

    create_image(kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                 VK_IMAGE_ASPECT_COLOR_BIT, &color_, &color_memory_, &color_view_);
    create_image(kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                 VK_IMAGE_ASPECT_DEPTH_BIT, &depth_, &depth_memory_, &depth_view_);
    VkImageView views[2] = {color_view_, depth_view_};
    VkFramebufferCreateInfo fb{};
    fb.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    fb.renderPass = render_pass_;
    fb.attachmentCount = 2;
    fb.pAttachments = views;
    fb.width = extent_.width;
    fb.height = extent_.height;
    fb.layers = 1;
    vk_check(vkCreateFramebuffer(device, &fb, nullptr, &framebuffer_), "vkCreateFramebuffer");
    vk_->create_host_buffer(VkDeviceSize(extent_.width) * extent_.height * 4,
                            VK_BUFFER_USAGE_TRANSFER_DST_BIT, &readback_, &readback_memory_);
}

void FrameTarget::destroy_sized() {
    const VkDevice device = vk_->device();
    vkDestroyBuffer(device, readback_, nullptr);
    vkFreeMemory(device, readback_memory_, nullptr);
    vkDestroyFramebuffer(device, framebuffer_, nullptr);
    vkDestroyImageView(device, color_view_, nullptr);
    vkDestroyImageView(device, depth_view_, nullptr);
    vkDestroyImage(device, color_, nullptr);
    vkDestroyImage(device, depth_, nullptr);
    vkFreeMemory(device, color_memory_, nullptr);
    vkFreeMemory(device, depth_memory_, nullptr);
    for (VkSemaphore s : render_finished_) vkDestroySemaphore(device, s, nullptr);
    render_finished_.clear();
    vkDestroySwapchainKHR(device, swapchain_, nullptr);
    readback_slot_ = -1;
}

void FrameTarget::recreate() {
    int w = 0, h = 0;
    glfwGetFramebufferSize(vk_->window(), &w, &h);
    while ((w == 0 || h == 0) && !glfwWindowShouldClose(vk_->window())) {  // minimised
        glfwWaitEvents();
        glfwGetFramebufferSize(vk_->window(), &w, &h);
    }
    wait_idle();
    destroy_sized();
    extent_ = {uint32_t(std::max(w, 1)), uint32_t(std::max(h, 1))};
    create_sized();
}

VkCommandBuffer FrameTarget::begin_frame() {
    const VkDevice device = vk_->device();
    Slot& s = slots_[slot_];
    vk_check(vkWaitForFences(device, 1, &s.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    run_retired(&s);
    for (;;) {
        const VkResult r = vkAcquireNextImageKHR(device, swapchain_, UINT64_MAX, s.image_available,
                                                 VK_NULL_HANDLE, &image_index_);
        if (r == VK_SUCCESS || r == VK_SUBOPTIMAL_KHR) break;
        if (r != VK_ERROR_OUT_OF_DATE_KHR) vk_check(r, "vkAcquireNextImageKHR");
        recreate();
    }
    vk_check(vkResetFences(device, 1, &s.fence), "vkResetFences");
    recording_ = true;
    vk_check(vkResetCommandBuffer(s.cmd, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vk_check(vkBeginCommandBuffer(s.cmd, &begin), "vkBeginCommandBuffer");
    VkClearValue clear[2]{};
    clear[0].color = {{kBackground[0], kBackground[1], kBackground[2], 1.0f}};
    clear[1].depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo rp{};
    rp.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    rp.renderPass = render_pass_;
    rp.framebuffer = framebuffer_;
    rp.renderArea = {{0, 0}, extent_};
    rp.clearValueCount = 2;
    rp.pClearValues = clear;
    vkCmdBeginRenderPass(s.cmd, &rp, VK_SUBPASS_CONTENTS_INLINE);
    return s.cmd;
}

void FrameTarget::end_frame(bool readback) {
    Slot& s = slots_[slot_];
    VkCommandBuffer cmd = s.cmd;
    vkCmdEndRenderPass(cmd);  // colour image now TRANSFER_SRC_OPTIMAL
    const VkImage target = swapchain_images_[image_index_];
    image_barrier(cmd, target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                  VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkImageBlit blit{};
    blit.srcSubresource = blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = blit.dstOffsets[1] = {int32_t(extent_.width), int32_t(extent_.height), 1};
    vkCmdBlitImage(cmd, color_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_NEAREST);
    image_barrier(cmd, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_ACCESS_TRANSFER_WRITE_BIT, 0,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
    if (readback) {
        VkBufferImageCopy copy{};
        copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.imageExtent = {extent_.width, extent_.height, 1};
        vkCmdCopyImageToBuffer(cmd, color_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_, 1, &copy);
        readback_slot_ = int(slot_);
    }
    vk_check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");

    const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &s.image_available;
    submit.pWaitDstStageMask = &wait_stage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &render_finished_[image_index_];
    VkPresentInfoKHR present{};
    present.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &render_finished_[image_index_];
    present.swapchainCount = 1;
    present.pSwapchains = &swapchain_;
    present.pImageIndices = &image_index_;
    VkResult presented;
    {
        auto lock = vk_->lock_queue();
        vk_check(vkQueueSubmit(vk_->queue(), 1, &submit, s.fence), "vkQueueSubmit");
        recording_ = false;
        presented = vkQueuePresentKHR(vk_->queue(), &present);
    }
    slot_ = (slot_ + 1) % kFramesInFlight;
    int w = 0, h = 0;
    glfwGetFramebufferSize(vk_->window(), &w, &h);
    const bool resized = uint32_t(w) != extent_.width || uint32_t(h) != extent_.height;
    const bool stale =
        presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR || resized;
    if (!stale) vk_check(presented, "vkQueuePresentKHR");
    // A screenshot frame keeps its readback buffer (recreate() replaces it): the next one resizes.
    else if (!readback) recreate();
}

std::vector<unsigned char> FrameTarget::read_pixels() {
    if (readback_slot_ < 0) throw std::runtime_error("no frame was read back");
    const VkDevice device = vk_->device();
    vk_check(vkWaitForFences(device, 1, &slots_[readback_slot_].fence, VK_TRUE, UINT64_MAX),
             "vkWaitForFences");
    const size_t size = size_t(extent_.width) * extent_.height * 4;
    std::vector<unsigned char> pixels(size);
    void* mapped = nullptr;
    vk_check(vkMapMemory(device, readback_memory_, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    std::memcpy(pixels.data(), mapped, size);
    vkUnmapMemory(device, readback_memory_);
    return pixels;
}

}  // namespace nfc_viewer
