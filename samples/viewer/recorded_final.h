// The final level of each asset, decoded on the viewer's own device into a command buffer of the
// viewer's (nfd_recording) and drawn where the decode left it, when libnfdecode decodes on that
// device (--decode-device vulkan; auto on a GPU). The coarser levels still come from the queue
// (Streamer, refresh_asset); once an asset's last of them is shown, its final level is recorded
// into a command buffer of this object's (not the frame's), submitted on the viewer's queue under
// its queue lock with a fence that the frame loop polls without waiting. One recording is in
// flight at a time: on lavapipe's single queue every frame waits behind it.
//
// When the fence has signalled, nfd_recording_finish says whether the capacities sufficed. If so
// the recording becomes the asset's GpuMesh (wrap_recording: zero copy, an indirect draw) and
// lives until the mesh is destroyed; the replaced coarser mesh is retired into the frames. On
// NFD_ERROR_CAPACITY_EXCEEDED the recording (never drawn, its commands complete) is destroyed and
// the asset is recorded again with the needed capacities, at most kMaxTries in all, the coarser
// level staying on screen meanwhile; any other error marks the asset failed (its mesh stays).
#pragma once

#include <chrono>
#include <vector>

#include "asset_view.h"

namespace nfc_viewer {

class RecordedFinals {
public:
    // Each try raises at least one of the four capacities (nfd_recording_result): 4 overflows
    // can be needed, one per capacity, before the try that fits.
    static constexpr uint32_t kMaxTries = 6;

    // `context` adopted vk's device and is this object's alone, used on the frame thread only
    // (a context is not thread-safe, and the queue's workers use the queue's). `resolution`: the
    // final level's. `first_capacity`: every capacity of each asset's first try (0: the library's
    // defaults); a small one exercises the retry.
    RecordedFinals(VkDeviceContext* vk, nfd_context* context, uint32_t resolution,
                   uint32_t first_capacity, size_t assets);
    // Waits for the submission in flight, if any, and destroys its recording.
    ~RecordedFinals();
    RecordedFinals(const RecordedFinals&) = delete;
    RecordedFinals& operator=(const RecordedFinals&) = delete;

    // One frame's step, never waiting: collects the recording in flight if its fence has
    // signalled, then, if none is in flight, records and submits the next asset whose coarser
    // levels are all shown. `streamed[i]->asset` must outlive the recordings made of it.
    void update(const std::vector<StreamedAsset*>& streamed, std::vector<AssetView>* views,
                FrameTarget* frames, double now_s);

private:
    void start(size_t index, const nfd_asset* asset, AssetView* view);
    void collect(AssetView* view, FrameTarget* frames, double now_s);

    VkDeviceContext* vk_;
    nfd_context* context_;
    uint32_t resolution_;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    VkFence fence_ = VK_NULL_HANDLE;
    std::vector<nfd_recording_options> next_;  // per asset: the capacities of its next try
    // The submission in flight.
    nfd_recording* recording_ = nullptr;
    size_t asset_ = 0;
    std::chrono::steady_clock::time_point started_{};  // before its nfd_recording_create
};

}  // namespace nfc_viewer
