// Asset arrival, off the frame thread. A loader thread plays the network: each file's bytes
// arrive at the simulated bandwidth (per asset, all assets at once from the frame clock's start,
// as over parallel connections), are fed to the asset's own nfd_stream, and the asset is
// submitted to an nfd_queue with the progressive levels the moment its geometry is verified.
// The frame thread only reads the atomics below and polls the jobs (O(1) calls that never wait).
//
// Priority: the loader thread and the queue's workers (created from it, so they inherit it) run
// at the lowest CPU priority (nice 19), so that on a machine whose cores are shared with the
// renderer (lavapipe) the frame loop is scheduled first.
#pragma once

#include <nfdecode/nfdecode.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace nfc_viewer {

enum class Arrival { kStreaming, kSubmitted, kFailed };

// One asset as the loader thread publishes it. Fields above `phase` are written before `phase`
// changes (release) and are read-only for the frame thread once it sees the change (acquire).
struct StreamedAsset {
    std::string path, name;
    // Written by the loader thread before phase becomes kSubmitted:
    nfd_asset_info info{};
    nfd_job* job = nullptr;  // owned by the Streamer; the frame thread polls and takes meshes
                             // (none when the Streamer was given no job resolution)
    nfd_asset* asset = nullptr;  // with keep_assets: owned by the Streamer, for the frame
                                 // thread's recordings (recorded_final.h), which it outlives
    // Written before phase becomes kFailed (the stream's or the submit's error):
    std::string error;
    std::atomic<Arrival> phase{Arrival::kStreaming};
    std::atomic<uint64_t> bytes_received{0};
    std::atomic<uint32_t> file_size{0};
    std::atomic<bool> complete{false};  // the whole file arrived and verified
};

class Streamer {
public:
    using Clock = std::chrono::steady_clock;

    // Starts the loader thread. `context` must outlive the Streamer and is used only by its
    // queue. `mesh_levels` is the ladder mask of `resolution` (nfd_job_options.mesh_levels);
    // resolution 0: no job (the asset is only published). `keep_assets`: publish the asset too.
    Streamer(nfd_context* context, const std::vector<std::string>& paths, double bandwidth,
             uint32_t resolution, uint32_t mesh_levels, bool keep_assets, Clock::time_point start);
    // Stops the loader thread, destroys the queue (cancelling what has not finished), the jobs
    // and the kept assets.
    ~Streamer();
    Streamer(const Streamer&) = delete;
    Streamer& operator=(const Streamer&) = delete;

    size_t size() const { return assets_.size(); }
    StreamedAsset& asset(size_t i) { return *assets_[i]; }

private:
    void run();
    void feed(StreamedAsset* a, std::vector<unsigned char>* bytes, nfd_stream** stream, size_t* fed,
              double now_s);
    void fail(StreamedAsset* a, const std::string& error);

    nfd_context* context_;
    double bandwidth_;
    uint32_t resolution_, mesh_levels_;
    bool keep_assets_;
    Clock::time_point start_;
    nfd_queue* queue_ = nullptr;
    std::vector<std::unique_ptr<StreamedAsset>> assets_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

}  // namespace nfc_viewer
