#include "streamer.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

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

Streamer::Streamer(nfd_context* context, const std::vector<std::string>& paths, double bandwidth,
                   uint32_t resolution, uint32_t mesh_levels, bool keep_assets,
                   Clock::time_point start)
    : context_(context),
      bandwidth_(bandwidth),
      resolution_(resolution),
      mesh_levels_(mesh_levels),
      keep_assets_(keep_assets),
      start_(start) {
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
    for (auto& a : assets_) nfd_asset_destroy(a->asset);
}

void Streamer::fail(StreamedAsset* a, const std::string& error) {
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
    std::vector<std::vector<unsigned char>> bytes(n);
    std::vector<nfd_stream*> streams(n, nullptr);
    std::vector<size_t> fed(n, 0);
    for (size_t i = 0; i < n; ++i) {
        std::string error;
        nfd_result r = NFD_SUCCESS;
        if (qr != NFD_SUCCESS)
            fail(assets_[i].get(), std::string("queue: ") + nfd_result_string(qr));
        else if (!read_file(assets_[i]->path, &bytes[i], &error))
            fail(assets_[i].get(), error);
        else if ((r = nfd_stream_create(nullptr, &streams[i])) != NFD_SUCCESS)
            fail(assets_[i].get(), nfd_result_string(r));
    }
    // Ticks at twice the frame rate: a piece is fed within 8 ms of its arrival.
    const auto tick = std::chrono::milliseconds(8);
    for (auto next = Clock::now(); !stop_; next += tick) {
        bool streaming = false;
        const double now_s = std::chrono::duration<double>(Clock::now() - start_).count();
        for (size_t i = 0; i < n; ++i) {
            if (!streams[i]) continue;
            feed(assets_[i].get(), &bytes[i], &streams[i], &fed[i], std::max(0.0, now_s));
            streaming |= streams[i] != nullptr;
        }
        if (!streaming) break;
        std::this_thread::sleep_until(next);
    }
    for (nfd_stream* s : streams) nfd_stream_destroy(s);
}

void Streamer::feed(StreamedAsset* a, std::vector<unsigned char>* bytes, nfd_stream** stream,
                    size_t* fed, double now_s) {
    const size_t arrived = std::min(bytes->size(), size_t(bandwidth_ * now_s));
    nfd_stream_progress p{};
    nfd_result r = nfd_stream_feed(*stream, bytes->data() + *fed, arrived - *fed, &p);
    *fed = arrived;
    a->bytes_received.store(p.bytes_consumed, std::memory_order_relaxed);
    a->file_size.store(p.file_size, std::memory_order_relaxed);
    auto published = [a] { return a->phase.load(std::memory_order_relaxed) != Arrival::kStreaming; };
    if (r == NFD_SUCCESS && !published() && (p.flags & NFD_STREAM_GEOMETRY_READY)) {
        nfd_asset* asset = nullptr;
        r = nfd_stream_take_asset(*stream, &asset);
        if (r == NFD_SUCCESS) r = nfd_asset_get_info(asset, &a->info);
        nfd_mesh_options mo = {};
        mo.struct_size = sizeof mo;
        mo.resolution = resolution_;
        nfd_job_options jo = {};
        jo.struct_size = sizeof jo;
        jo.mesh_levels = mesh_levels_;
        if (r == NFD_SUCCESS && resolution_)
            r = nfd_queue_submit(queue_, asset, &mo, &jo, &a->job);
        if (r == NFD_SUCCESS && keep_assets_) a->asset = asset;
        else nfd_asset_destroy(asset);  // the queue keeps its own copy of the network
        if (r == NFD_SUCCESS) a->phase.store(Arrival::kSubmitted, std::memory_order_release);
    }
    if (r == NFD_SUCCESS && *fed == bytes->size()) {
        r = nfd_stream_finish(*stream);
        a->complete.store(r == NFD_SUCCESS, std::memory_order_release);
    }
    if (r != NFD_SUCCESS || *fed == bytes->size()) {
        nfd_stream_destroy(*stream);
        *stream = nullptr;
        bytes->clear();
        bytes->shrink_to_fit();
    }
    if (r != NFD_SUCCESS)  // a damaged file: before its geometry, or in a later chunk
        fail(a, std::string(published() ? "damaged after its geometry: " : "") + nfd_result_string(r));
}

}  // namespace nfc_viewer
