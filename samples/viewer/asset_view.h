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
    Colouring colouring = Colouring::kNone;  // of the mesh shown (a recorded level: none)
    double colour_ms = 0;  // kAdded: the loader thread's evaluation
};

struct AssetView {
    GpuMesh mesh;
    std::vector<LevelRecord> levels;  // delivered and shown, coarsest first
    bool queue_done = false;          // the last offer (OfferedLevel::last) taken
    bool awaits_recording = false;    // the final level is to come from a recording, not yet shown
    uint32_t recording_tries = 0;     // recordings submitted (more than one after an overflow)
    std::string error;                // the job's error, or the stream's (StreamedAsset::error)

    bool final() const { return queue_done && !awaits_recording; }
    bool failed() const { return !error.empty(); }
    size_t triangles() const { return levels.empty() ? 0 : levels.back().triangles; }
    uint32_t resolution() const { return levels.empty() ? 0 : levels.back().resolution; }
};

// One frame's look at an asset: reads its arrival state and, when `may_upload`, takes the level
// the loader thread offers (an atomic exchange, never waiting) and shows it uploaded
// (upload_mesh, show_level; a recoloured one replaces the mesh of its level). A level that is not
// the last goes back to the loader thread, which may colour it (streamer.h). Returns true if it
// uploaded.
bool refresh_asset(StreamedAsset* streamed, AssetView* view, VkDeviceContext* vk,
                   FrameTarget* frames, bool may_upload, double now_s);

// Makes `mesh` the one drawn; the replaced mesh is retired into `frames` (freed once the GPU no
// longer draws it).
void show_mesh(AssetView* view, const GpuMesh& mesh, VkDevice device, FrameTarget* frames);
// show_mesh, and records its level.
void show_level(AssetView* view, const GpuMesh& mesh, const LevelRecord& level, VkDevice device,
                FrameTarget* frames);

// Where the final level is drawn from: "device (recorded)" (zero copy), "uploaded", or "-" while
// it is not shown.
inline const char* final_mesh_source(const AssetView& view) {
    if (!view.final() || view.failed()) return "-";
    return view.mesh.recorded() ? "device (recorded)" : "uploaded";
}

// Where the colour drawn comes from: "from the queue" (the job had the complete asset), "added
// on arrival" (by the loader thread), "awaited" (announced, not arrived), "none", or "-" while
// nothing is shown.
std::string colour_source(const StreamedAsset& streamed, const AssetView& view);

// Still arriving or refining: not failed and not final.
inline bool loading(const AssetView& view) { return !view.final() && !view.failed(); }

}  // namespace nfc_viewer
