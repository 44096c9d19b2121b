// nfc-viewer: streams .nfc assets into a grid and shows each as soon as its first level of detail
// is decoded, replacing it in place by finer levels while the camera keeps moving. The sample of
// libnfdecode's streaming API, over the public header only: nfd_stream (streamer.cpp), nfd_queue
// with progressive levels (nfd_job_options.mesh_levels), device adoption (the viewer's VkDevice,
// nfd_context_options.adopt) and, on that device, the final level recorded into the viewer's
// command buffer and drawn in place (nfd_recording, recorded_final.h); colour (format 1.1) drawn
// as soon as its chunk arrives (streamer.h). See --help; headless:
// xvfb-run -a nfc-viewer DIR --screenshot F.png.
//
// Errors are one line on stderr ("nfc-viewer: error: ...") and a non-zero exit status: 2 for a
// bad command line, 1 for no display, no Vulkan or a failure while running. An asset that cannot
// be read or decoded is shown as failed while the others keep streaming.
#include <nfdecode/nfdecode.h>

#include <stb_image_write.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <stdexcept>
#include <thread>

#include "asset_view.h"
#include "controls.h"
#include "frame_clock.h"
#include "mesh_pipeline.h"
#include "options.h"
#include "overlay.h"
#include "recorded_final.h"
#include "scene.h"

namespace nfc_viewer {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

using ContextPtr = std::unique_ptr<nfd_context, void (*)(nfd_context*)>;

// Whether libnfdecode decodes on the viewer's own device, adopted. auto: the CPU path on a CPU
// implementation (lavapipe), whose threads the renderer needs and where the one queue would make
// frames wait behind decode submissions; the device on a GPU (bench/RESULTS.md, "Viewer").
bool decodes_on_device(const Options& o, const VkDeviceContext& vk) {
    return o.decode_device == DecodeDevice::kVulkan ||
           (o.decode_device == DecodeDevice::kAuto && !vk.is_cpu_device());
}

// A context on the CPU, or on `lent` (the viewer's device) when given, whose pipeline cache
// starts from `cache` (an earlier run's; the library ignores bytes that do not match).
ContextPtr create_context(const nfd_vulkan_device* lent,
                          const std::vector<unsigned char>& cache = {}) {
    nfd_context_options co = {};
    co.struct_size = sizeof co;
    co.device = lent ? NFD_DEVICE_VULKAN : NFD_DEVICE_CPU;
    co.adopt = lent;
    co.pipeline_cache = cache.data();
    co.pipeline_cache_size = cache.size();
    nfd_context* context = nullptr;
    const nfd_result r = nfd_context_create(&co, &context);
    if (r != NFD_SUCCESS)
        throw std::runtime_error(std::string("libnfdecode context: ") + nfd_result_string(r));
    return ContextPtr(context, nfd_context_destroy);
}

void print_summary(const std::vector<StreamedAsset*>& streamed, const std::vector<AssetView>& views) {
    for (size_t i = 0; i < views.size(); ++i) {
        const AssetView& v = views[i];
        std::printf("asset %s: %s, %u cells, %zu triangles, %llu bytes received, levels",
                    streamed[i]->name.c_str(),
                    v.failed() ? ("failed: " + v.error).c_str() : v.final() ? "done" : "loading",
                    v.resolution(), v.triangles(),
                    (unsigned long long)streamed[i]->bytes_received.load());
        for (const LevelRecord& l : v.levels) std::printf(" %u:%.1fms", l.resolution, l.decode_ms);
        std::printf(", final mesh %s", final_mesh_source(v));
        if (v.recording_tries) std::printf(", %u recordings", v.recording_tries);
        std::printf(", colour %s\n", colour_source(*streamed[i], v).c_str());
    }
}

int run(const Options& o) {
    VkDeviceContext vk(o.width, o.height, "nfc-viewer");
    FrameTarget frames(&vk, o.width, o.height);
    MeshPipeline pipeline(vk.device(), frames.render_pass(), vk.wireframe_supported());
    Controls controls;
    controls.overlay = o.overlay;
    controls.install(vk.window());
    Overlay overlay(&vk, frames);

    // On the device: the queue's context decodes the coarser levels on its worker, a second
    // context on the same device records the final ones on this thread (contexts are not
    // thread-safe). A third, on the CPU, colours levels on the loader thread (streamer.h): on the
    // device its submissions would hold the one queue that the frames need (lavapipe: frames of
    // over a second behind a colour evaluation's first submission), and one colour network per
    // vertex is cheap on a core. Destroyed last: after the recordings, the jobs and the assets.
    const bool on_device = decodes_on_device(o, vk);
    const nfd_vulkan_device lent = on_device ? vk.lend() : nfd_vulkan_device{};
    const std::vector<unsigned char> cache =
        on_device ? nfc_cli::read_pipeline_cache(o.pipeline_cache) : std::vector<unsigned char>();
    ContextPtr context = create_context(on_device ? &lent : nullptr, cache);
    ContextPtr recording_context =
        on_device ? create_context(&lent, cache) : ContextPtr(nullptr, nullptr);
    ContextPtr colour_context = create_context(nullptr);
    OverlayStatus status;
    status.render_device = vk.properties().deviceName;
    status.decode_device = on_device ? std::string("adopted ") +
                                           nfd_context_device_name(context.get()) +
                                           ", final level recorded (uploaded with colour)"
                                     : std::string("cpu");

    const size_t n = o.inputs.size();
    std::vector<AssetView> views(n);
    // The queue's levels: all of them on the CPU, the coarser ones (maybe none) on the device
    // for a file without colour.
    Streamer::Config config;
    config.bandwidth = o.bandwidth;
    config.levels = o.levels;
    config.record_finals = on_device;
    config.colour = o.colour;
    const Clock::time_point start = Clock::now();
    auto streamer = std::make_unique<Streamer>(context.get(), colour_context.get(), o.inputs,
                                               config, start);
    std::unique_ptr<RecordedFinals> finals;
    if (on_device)
        finals = std::make_unique<RecordedFinals>(&vk, recording_context.get(), o.levels.back(),
                                                  o.recording_capacity, n);
    // Whatever ends the run: the GPU done with every mesh before they go, the recordings (and
    // the meshes retired into the frames) before the assets and contexts they borrow.
    struct Teardown {
        std::function<void()> run;
        ~Teardown() { run(); }
    } teardown{[&] {
        frames.drain();
        finals.reset();
        for (AssetView& v : views) destroy_mesh(vk.device(), &v.mesh);
        streamer.reset();  // cancels jobs still running, joins the workers: before the context
        // Each of the two device contexts has its own cache, and either may hold kernels the
        // other lacks (with one level, the queue decodes nothing but files with colour, whose
        // finals are not recorded): the fuller one is kept.
        if (on_device && !o.pipeline_cache.empty()) {
            size_t queue_bytes = 0, recording_bytes = 0;
            nfd_context_get_pipeline_cache(context.get(), nullptr, &queue_bytes);
            nfd_context_get_pipeline_cache(recording_context.get(), nullptr, &recording_bytes);
            const nfd_context* fuller =
                recording_bytes > queue_bytes ? recording_context.get() : context.get();
            const std::string why = nfc_cli::save_pipeline_cache(fuller, o.pipeline_cache);
            if (!why.empty())
                std::fprintf(stderr, "nfc-viewer: warning: pipeline cache not saved to %s: %s\n",
                             o.pipeline_cache.c_str(), why.c_str());
        }
    }};
    std::vector<StreamedAsset*> streamed;
    for (size_t i = 0; i < n; ++i) streamed.push_back(&streamer->asset(i));
    auto any_loading = [&] {
        for (const AssetView& v : views)
            if (loading(v)) return true;
        return false;
    };
    auto timed_out = [&] { return seconds_between(start, Clock::now()) > o.timeout_s; };

    if (o.preload) {  // the fully loaded baseline: every final mesh before the first frame
        while (any_loading() && !timed_out()) {
            for (size_t i = 0; i < n; ++i)
                refresh_asset(streamed[i], &views[i], &vk, &frames, true, 0);
            if (finals) finals->update(streamed, &views, &frames, 0);
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }

    const VkExtent2D first = frames.extent();
    controls.home = OrbitCamera::framing(n, float(first.width) / float(first.height));
    controls.camera = controls.home;
    FrameClock clock(o.fps, o.frame_log);
    const bool headless = !o.screenshot.empty();
    for (int frame = 0;; ++frame) {
        glfwPollEvents();
        if (!headless && glfwWindowShouldClose(vk.window())) break;
        clock.begin_frame();
        VkCommandBuffer cmd = frames.begin_frame();
        const double now_s = seconds_between(start, Clock::now());
        // One upload per frame bounds the frame's copying; a job keeps its newest level meanwhile.
        bool uploaded = false;
        for (size_t i = 0; i < n; ++i)
            uploaded |= refresh_asset(streamed[i], &views[i], &vk, &frames, !uploaded, now_s);
        if (finals) finals->update(streamed, &views, &frames, now_s);  // polls, never waits
        const bool loading_now = any_loading();
        controls.overlay_has_keyboard = overlay.wants_keyboard();
        controls.update(vk.window(), controls.overlay && overlay.wants_mouse());

        const VkExtent2D extent = frames.extent();
        const float aspect = float(extent.width) / float(extent.height);
        const glm::mat4 view_projection = controls.camera.projection(aspect) * controls.camera.view();
        MeshPush push{};
        push.light_dir = glm::vec4(controls.camera.eye() - controls.camera.target, 0.0f);
        pipeline.bind(cmd, extent, controls.wireframe);
        for (size_t i = 0; i < n; ++i) {
            if (views[i].mesh.empty()) continue;
            const nfd_asset_info& info = streamed[i]->info;  // set before the job was published
            push.mvp = view_projection * model_matrix(i, n, info.center, info.scale);
            const float hue = float(i) / float(std::max<size_t>(n, 1));
            const ShaderMode mode = controls.shading == Shading::kNormals ? ShaderMode::kNormals
                                    : controls.colour && views[i].mesh.coloured()
                                        ? ShaderMode::kVertexColour
                                        : ShaderMode::kTint;
            push.tint = glm::vec4(0.75f + 0.2f * std::sin(6.2832f * hue),
                                  0.75f + 0.2f * std::sin(6.2832f * (hue + 0.33f)),
                                  0.75f + 0.2f * std::sin(6.2832f * (hue + 0.67f)), float(int(mode)));
            pipeline.draw(cmd, views[i].mesh, push);
        }
        if (controls.overlay) {
            status.frame_ms = clock.last_ms();
            status.frame_ms_average = clock.average_ms();
            status.shading = controls.shading == Shading::kLit ? "lit" : "normals";
            status.colour = !o.colour ? "off (--no-colour)" : controls.colour ? "on" : "off (C)";
            status.wireframe = controls.wireframe && pipeline.has_wireframe();
            overlay.draw(cmd, status, streamed, views);
        }
        const bool last = headless && frame + 1 >= o.frames && !(o.wait_loaded && loading_now);
        frames.end_frame(last);
        clock.end_frame(loading_now);
        if (last) break;
        if (headless && o.wait_loaded && timed_out())
            throw std::runtime_error("--wait-loaded: assets still loading after --timeout " +
                                     std::to_string(int(o.timeout_s)) + " s");
        clock.pace();
    }

    if (headless) {
        const std::vector<unsigned char> pixels = frames.read_pixels();
        const VkExtent2D e = frames.extent();
        if (!stbi_write_png(o.screenshot.c_str(), int(e.width), int(e.height), 4, pixels.data(),
                            int(e.width) * 4))
            throw std::runtime_error(o.screenshot + ": cannot write the PNG");
    }
    print_summary(streamed, views);
    clock.print_summary();
    return 0;
}

}  // namespace
}  // namespace nfc_viewer

int main(int argc, char** argv) {
    const nfc_viewer::Options options = nfc_viewer::parse_options(argc, argv);
    try {
        return nfc_viewer::run(options);
    } catch (const std::exception& e) {
        nfc_viewer::fail(1, e.what());
    }
}
