// nfc-viewer's command line.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "../common/pipeline_cache_file.h"

namespace nfc_viewer {

enum class DecodeDevice { kAuto, kCpu, kVulkan };

struct Options {
    std::vector<std::string> inputs;  // .nfc files, directories expanded (sorted by name)
    double bandwidth = 256.0 * 1024.0;  // bytes per second, per asset
    std::vector<uint32_t> levels{32, 64, 128, 256};  // ascending, on the last one's ladder
    int width = 1280, height = 720;
    std::string screenshot;    // headless: write the last frame here and exit
    int frames = 60;           // with --screenshot: frames to render
    bool wait_loaded = false;  // with --screenshot: also render until every asset is final
    double timeout_s = 300;    // with --wait-loaded: fail if the assets take longer
    bool overlay = true;
    bool colour = true;        // decode and draw colour; --no-colour: geometry only
    bool preload = false;      // decode everything before the first frame (the bench's baseline)
    DecodeDevice decode_device = DecodeDevice::kAuto;
    int fps = 60;              // frame-rate cap; 0: uncapped
    std::string frame_log;     // one line per frame: milliseconds, assets still loading
    uint32_t recording_capacity = 0;  // first try's nfd_recording capacities; 0: the defaults
    // libnfdecode's pipeline cache on the viewer's device, kept between runs ("": none).
    std::string pipeline_cache = nfc_cli::default_pipeline_cache_path();
};

// Parses argv; prints the usage and exits 0 for --help, or prints one line and exits 2 for a bad
// command line (also for a path that does not exist or a directory without .nfc files).
Options parse_options(int argc, char** argv);

// Prints "nfc-viewer: error: <message>" on one line and exits with `status`.
[[noreturn]] void fail(int status, const std::string& message);

}  // namespace nfc_viewer
