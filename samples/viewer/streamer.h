// Asset arrival, off the frame thread. A loader thread plays the network: each file's bytes
// arrive at the simulated bandwidth (per asset, all assets at once from the frame clock's start,
// as over parallel connections), are fed to the asset's own nfd_stream, and the asset is
// submitted to an nfd_queue with the progressive levels the moment its geometry is verified.
// The loader thread also collects the job's levels and offers them to the frame thread, which
// only reads the atomics below and exchanges pointers (O(1), never waiting).
//
// Colour arriving late. A file's `colr` chunk follows its geometry (FORMAT.md), so the asset
// submitted at NFD_STREAM_GEOMETRY_READY has no colour unless the whole file came in the same
// feed, and the job's levels come uncoloured. Once the stream completes, the loader thread takes
// the complete asset (nfd_stream_take_complete_asset) and, on a CPU context of its own, colours
// (nfd_mesh_evaluate_colours) every level it takes from the job after that, and the level already
// shown: the frame thread hands each uploaded level's host mesh back (StreamedAsset::returned)
// until the one that is the last, so the loader thread can colour it and offer it again.
// Colouring a level costs one colour-network evaluation per vertex, far less than extracting it
// again (a second job for the complete asset); it delays the other assets' feeding by as long,
// on a thread that runs at the lowest priority, never the frame.
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

// How the level offered got its colours.
enum class Colouring { kNone, kQueued, kAdded };  // none; by the job; by the loader thread

// A level as the loader thread offers it to the frame thread, who takes it (with its mesh).
struct OfferedLevel {
    nfd_mesh* mesh = nullptr;  // null: no mesh (the job's final level was offered before, or
                               // there is no job), only `last`
    uint32_t resolution = 0;
    double decode_ms = 0;      // field evaluation + meshing of this level (nfd_mesh_get_stats)
    Colouring colouring = Colouring::kNone;
    double colour_ms = 0;      // kAdded: nfd_mesh_evaluate_colours's time
    bool recoloured = false;   // the level offered before, now with its colours
    bool last = false;         // nothing follows: the final level, with colour if the file has it
};

// One asset as the loader thread publishes it. Fields above `phase` are written before `phase`
// changes (release) and are read-only for the frame thread once it sees the change (acquire).
struct StreamedAsset {
    std::string path, name;
    // Written by the loader thread before phase becomes kSubmitted:
    nfd_asset_info info{};     // of the geometry's asset (has_colour: as of that moment)
    bool records_final = false;  // the final level is left to a recording (recorded_final.h)
    bool colour_expected = false;  // a colour field is announced (header minor >= 1) and drawn
    nfd_job* job = nullptr;    // owned by the Streamer (none when the queue has no level)
    nfd_asset* asset = nullptr;  // with records_final: owned by the Streamer, for the frame
                                 // thread's recordings, which it outlives
    // Written before phase becomes kFailed (the stream's, the submit's or the job's error):
    std::string error;
    std::atomic<Arrival> phase{Arrival::kStreaming};
    std::atomic<uint64_t> bytes_received{0};
    std::atomic<uint32_t> file_size{0};
    std::atomic<bool> complete{false};  // the whole file arrived and verified
    // The hand-off, once kSubmitted. Whoever exchanges a pointer out owns it.
    std::atomic<OfferedLevel*> offered{nullptr};  // loader -> frame, one at a time
    std::atomic<nfd_mesh*> returned{nullptr};     // frame -> loader: uploaded, not `last`
};

class Streamer {
public:
    using Clock = std::chrono::steady_clock;

    struct Config {
        double bandwidth = 0;          // bytes per second, per asset
        std::vector<uint32_t> levels;  // the ladder shown, ascending
        bool record_finals = false;    // a file without colour drawn leaves its final level to a
                                       // recording and is kept (StreamedAsset::asset) for it
        bool colour = true;            // false: geometry only (--no-colour)
    };

    // Starts the loader thread. `context` must outlive the Streamer and is used only by its
    // queue; `colour_context` only by the loader thread, to colour levels.
    Streamer(nfd_context* context, nfd_context* colour_context,
             const std::vector<std::string>& paths, const Config& config, Clock::time_point start);
    // Stops the loader thread, destroys the queue (cancelling what has not finished), the jobs,
    // the meshes in the hand-off and the kept assets.
    ~Streamer();
    Streamer(const Streamer&) = delete;
    Streamer& operator=(const Streamer&) = delete;

    size_t size() const { return assets_.size(); }
    StreamedAsset& asset(size_t i) { return *assets_[i]; }

private:
    struct Loading;  // the loader thread's own state of one asset (streamer.cpp)

    void run();
    void feed(StreamedAsset* a, Loading* l, double now_s);
    void submit(StreamedAsset* a, Loading* l, const nfd_stream_progress& p, nfd_result* r);
    void take_colour(StreamedAsset* a, Loading* l);
    bool deliver(StreamedAsset* a, Loading* l);
    // Colours `mesh` (of `level`) with the complete asset's field; on failure destroys it and
    // fails the asset.
    bool colour(StreamedAsset* a, Loading* l, nfd_mesh* mesh, OfferedLevel* level);
    void fail(StreamedAsset* a, const std::string& error);

    nfd_context* context_;
    nfd_context* colour_context_;
    Config config_;
    Clock::time_point start_;
    nfd_queue* queue_ = nullptr;
    std::vector<std::unique_ptr<StreamedAsset>> assets_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

}  // namespace nfc_viewer
