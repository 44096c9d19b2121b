#include "asset_view.h"

namespace nfc_viewer {

bool refresh_asset(StreamedAsset* streamed, AssetView* view, VkDeviceContext* vk,
                   FrameTarget* frames, bool may_upload, double now_s) {
    if (view->queue_done || view->failed()) return false;
    const Arrival phase = streamed->phase.load(std::memory_order_acquire);
    if (phase == Arrival::kFailed) {
        view->error = streamed->error;  // the mesh shown so far stays, marked failed
        return false;
    }
    if (phase != Arrival::kSubmitted) return false;
    nfd_job* job = streamed->job;
    if (!job) {  // no coarser level: the recording decodes them all (recorded_final.h)
        view->queue_done = true;
        return false;
    }
    const nfd_job_status status = nfd_job_poll(job);
    const bool final =
        status == NFD_JOB_DONE || status == NFD_JOB_FAILED || status == NFD_JOB_CANCELLED;
    nfd_job_progress progress = {};
    progress.struct_size = sizeof progress;
    nfd_job_get_progress(job, &progress);
    if (!final && progress.newest_mesh_resolution == view->resolution()) return false;
    if (!may_upload) return false;  // the job keeps the newest level until a later frame takes it

    nfd_mesh* mesh = nullptr;
    const nfd_result r = nfd_job_take_mesh(job, &mesh);
    if (r != NFD_SUCCESS) {
        view->error = nfd_result_string(r);
        return false;
    }
    view->queue_done = final;
    if (!mesh) return false;  // DONE, and its final mesh was taken earlier
    nfd_mesh_data data{};
    nfd_decode_stats stats{};
    nfd_mesh_get_data(mesh, &data);
    nfd_mesh_get_stats(mesh, &stats);
    nfd_job_get_progress(job, &progress);
    LevelRecord level;
    level.resolution = progress.taken_mesh_resolution;
    level.triangles = data.triangle_count;
    // seconds_field counts every step so far; seconds_mesh is the level's own.
    level.decode_ms = 1e3 * (stats.seconds_field - view->field_seconds + stats.seconds_mesh);
    level.shown_s = now_s;
    view->field_seconds = stats.seconds_field;
    const GpuMesh uploaded = upload_mesh(*vk, data);
    nfd_mesh_destroy(mesh);
    show_level(view, uploaded, level, vk->device(), frames);
    return true;
}

void show_level(AssetView* view, const GpuMesh& mesh, const LevelRecord& level, VkDevice device,
                FrameTarget* frames) {
    GpuMesh replaced = view->mesh;
    view->mesh = mesh;
    frames->retire([device, replaced]() mutable { destroy_mesh(device, &replaced); });
    view->levels.push_back(level);
}

}  // namespace nfc_viewer
