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
    double decode_ms = 0;  // queue levels: field evaluation + meshing (nfd_mesh_get_stats);
                           // a recorded level: from its creation to the frame that saw it done
    double shown_s = 0;    // since the frame clock's start
};

struct AssetView {
    GpuMesh mesh;
    std::vector<LevelRecord> levels;  // delivered and shown, coarsest first
    double field_seconds = 0;         // cumulative field time of the newest level (stats)
    bool queue_done = false;          // the job ended and was collected, or there is none
    bool awaits_recording = false;    // the final level is to come from a recording, not yet shown
    uint32_t recording_tries = 0;     // recordings submitted (more than one after an overflow)
    std::string error;                // the job's error, or the stream's (StreamedAsset::error)

    bool final() const { return queue_done && !awaits_recording; }
    bool failed() const { return !error.empty(); }
    size_t triangles() const { return levels.empty() ? 0 : levels.back().triangles; }
    uint32_t resolution() const { return levels.empty() ? 0 : levels.back().resolution; }
};

// One frame's look at an asset: reads its arrival state and polls its job (nfd_job_poll,
// nfd_job_get_progress: O(1), never waiting). When a newer level is ready and `may_upload`, takes
// it and shows it uploaded (upload_mesh, show_level). Returns true if it uploaded.
bool refresh_asset(StreamedAsset* streamed, AssetView* view, VkDeviceContext* vk,
                   FrameTarget* frames, bool may_upload, double now_s);

// Makes `mesh` the one drawn and records its level; the replaced mesh is retired into `frames`
// (freed once the GPU no longer draws it).
void show_level(AssetView* view, const GpuMesh& mesh, const LevelRecord& level, VkDevice device,
                FrameTarget* frames);

// Where the final level is drawn from: "device (recorded)" (zero copy), "uploaded", or "-" while
// it is not shown.
inline const char* final_mesh_source(const AssetView& view) {
    if (!view.final() || view.failed()) return "-";
    return view.mesh.recorded() ? "device (recorded)" : "uploaded";
}

// Still arriving or refining: not failed and not final.
inline bool loading(const AssetView& view) { return !view.final() && !view.failed(); }

}  // namespace nfc_viewer
