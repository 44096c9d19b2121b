// What the frame thread shows of one asset: the newest level's GpuMesh and what the overlay lists
// (levels, their decode times and triangle counts).
#pragma once

#include <string>
#include <vector>

#include "gpu_mesh.h"
#include "streamer.h"
#include "vk_frame.h"

namespace nfc_viewer {

struct LevelRecord {
    uint32_t resolution = 0;
    size_t triangles = 0;
    double decode_ms = 0;  // this level's field evaluation + meshing (nfd_mesh_get_stats)
    double shown_s = 0;    // since the frame clock's start
};

struct AssetView {
    GpuMesh mesh;
    std::vector<LevelRecord> levels;  // delivered and shown, coarsest first
    double field_seconds = 0;         // cumulative field time of the newest level (stats)
    bool final = false;               // the job ended (done, failed or cancelled) and was collected
    std::string error;                // the job's error, or the stream's (StreamedAsset::error)

    bool failed() const { return !error.empty(); }
    size_t triangles() const { return levels.empty() ? 0 : levels.back().triangles; }
    uint32_t resolution() const { return levels.empty() ? 0 : levels.back().resolution; }
};

// One frame's look at an asset: reads its arrival state and polls its job (nfd_job_poll,
// nfd_job_get_progress: O(1), never waiting). When a newer level is ready and `may_upload`, takes
// it, uploads it (upload_mesh) and retires the replaced mesh into the frame (it is freed once
// the GPU no longer draws it). Returns true if it uploaded.
bool refresh_asset(StreamedAsset* streamed, AssetView* view, VkDeviceContext* vk,
                   FrameTarget* frames, bool may_upload, double now_s);

// Still arriving or refining: not failed and not final.
inline bool loading(const AssetView& view) { return !view.final && !view.failed(); }

}  // namespace nfc_viewer
