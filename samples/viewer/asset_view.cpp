#include "asset_view.h"

#include <cstdio>
#include <memory>

namespace nfc_viewer {

bool refresh_asset(StreamedAsset* streamed, AssetView* view, VkDeviceContext* vk,
                   FrameTarget* frames, bool may_upload, double now_s) {
    if (view->queue_done || view->failed()) return false;
    const Arrival phase = streamed->phase.load(std::memory_order_acquire);
    if (phase == Arrival::kFailed) {
        view->error = streamed->error;  // the mesh shown so far stays, marked failed
        return false;
    }
    if (phase != Arrival::kSubmitted || !may_upload) return false;  // an offer waits meanwhile
    const std::unique_ptr<OfferedLevel> level(
        streamed->offered.exchange(nullptr, std::memory_order_acq_rel));
    if (!level) return false;
    if (level->last) {
        view->queue_done = true;
        view->awaits_recording = streamed->records_final;
    }
    if (!level->mesh) return false;
    nfd_mesh_data data{};
    const float* colours = nullptr;
    nfd_mesh_get_data(level->mesh, &data);
    nfd_mesh_get_colours(level->mesh, &colours);
    const GpuMesh uploaded = upload_mesh(*vk, data, colours);
    // The loader thread offers no other mesh before this one is back: the slot is empty.
    if (level->last) nfd_mesh_destroy(level->mesh);
    else streamed->returned.store(level->mesh, std::memory_order_release);
    if (level->recoloured) {
        show_mesh(view, uploaded, vk->device(), frames);
        view->levels.back().colouring = level->colouring;
        view->levels.back().colour_ms = level->colour_ms;
        return true;
    }
    LevelRecord record;
    record.resolution = level->resolution;
    record.triangles = data.triangle_count;
    record.decode_ms = level->decode_ms;
    record.shown_s = now_s;
    record.colouring = level->colouring;
    record.colour_ms = level->colour_ms;
    show_level(view, uploaded, record, vk->device(), frames);
    return true;
}

void show_mesh(AssetView* view, const GpuMesh& mesh, VkDevice device, FrameTarget* frames) {
    GpuMesh replaced = view->mesh;
    view->mesh = mesh;
    frames->retire([device, replaced]() mutable { destroy_mesh(device, &replaced); });
}

void show_level(AssetView* view, const GpuMesh& mesh, const LevelRecord& level, VkDevice device,
                FrameTarget* frames) {
    show_mesh(view, mesh, device, frames);
    view->levels.push_back(level);
}

std::string colour_source(const StreamedAsset& streamed, const AssetView& view) {
    if (view.levels.empty()) return "-";
    const LevelRecord& shown = view.levels.back();
    if (shown.colouring == Colouring::kQueued) return "from the queue";
    if (shown.colouring == Colouring::kAdded) {
        char text[64];
        std::snprintf(text, sizeof text, "added on arrival (%.0f ms)", shown.colour_ms);
        return text;
    }
    return streamed.colour_expected && !view.final() && !view.failed() ? "awaited" : "none";
}

}  // namespace nfc_viewer
