#include "options.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "../common/cli_values.h"

namespace nfc_viewer {
namespace {

const char kUsage[] =
    "usage: nfc-viewer DIR|FILE... [--bandwidth 256KB/s] [--levels 32,64,128,256]\n"
    "                  [--width W --height H] [--decode-device auto|cpu|vulkan]\n"
    "                  [--screenshot OUT.png --frames N [--wait-loaded] [--timeout S]]\n"
    "                  [--no-overlay] [--no-colour] [--preload] [--fps N] [--frame-log FILE]\n"
    "                  [--recording-capacity N] [--pipeline-cache FILE|none]\n"
    "  DIR|FILE        .nfc files, or directories of them (laid out in a grid, by name)\n"
    "  --bandwidth R   each asset arrives at R (B/s, KB/s, MB/s; 1 KB = 1024 B), default 256KB/s\n"
    "  --levels LIST   progressive levels shown as they decode (ascending, on the last one's\n"
    "                  ladder), default 32,64,128,256\n"
    "  --decode-device where libnfdecode decodes: vulkan (the viewer's own VkDevice, adopted),\n"
    "                  cpu, or auto (default: cpu on a CPU implementation such as lavapipe,\n"
    "                  whose threads the render shares; vulkan on a GPU; see bench/RESULTS.md).\n"
    "                  On vulkan the final level is recorded into the viewer's command buffer\n"
    "                  (nfd_recording) and drawn from the library's buffers (zero copy), but\n"
    "                  for a file with colour: recordings are geometry only, so its final\n"
    "                  level comes from the queue, uploaded, coloured\n"
    "  --screenshot F  headless: render --frames N frames (default 60), write the last as PNG\n"
    "  --wait-loaded   with --screenshot: keep rendering until every asset is final\n"
    "  --timeout S     with --wait-loaded: give up after S seconds (default 300)\n"
    "  --no-overlay    hide the ImGui overlay\n"
    "  --no-colour     geometry only: colour fields are not decoded, meshes drawn in the tint\n"
    "  --preload       decode every asset before the first frame (a fully loaded scene)\n"
    "  --fps N         frame-rate cap (default 60; 0: none)\n"
    "  --frame-log F   write one line per frame: frame milliseconds, assets still loading\n"
    "  --recording-capacity N  every capacity of a recording's first try (cells, gradient\n"
    "                  points, vertices, triangles; default 0: libnfdecode's); an overflow is\n"
    "                  recorded again with the capacities it needed\n"
    "  --pipeline-cache FILE|none  with decoding on the device, libnfdecode's compiled kernels\n"
    "                  are kept in FILE between runs (default $XDG_CACHE_HOME/nfc/pipelines.bin,\n"
    "                  else ~/.cache/nfc/pipelines.bin); none: compiled anew each run\n"
    "Mouse: left drag rotates, right drag (or shift + left) pans, wheel zooms.\n"
    "Keys: R reset camera, W wireframe, N shading (lit / normals), C colour (the vertex colours\n"
    "of a file with colour, lit, or the tint), O overlay, Esc quit.\n"
    "A file's colour (format 1.1) is drawn once its colour chunk has arrived, on the levels\n"
    "already shown too.\n";

long parse_int(const std::string& flag, const char* text, long min, long max) {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(text, &end, 10);
    if (!*text || *end || errno || v < min || v > max)
        fail(2, flag + " expects an integer in " + std::to_string(min) + ".." +
                    std::to_string(max) + ", got '" + text + "'");
    return v;
}

// A directory contributes its *.nfc files sorted by name; a file is taken as given (a file that
// exists but cannot be read or decoded is the viewer's to show as failed, not a usage error).
void add_input(const std::string& path, std::vector<std::string>* inputs) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
        std::vector<std::string> found;
        for (const fs::directory_entry& e : fs::directory_iterator(path, ec))
            if (e.path().extension() == ".nfc") found.push_back(e.path().string());
        if (found.empty()) fail(2, path + ": no .nfc files in this directory");
        std::sort(found.begin(), found.end());
        inputs->insert(inputs->end(), found.begin(), found.end());
    } else if (fs::exists(path, ec)) {
        inputs->push_back(path);
    } else {
        fail(2, path + ": no such file or directory");
    }
}

}  // namespace

void fail(int status, const std::string& message) {
    std::fprintf(stderr, "nfc-viewer: error: %s\n", message.c_str());
    std::exit(status);
}

Options parse_options(int argc, char** argv) {
    Options o;
    bool frames_given = false;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        auto value = [&]() -> const char* {
            if (i + 1 >= argc) fail(2, arg + " needs a value");
            return argv[++i];
        };
        std::string error;
        if (arg == "-h" || arg == "--help") {
            std::fputs(kUsage, stdout);
            std::exit(0);
        } else if (arg == "--bandwidth") {
            o.bandwidth = nfc_cli::parse_bandwidth(value(), &error);
        } else if (arg == "--levels") {
            o.levels = nfc_cli::parse_levels(value(), &error);
        } else if (arg == "--width") {
            o.width = int(parse_int(arg, value(), 16, 8192));
        } else if (arg == "--height") {
            o.height = int(parse_int(arg, value(), 16, 8192));
        } else if (arg == "--screenshot") {
            o.screenshot = value();
        } else if (arg == "--frames") {
            o.frames = int(parse_int(arg, value(), 1, 1000000));
            frames_given = true;
        } else if (arg == "--wait-loaded") {
            o.wait_loaded = true;
        } else if (arg == "--timeout") {
            o.timeout_s = double(parse_int(arg, value(), 1, 86400));
        } else if (arg == "--no-overlay") {
            o.overlay = false;
        } else if (arg == "--no-colour") {
            o.colour = false;
        } else if (arg == "--preload") {
            o.preload = true;
        } else if (arg == "--fps") {
            o.fps = int(parse_int(arg, value(), 0, 1000));
        } else if (arg == "--frame-log") {
            o.frame_log = value();
        } else if (arg == "--recording-capacity") {
            o.recording_capacity = uint32_t(parse_int(arg, value(), 0, 1 << 25));
        } else if (arg == "--pipeline-cache") {
            const std::string path = value();
            o.pipeline_cache = path == "none" ? "" : path;
        } else if (arg == "--decode-device") {
            const std::string d = value();
            if (d == "auto") o.decode_device = DecodeDevice::kAuto;
            else if (d == "cpu") o.decode_device = DecodeDevice::kCpu;
            else if (d == "vulkan") o.decode_device = DecodeDevice::kVulkan;
            else error = "--decode-device expects auto, cpu or vulkan, got '" + d + "'";
        } else if (!arg.empty() && arg[0] == '-') {
            error = "unknown option '" + arg + "' (see --help)";
        } else {
            add_input(arg, &o.inputs);
        }
        if (!error.empty()) fail(2, error);
    }
    if (o.inputs.empty()) fail(2, "no input: give .nfc files or directories (see --help)");
    if (o.screenshot.empty() && (frames_given || o.wait_loaded))
        fail(2, "--frames and --wait-loaded go with --screenshot");
    return o;
}

}  // namespace nfc_viewer
