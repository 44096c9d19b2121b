#include "recorded_final.h"

#include <chrono>

namespace nfc_viewer {

RecordedFinals::RecordedFinals(VkDeviceContext* vk, nfd_context* context, uint32_t resolution,
                               uint32_t first_capacity, size_t assets)
    : vk_(vk), context_(context), resolution_(resolution) {
    nfd_recording_options first = {};
    first.struct_size = sizeof first;
    first.resolution = resolution;
    first.max_cells = first.max_gradient_points = first.max_vertices = first.max_triangles =
        first_capacity;
    next_.assign(assets, first);
    // A pool of the family libnfdecode adopted; the buffer is reset for each recording.
    pool_ = vk_->create_command_pool(VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT);
    cmd_ = vk_->allocate_command_buffer(pool_);
    VkFenceCreateInfo fence{};
    fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    vk_check(vkCreateFence(vk_->device(), &fence, nullptr, &fence_), "vkCreateFence");
}

RecordedFinals::~RecordedFinals() {
    const VkDevice device = vk_->device();
    if (recording_) {
        vkWaitForFences(device, 1, &fence_, VK_TRUE, UINT64_MAX);
        nfd_recording_destroy(recording_);
    }
    vkDestroyFence(device, fence_, nullptr);
    vkDestroyCommandPool(device, pool_, nullptr);
}

void RecordedFinals::update(const std::vector<StreamedAsset*>& streamed,
                            std::vector<AssetView>* views, FrameTarget* frames, double now_s) {
    if (recording_) {
        const VkResult status = vkGetFenceStatus(vk_->device(), fence_);
        if (status == VK_NOT_READY) return;
        vk_check(status, "vkGetFenceStatus");
        collect(&(*views)[asset_], frames, now_s);
    }
    for (size_t i = 0; i < views->size() && !recording_; ++i) {
        AssetView& view = (*views)[i];
        if (view.awaits_recording && view.queue_done && !view.failed())
            start(i, streamed[i]->asset, &view);
    }
}

void RecordedFinals::start(size_t index, const nfd_asset* asset, AssetView* view) {
    const auto started = std::chrono::steady_clock::now();
    nfd_recording* recording = nullptr;
    nfd_result r = nfd_recording_create(context_, asset, &next_[index], &recording);
    if (r == NFD_SUCCESS) {
        VkCommandBufferBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        vk_check(vkBeginCommandBuffer(cmd_, &begin), "vkBeginCommandBuffer");  // resets it
        r = nfd_recording_record(recording, cmd_);
        vk_check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
        if (r != NFD_SUCCESS) nfd_recording_destroy(recording);  // part of a decode: not submitted
    }
    if (r != NFD_SUCCESS) {
        view->error = std::string("recording: ") + nfd_result_string(r);
        return;
    }
    vk_check(vkResetFences(vk_->device(), 1, &fence_), "vkResetFences");
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd_;
    VkResult submitted;
    {
        auto lock = vk_->lock_queue();
        submitted = vkQueueSubmit(vk_->queue(), 1, &submit, fence_);
    }
    if (submitted != VK_SUCCESS) nfd_recording_destroy(recording);  // nothing of it runs
    vk_check(submitted, "vkQueueSubmit (recording)");
    recording_ = recording;
    asset_ = index;
    started_ = started;
    ++view->recording_tries;
}

void RecordedFinals::collect(AssetView* view, FrameTarget* frames, double now_s) {
    nfd_recording_result result = {};
    result.struct_size = sizeof result;
    const nfd_result r = nfd_recording_finish(recording_, &result);
    nfd_recording* recording = recording_;
    recording_ = nullptr;
    if (r == NFD_SUCCESS && !view->failed()) {
        LevelRecord level;
        level.resolution = resolution_;
        level.triangles = result.triangle_count;
        level.decode_ms = std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - started_).count();
        level.shown_s = now_s;
        show_level(view, wrap_recording(recording, result), level, vk_->device(), frames);
        view->awaits_recording = false;
        return;
    }
    nfd_recording_destroy(recording);  // never drawn, and its commands have completed
    if (view->failed()) return;        // the stream failed meanwhile
    if (r == NFD_ERROR_CAPACITY_EXCEEDED && view->recording_tries < kMaxTries) {
        nfd_recording_options& next = next_[asset_];
        next.max_cells = result.needed_cells;
        next.max_gradient_points = result.needed_gradient_points;
        next.max_vertices = result.needed_vertices;
        next.max_triangles = result.needed_triangles;
        return;  // recorded again by a later update()
    }
    view->error = std::string("recording: ") + nfd_result_string(r) + " after " +
                  std::to_string(view->recording_tries) + " tries";
}

}  // namespace nfc_viewer
