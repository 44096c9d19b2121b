// The Dear ImGui overlay (Debian's libimgui-dev: imgui 1.86 with its GLFW and Vulkan backends):
// per asset the bytes received, the decode milliseconds and triangles of every level, its state,
// where its colour comes from;
// the frame time; the keys.
#pragma once

#include <string>
#include <vector>

#include "asset_view.h"
#include "vk_frame.h"

namespace nfc_viewer {

// What the overlay shows besides the assets.
struct OverlayStatus {
    std::string render_device, decode_device;
    double frame_ms = 0, frame_ms_average = 0;
    const char* shading = "";
    const char* colour = "";  // on, off (C) or off (--no-colour)
    bool wireframe = false;
};

class Overlay {
public:
    // Installs ImGui's GLFW callbacks (chaining the viewer's, installed before) and creates its
    // Vulkan objects for `frames`' render pass; uploads the font.
    Overlay(VkDeviceContext* vk, const FrameTarget& frames);
    ~Overlay();
    Overlay(const Overlay&) = delete;
    Overlay& operator=(const Overlay&) = delete;

    // True when ImGui wants the mouse / keyboard (the camera and keys then leave them alone).
    bool wants_mouse() const;
    bool wants_keyboard() const;
    // Builds this frame's windows and records them into `cmd` (inside the render pass).
    void draw(VkCommandBuffer cmd, const OverlayStatus& status, const std::vector<StreamedAsset*>& streamed,
              const std::vector<AssetView>& views);

private:
    VkDevice device_;
    VkDescriptorPool pool_ = VK_NULL_HANDLE;
};

}  // namespace nfc_viewer
