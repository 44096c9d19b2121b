#include "streamer.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "../common/cli_values.h"

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace nfc_viewer {
namespace {

// Linux keeps a nice value per thread, and threads inherit their creator's: lowering this
// thread's also lowers the queue workers it starts and the threads they start for each step.
void lower_this_threads_priority() {
#if defined(__linux__)
    setpriority(PRIO_PROCESS, id_t(syscall(SYS_gettid)), 19);
#endif
}

std::string base_name(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

// The whole file, as a server would have it; false and *error when it cannot be read.
bool read_file(const std::string& path, std::vector<unsigned char>* bytes, std::string* error) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) {
        *error = std::string("cannot open: ") + std::strerror(errno);
        return false;
    }
    unsigned char buffer[1 << 16];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) {
        bytes->insert(bytes->end(), buffer, buffer + n);
        if (bytes->size() > NFD_MAX_FILE_SIZE) break;  // the stream refuses it from the header
    }
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    if (failed) *error = "read error";
    return !failed;
}

}  // namespace

// The loader thread's own state of one asset.
struct Streamer::Loading {
    enum class Colour { kNone, kPending, kArrived };  // none to add; not yet known; to add

    std::vector<unsigned char> bytes;  // the whole file, until it has all been fed
    nfd_stream* stream = nullptr;
    size_t fed = 0;
    Colour colour = Colour::kNone;
    nfd_asset* coloured = nullptr;  // kArrived: the complete asset, whose colour is added
    nfd_mesh* shown = nullptr;      // the newest level handed back, uncoloured
    bool awaiting_return = false;   // a level offered that is not `last`, not yet handed back
    bool job_ended = false;         // the job's final level (or its failure) taken
    bool last_offered = false;
    uint32_t taken_resolution = 0;
    double field_seconds = 0;       // cumulative field time of the newest level taken (stats)

    Loading() = default;
    Loading(const Loading&) = delete;
    Loading& operator=(const Loading&) = delete;
    ~Loading() {
        nfd_stream_destroy(stream);
        nfd_asset_destroy(coloured);
        nfd_mesh_destroy(shown);
    }
};

Streamer::Streamer(nfd_context* context, nfd_context* colour_context,
                   const std::vector<std::string>& paths, const Config& config,
                   Clock::time_point start)
    : context_(context), colour_context_(colour_context), config_(config), start_(start) {
    for (const std::string& p : paths) {
        auto a = std::make_unique<StreamedAsset>();
        a->path = p;
        a->name = base_name(p);
        assets_.push_back(std::move(a));
    }
    thread_ = std::thread([this] { run(); });
}

Streamer::~Streamer() {
    stop_ = true;
    thread_.join();
    for (auto& a : assets_) nfd_job_destroy(a->job);  // cancels jobs still running
    nfd_queue_destroy(queue_);
    for (auto& a : assets_) {
        if (OfferedLevel* level = a->offered.exchange(nullptr)) {
            nfd_mesh_destroy(level->mesh);
            delete level;
        }
        nfd_mesh_destroy(a->returned.exchange(nullptr));
        nfd_asset_destroy(a->asset);
    }
}

void Streamer::fail(StreamedAsset* a, const std::string& error) {
    if (a->phase.load(std::memory_order_relaxed) == Arrival::kFailed) return;  // error is read
    a->error = error;
    a->phase.store(Arrival::kFailed, std::memory_order_release);
}

void Streamer::run() {
    lower_this_threads_priority();
    nfd_queue_options qo = {};
    qo.struct_size = sizeof qo;
    qo.worker_threads = 1;  // one job at a time: the earliest asset refines first
    const nfd_result qr = nfd_queue_create(context_, &qo, &queue_);
    const size_t n = assets_.size();
    std::vector<Loading> loading(n);
    // The decoding context compiles each file's field pipelines as soon as its network's shape
    // has arrived, while the rest of its geometry is still on the way (the streams end on this
    // thread, before the context is destroyed).
    nfd_stream_options so = {};
    so.struct_size = sizeof so;
    so.prepare_context = context_;
    for (size_t i = 0; i < n; ++i) {
        std::string error;
        nfd_result r = NFD_SUCCESS;
        if (qr != NFD_SUCCESS)
            fail(assets_[i].get(), std::string("queue: ") + nfd_result_string(qr));
        else if (!read_file(assets_[i]->path, &loading[i].bytes, &error))
            fail(assets_[i].get(), error);
        else if ((r = nfd_stream_create(&so, &loading[i].stream)) != NFD_SUCCESS)
            fail(assets_[i].get(), nfd_result_string(r));
    }
    // Ticks at twice the frame rate: a piece is fed, and a level offered, within 8 ms.
    const auto tick = std::chrono::milliseconds(8);
    for (auto next = Clock::now(); !stop_; next += tick) {
        bool busy = false;
        const double now_s = std::chrono::duration<double>(Clock::now() - start_).count();
        for (size_t i = 0; i < n; ++i) {
            if (loading[i].stream) feed(assets_[i].get(), &loading[i], std::max(0.0, now_s));
            busy |= loading[i].stream != nullptr;
            busy |= deliver(assets_[i].get(), &loading[i]);
        }
        if (!busy) break;
        std::this_thread::sleep_until(next);
    }
}

void Streamer::feed(StreamedAsset* a, Loading* l, double now_s) {
    const size_t arrived = std::min(l->bytes.size(), size_t(config_.bandwidth * now_s));
    nfd_stream_progress p{};
    nfd_result r = nfd_stream_feed(l->stream, l->bytes.data() + l->fed, arrived - l->fed, &p);
    l->fed = arrived;
    a->bytes_received.store(p.bytes_consumed, std::memory_order_relaxed);
    a->file_size.store(p.file_size, std::memory_order_relaxed);
    auto published = [a] { return a->phase.load(std::memory_order_relaxed) != Arrival::kStreaming; };
    if (r == NFD_SUCCESS && !published() && (p.flags & NFD_STREAM_GEOMETRY_READY)) submit(a, l, p, &r);
    const bool all_fed = l->fed == l->bytes.size();
    if (r == NFD_SUCCESS && all_fed) {
        r = nfd_stream_finish(l->stream);
        a->complete.store(r == NFD_SUCCESS, std::memory_order_release);
        if (r == NFD_SUCCESS && l->colour == Loading::Colour::kPending) take_colour(a, l);
    }
    if (r != NFD_SUCCESS || all_fed) {
        nfd_stream_destroy(l->stream);
        l->stream = nullptr;
        l->bytes.clear();
        l->bytes.shrink_to_fit();
        if (l->colour == Loading::Colour::kPending) l->colour = Loading::Colour::kNone;
    }
    if (r != NFD_SUCCESS)  // a damaged file: before its geometry, or in a later chunk
        fail(a, std::string(published() ? "damaged after its geometry: " : "") + nfd_result_string(r));
}

void Streamer::submit(StreamedAsset* a, Loading* l, const nfd_stream_progress& p, nfd_result* r) {
    // The whole file already here (a small file, a fast link): the job gets the complete asset
    // and colours its levels itself.
    const bool complete = config_.colour && (p.flags & NFD_STREAM_COMPLETE);
    nfd_asset* asset = nullptr;
    *r = complete ? nfd_stream_take_complete_asset(l->stream, &asset)
                  : nfd_stream_take_asset(l->stream, &asset);
    if (*r == NFD_SUCCESS) *r = nfd_asset_get_info(asset, &a->info);
    if (*r != NFD_SUCCESS) return;
    // FORMAT.md: the header's minor is 1 iff a colr chunk follows GEOM (a later minor may have
    // one): whether to wait for colour is known from the header, before the chunk arrives.
    a->colour_expected = config_.colour && (complete ? a->info.has_colour : p.format_minor >= 1);
    if (a->colour_expected && !complete) l->colour = Loading::Colour::kPending;
    // Recordings are geometry only: a file whose colour is drawn gets its final level from the
    // queue, uploaded, as the coarser ones.
    a->records_final = config_.record_finals && !a->colour_expected;
    std::vector<uint32_t> queued = config_.levels;
    if (a->records_final) queued.pop_back();
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = queued.empty() ? 0 : queued.back();
    mo.skip_colour = !config_.colour;
    nfd_job_options jo = {};
    jo.struct_size = sizeof jo;
    jo.mesh_levels = nfc_cli::ladder_mask(queued);
    if (!queued.empty()) *r = nfd_queue_submit(queue_, asset, &mo, &jo, &a->job);
    if (*r == NFD_SUCCESS && a->records_final) a->asset = asset;
    else nfd_asset_destroy(asset);  // the queue keeps its own copy of the network
    if (*r == NFD_SUCCESS) a->phase.store(Arrival::kSubmitted, std::memory_order_release);
}

void Streamer::take_colour(StreamedAsset* a, Loading* l) {
    nfd_asset* asset = nullptr;
    nfd_asset_info info{};
    nfd_result r = nfd_stream_take_complete_asset(l->stream, &asset);
    if (r == NFD_SUCCESS) r = nfd_asset_get_info(asset, &info);
    if (r == NFD_SUCCESS && info.has_colour) {
        l->coloured = asset;
        l->colour = Loading::Colour::kArrived;
        return;
    }
    nfd_asset_destroy(asset);
    l->colour = Loading::Colour::kNone;
    if (r != NFD_SUCCESS) fail(a, std::string("colour: ") + nfd_result_string(r));
}

bool Streamer::colour(StreamedAsset* a, Loading* l, nfd_mesh* mesh, OfferedLevel* level) {
    const auto started = Clock::now();
    const nfd_result r = nfd_mesh_evaluate_colours(colour_context_, l->coloured, mesh);
    level->colouring = Colouring::kAdded;
    level->colour_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
    if (r == NFD_SUCCESS) return true;
    nfd_mesh_destroy(mesh);
    fail(a, std::string("colour: ") + nfd_result_string(r));
    return false;
}

bool Streamer::deliver(StreamedAsset* a, Loading* l) {
    const Arrival phase = a->phase.load(std::memory_order_relaxed);  // this thread's own writes
    if (phase == Arrival::kFailed || l->last_offered) return false;
    if (phase == Arrival::kStreaming) return true;
    if (nfd_mesh* back = a->returned.exchange(nullptr, std::memory_order_acq_rel)) {
        l->awaiting_return = false;
        nfd_mesh_destroy(l->shown);
        const float* colours = nullptr;
        nfd_mesh_get_colours(back, &colours);
        l->shown = !colours && l->colour != Loading::Colour::kNone ? back : nullptr;
        if (!l->shown) nfd_mesh_destroy(back);  // nothing will be added to it
    }
    if (l->awaiting_return) return true;  // the frame thread has not taken the offer yet
    const bool settled = l->colour != Loading::Colour::kPending;
    auto offer = [&](std::unique_ptr<OfferedLevel> level) {
        l->awaiting_return = level->mesh && !level->last;
        l->last_offered = level->last;
        a->offered.store(level.release(), std::memory_order_release);
        return !l->last_offered;
    };
    auto level = std::make_unique<OfferedLevel>();
    if (!a->job) {
        l->job_ended = true;  // no queued level: the recording decodes them all
    } else if (!l->job_ended) {
        const nfd_job_status status = nfd_job_poll(a->job);
        const bool final =
            status == NFD_JOB_DONE || status == NFD_JOB_FAILED || status == NFD_JOB_CANCELLED;
        nfd_job_progress progress = {};
        progress.struct_size = sizeof progress;
        nfd_job_get_progress(a->job, &progress);
        nfd_mesh* mesh = nullptr;
        if (final || progress.newest_mesh_resolution != l->taken_resolution) {
            const nfd_result r = nfd_job_take_mesh(a->job, &mesh);
            if (r != NFD_SUCCESS) {
                fail(a, nfd_result_string(r));
                return false;
            }
            l->job_ended = final;
        }
        if (mesh) {  // else no newer level, or DONE and its final mesh was taken earlier
            nfd_decode_stats stats{};
            nfd_mesh_get_stats(mesh, &stats);
            nfd_job_get_progress(a->job, &progress);
            level->mesh = mesh;
            level->resolution = l->taken_resolution = progress.taken_mesh_resolution;
            // seconds_field counts every step so far; seconds_mesh is the level's own.
            level->decode_ms = 1e3 * (stats.seconds_field - l->field_seconds + stats.seconds_mesh);
            l->field_seconds = stats.seconds_field;
            const float* colours = nullptr;
            nfd_mesh_get_colours(mesh, &colours);
            if (colours) level->colouring = Colouring::kQueued;
            // A newer level than the one shown: the shown one is not coloured any more.
            nfd_mesh_destroy(l->shown);
            l->shown = nullptr;
            if (l->colour == Loading::Colour::kArrived && !colour(a, l, mesh, level.get()))
                return false;
            level->last = final && settled;
            return offer(std::move(level));
        }
    }
    if (l->shown && l->colour == Loading::Colour::kArrived) {  // the level shown, coloured now
        level->mesh = l->shown;
        l->shown = nullptr;
        level->recoloured = true;
        if (!colour(a, l, level->mesh, level.get())) return false;
        level->last = l->job_ended;
        return offer(std::move(level));
    }
    if (!l->job_ended || !settled) return true;
    nfd_mesh_destroy(l->shown);  // no colour came for it
    l->shown = nullptr;
    level->last = true;
    return offer(std::move(level));
}

}  // namespace nfc_viewer
