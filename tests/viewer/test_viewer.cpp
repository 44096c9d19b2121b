// nfc-viewer as the acceptance uses it: a headless screenshot of the golden vectors under
// Xvfb whose silhouette matches a CPU rasterisation of the same meshes, decoded through the public
// API and placed by the viewer's own layout and camera (scene.h), with IoU >= 0.9, by the default
// decode and by the device's, whose final levels are recorded and drawn in place; a corrupt
// asset shown as failed while the others load; one-line errors. The comparison itself is tested
// to reject an empty or shifted image. The golden colour vector is drawn in its field's colours,
// whether its colour chunk arrives with its geometry or after the final level, and in the tint
// with --no-colour. Only the tests that need a display skip, and only where
// xvfb-run is not installed (scripts/setup.sh installs it).
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>
#include <stb_image.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "scene.h"
#include "silhouette.h"

namespace nfc_viewer::test {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 320, kHeight = 240;
const char* const kVectors[] = {"bunny_scans_udf_w16", "bunny_sdf_w16", "bunny_sdf_w32",
                                "spot_sdf_w24_b6", "tshirt_udf_w16"};

std::string vector_path(const char* name) {
    return std::string(NFC_TEST_VECTORS_DIR) + "/v1_0_" + name + ".nfc";
}

std::vector<unsigned char> read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

struct Outcome {
    int status;
    std::string out, err;
};

// Runs `command` (a shell line) and captures its status and output.
Outcome run(const std::string& command) {
    const std::string base = (fs::temp_directory_path() /
                              ("nfc_viewer_test_" + std::to_string(::getpid()))).string();
    const int raw = std::system((command + " >" + base + ".out 2>" + base + ".err").c_str());
    const std::vector<unsigned char> o = read_bytes(base + ".out"), e = read_bytes(base + ".err");
    fs::remove(base + ".out");
    fs::remove(base + ".err");
    return Outcome{WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, std::string(o.begin(), o.end()),
               std::string(e.begin(), e.end())};
}

bool have_xvfb() { return std::system("command -v xvfb-run >/dev/null 2>&1") == 0; }

std::string viewer_under_xvfb() {
    return std::string("xvfb-run -a -s '-screen 0 640x480x24' ") + NFC_VIEWER_PATH;
}

// The golden vectors decoded on the CPU at `resolution` and rasterised as the viewer lays them out.
Mask reference_silhouette(const std::vector<std::string>& paths, uint32_t resolution) {
    nfd_context_options co = {};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_CPU;
    nfd_context* context = nullptr;
    EXPECT_EQ(nfd_context_create(&co, &context), NFD_SUCCESS);
    const OrbitCamera camera = OrbitCamera::framing(paths.size(), float(kWidth) / float(kHeight));
    const glm::mat4 view_projection = camera.projection(float(kWidth) / kHeight) * camera.view();
    Mask mask(kWidth, kHeight);
    for (size_t i = 0; i < paths.size(); ++i) {
        const std::vector<unsigned char> bytes = read_bytes(paths[i]);
        nfd_asset* asset = nullptr;
        EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS) << paths[i];
        nfd_asset_info info{};
        nfd_asset_get_info(asset, &info);
        nfd_mesh_options mo = {};
        mo.struct_size = sizeof mo;
        mo.resolution = resolution;
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_mesh_extract(context, asset, &mo, &mesh), NFD_SUCCESS) << paths[i];
        nfd_mesh_data data{};
        nfd_mesh_get_data(mesh, &data);
        rasterize(data, view_projection * model_matrix(i, paths.size(), info.center, info.scale),
                  &mask);
        nfd_mesh_destroy(mesh);
        nfd_asset_destroy(asset);
    }
    nfd_context_destroy(context);
    return mask;
}

std::vector<std::string> golden_paths() {
    std::vector<std::string> paths;
    for (const char* name : kVectors) paths.push_back(vector_path(name));
    return paths;
}

std::string joined(const std::vector<std::string>& paths) {
    std::string s;
    for (const std::string& p : paths) s += " '" + p + "'";
    return s;
}

// The comparison can fail: an empty image, or the right silhouette moved by a few pixels.
TEST(Silhouette, RejectsAnEmptyOrShiftedImage) {
    const Mask reference = reference_silhouette(golden_paths(), 32);
    ASSERT_GT(reference.coverage(), 0.03);
    EXPECT_DOUBLE_EQ(iou(reference, reference), 1.0);
    EXPECT_LT(iou(reference, Mask(kWidth, kHeight)), 0.9);
    EXPECT_LT(iou(reference, shifted(reference, 6, 0)), 0.9);
    EXPECT_LT(iou(reference, shifted(reference, 0, -6)), 0.9);
    std::vector<unsigned char> background(size_t(kWidth) * kHeight * 4);
    for (size_t i = 0; i < background.size(); i += 4)
        for (int c = 0; c < 3; ++c) background[i + c] = (unsigned char)std::lround(kBackground[c] * 255);
    EXPECT_EQ(foreground(background.data(), kWidth, kHeight).coverage(), 0.0);
}

// The viewer headless on `paths` with --levels 32,64 and `options`; its screenshot's RGBA pixels
// in *rgba (left empty when there is none).
Outcome screenshot_of(const std::vector<std::string>& paths, const std::string& options,
                      std::vector<unsigned char>* rgba) {
    const std::string png = (fs::temp_directory_path() /
                             ("nfc_viewer_shot_" + std::to_string(::getpid()) + ".png")).string();
    const Outcome r = run(viewer_under_xvfb() + joined(paths) + " --screenshot '" + png +
                      "' --frames 10 --wait-loaded --timeout 120 --no-overlay --levels 32,64" +
                      " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight) +
                      options);
    int w = 0, h = 0, channels = 0;
    unsigned char* pixels = stbi_load(png.c_str(), &w, &h, &channels, 4);
    fs::remove(png);
    if (pixels && w == kWidth && h == kHeight) rgba->assign(pixels, pixels + size_t(w) * h * 4);
    stbi_image_free(pixels);
    return r;
}

// screenshot_of the golden vectors; its foreground in *shot (left empty when there is none).
Outcome screenshot_of_golden_vectors(const std::string& options, Mask* shot) {
    std::vector<unsigned char> rgba;
    const Outcome r = screenshot_of(golden_paths(), options, &rgba);
    if (!rgba.empty()) *shot = foreground(rgba.data(), kWidth, kHeight);
    return r;
}

// The screenshot shows what the CPU decode of the final level (64) rasterises to.
void expect_silhouette_of_final_level(const Mask& shot) {
    const Mask reference = reference_silhouette(golden_paths(), 64);
    std::printf("silhouette IoU %.4f, coverage: screenshot %.4f, reference %.4f\n",
                iou(shot, reference), shot.coverage(), reference.coverage());
    EXPECT_GT(shot.coverage(), 0.05) << "the shapes cover too little of the image";
    EXPECT_GE(iou(shot, reference), 0.9)
        << "coverage: screenshot " << shot.coverage() << ", reference " << reference.coverage();
}

// The summary line of one golden vector (nfc-viewer prints one per asset on exit).
std::string summary_line(const std::string& out, const char* name) {
    const std::string key = std::string("asset v1_0_") + name + ".nfc: ";
    const size_t at = out.find(key);
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
}

TEST(Viewer, ScreenshotSilhouetteMatchesTheDecodedMeshes) {
    if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh installs xvfb)";
    Mask shot(kWidth, kHeight);
    const Outcome r = screenshot_of_golden_vectors("", &shot);
    ASSERT_EQ(r.status, 0) << r.err << r.out;
    for (const char* name : kVectors)
        EXPECT_NE(summary_line(r.out, name).find("done, 64 cells"), std::string::npos) << r.out;
    expect_silhouette_of_final_level(shot);
}

// On the viewer's device the final level is recorded into the viewer's command buffer and drawn
// from libnfdecode's buffers: each asset says so, after the queue's coarser level (32), and with
// a first try's capacities far too small, after at least one overflow recorded again. An upload
// of the final level would say "final mesh uploaded"; the silhouette is the CPU decode's. The
// run leaves libnfdecode's pipeline cache in the file given (nfd_context_get_pipeline_cache).
TEST(Viewer, OnTheDeviceTheFinalLevelIsRecordedAndDrawnInPlace) {
    if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh installs xvfb)";
    Mask shot(kWidth, kHeight);
    const fs::path cache =
        fs::temp_directory_path() / ("nfc_viewer_cache_" + std::to_string(::getpid())) / "p.bin";
    const Outcome r = screenshot_of_golden_vectors(
        " --decode-device vulkan --recording-capacity 64 --pipeline-cache '" + cache.string() + "'",
        &shot);
    const std::vector<unsigned char> saved =
        fs::exists(cache) ? read_bytes(cache.string()) : std::vector<unsigned char>();
    fs::remove_all(cache.parent_path());
    ASSERT_EQ(r.status, 0) << r.err << r.out;
    ASSERT_GE(saved.size(), 4u);
    EXPECT_EQ(std::string(saved.begin(), saved.begin() + 4), "NFPC");
    for (const char* name : kVectors) {
        const std::string line = summary_line(r.out, name);
        SCOPED_TRACE(line);
        EXPECT_NE(line.find(": done, 64 cells"), std::string::npos);
        EXPECT_NE(line.find(" levels 32:"), std::string::npos) << "the coarser level, queued";
        EXPECT_NE(line.find(", final mesh device (recorded), "), std::string::npos);
        unsigned recordings = 0;
        const size_t at = line.find("device (recorded), ");
        if (at != std::string::npos)
            std::sscanf(line.c_str() + at, "device (recorded), %u recordings", &recordings);
        EXPECT_GE(recordings, 2u) << "capacities of 64 must overflow at least once";
    }
    expect_silhouette_of_final_level(shot);
}

TEST(Viewer, ACorruptAssetFailsWhileTheOthersLoad) {
    if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh installs xvfb)";
    const fs::path dir = fs::temp_directory_path() / ("nfc_viewer_dir_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    std::vector<unsigned char> bytes = read_bytes(vector_path("bunny_sdf_w16"));
    std::ofstream(dir / "a_good.nfc", std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    bytes[bytes.size() / 2] ^= 0x40;  // inside GEOM: its CRC fails
    std::ofstream(dir / "b_corrupt.nfc", std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    const Outcome r = run(viewer_under_xvfb() + " '" + dir.string() + "' --screenshot '" +
                      (dir / "shot.png").string() + "' --frames 3 --wait-loaded --levels 32" +
                      " --width 160 --height 120");
    fs::remove_all(dir);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("a_good.nfc: done, 32 cells"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("b_corrupt.nfc: failed: "), std::string::npos) << r.out;
}

// The golden colour vector (format 1.1: v1_1_*.nfc), the first by name; "" when there is none.
std::string colour_vector_path() {
    std::vector<std::string> found;
    for (const fs::directory_entry& e : fs::directory_iterator(NFC_TEST_VECTORS_DIR)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("v1_1_", 0) == 0 && e.path().extension() == ".nfc")
            found.push_back(e.path().string());
    }
    std::sort(found.begin(), found.end());
    return found.empty() ? std::string() : found.front();
}

// What the viewer's lit shading draws of `path` alone at `resolution` in its vertex colours, on
// the CPU, from the viewer's camera and light.
Shaded reference_colours(const std::string& path, uint32_t resolution) {
    nfd_context_options co = {};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_CPU;
    nfd_context* context = nullptr;
    EXPECT_EQ(nfd_context_create(&co, &context), NFD_SUCCESS);
    const std::vector<unsigned char> bytes = read_bytes(path);
    nfd_asset* asset = nullptr;
    EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS) << path;
    nfd_asset_info info{};
    nfd_asset_get_info(asset, &info);
    EXPECT_TRUE(info.has_colour) << path;
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    nfd_mesh* mesh = nullptr;
    EXPECT_EQ(nfd_mesh_extract(context, asset, &mo, &mesh), NFD_SUCCESS) << path;
    nfd_mesh_data data{};
    const float* colours = nullptr;
    nfd_mesh_get_data(mesh, &data);
    nfd_mesh_get_colours(mesh, &colours);
    Shaded image(kWidth, kHeight);
    EXPECT_NE(colours, nullptr) << path;
    if (colours) {
        const OrbitCamera camera = OrbitCamera::framing(1, float(kWidth) / float(kHeight));
        const glm::mat4 mvp = camera.projection(float(kWidth) / kHeight) * camera.view() *
                              model_matrix(0, 1, info.center, info.scale);
        shade(data, colours, mvp, camera.eye() - camera.target, &image);  // main.cpp's light
    }
    nfd_mesh_destroy(mesh);
    nfd_asset_destroy(asset);
    nfd_context_destroy(context);
    return image;
}

// How far a screenshot's colours are from the reference's: the largest channel difference of
// their means (each over its own foreground), and the mean per-pixel channel difference where
// both have a shape. In [0, 1].
struct ColourError {
    double of_means = 1, per_pixel = 1;
};
ColourError colour_error(const std::vector<unsigned char>& rgba, const Shaded& reference) {
    const Mask shot = foreground(rgba.data(), kWidth, kHeight);
    glm::dvec3 shot_sum(0), reference_sum(0);
    double shot_n = 0, reference_n = 0, pixel_sum = 0, both_n = 0;
    for (size_t i = 0; i < shot.covered.size(); ++i) {
        const glm::dvec3 shown = glm::dvec3(rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]) / 255.0;
        const glm::dvec3 expected(reference.rgb[i]);
        if (shot.covered[i]) shot_sum += shown, ++shot_n;
        if (reference.mask.covered[i]) reference_sum += expected, ++reference_n;
        if (shot.covered[i] && reference.mask.covered[i]) {
            const glm::dvec3 d = glm::abs(shown - expected);
            pixel_sum += (d.x + d.y + d.z) / 3.0;
            ++both_n;
        }
    }
    ColourError e;
    if (!shot_n || !reference_n || !both_n) return e;
    const glm::dvec3 d = glm::abs(shot_sum / shot_n - reference_sum / reference_n);
    e.of_means = std::max({d.x, d.y, d.z});
    e.per_pixel = pixel_sum / both_n;
    std::printf("mean colour: screenshot %.3f %.3f %.3f, reference %.3f %.3f %.3f; "
                "per-pixel error %.3f\n", shot_sum.x / shot_n, shot_sum.y / shot_n,
                shot_sum.z / shot_n, reference_sum.x / reference_n, reference_sum.y / reference_n,
                reference_sum.z / reference_n, e.per_pixel);
    return e;
}

// The golden colour vector drawn in its field's colours: when the whole (small) file arrives at
// once, the queue colours its levels; at a bandwidth that brings the colour chunk 2 s after the
// geometry (usually after the final level is shown), the loader thread colours them. With --no-colour
// the same shape is drawn in the tint, which the comparison tells apart. Tolerances: 0.03 of the
// means (8-bit rounding, edge pixels, screen-space interpolation) and 0.05 per pixel.
TEST(Viewer, DrawsTheColourField) {
    if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh installs xvfb)";
    const std::string path = colour_vector_path();
    ASSERT_FALSE(path.empty()) << "no golden colour vector v1_1_*.nfc in " NFC_TEST_VECTORS_DIR;
    const Shaded reference = reference_colours(path, 64);
    ASSERT_GT(reference.mask.coverage(), 0.02);
    // GEOM's end (FORMAT.md: a 16-byte header, then GEOM framed by tag, length and CRC): the
    // colour chunk's bytes follow, brought in 2 s (less for a chunk under a tenth of the file:
    // the whole file in 10 s at most).
    const std::vector<unsigned char> bytes = read_bytes(path);
    ASSERT_GT(bytes.size(), 24u);
    uint32_t geom_length = 0;
    std::memcpy(&geom_length, bytes.data() + 20, 4);  // little-endian, as this host
    const size_t colour_bytes = bytes.size() - (16 + 8 + size_t(geom_length) + 4);
    ASSERT_GT(colour_bytes, 0u);
    const std::string slow =
        " --bandwidth " + std::to_string(std::max(colour_bytes / 2, bytes.size() / 10)) + "B/s";
    const std::string name = fs::path(path).filename().string();
    // 1 GB/s: the whole file is there at the loader thread's first feed, microseconds in.
    const std::string fast = " --bandwidth 1024MB/s";
    for (const std::string& options : {fast, slow}) {
        SCOPED_TRACE(options);
        std::vector<unsigned char> rgba;
        const Outcome r = screenshot_of({path}, options, &rgba);
        ASSERT_EQ(r.status, 0) << r.err << r.out;
        const std::string line = r.out.substr(0, r.out.find('\n'));
        EXPECT_NE(line.find(name + ": done, 64 cells"), std::string::npos) << r.out;
        const char* source = options == fast ? ", colour from the queue" : ", colour added on arrival";
        EXPECT_NE(line.find(source), std::string::npos) << line;
        ASSERT_FALSE(rgba.empty());
        const ColourError e = colour_error(rgba, reference);
        EXPECT_LT(e.of_means, 0.03);
        EXPECT_LT(e.per_pixel, 0.05);
    }
    std::vector<unsigned char> rgba;
    const Outcome r = screenshot_of({path}, " --no-colour", &rgba);
    ASSERT_EQ(r.status, 0) << r.err << r.out;
    EXPECT_NE(r.out.find(", colour none"), std::string::npos) << r.out;
    ASSERT_FALSE(rgba.empty());
    const ColourError e = colour_error(rgba, reference);
    EXPECT_GT(e.per_pixel, 0.05) << "the tint must not pass for the field's colours";
}

void expect_one_line_error(const Outcome& r, int status, const std::string& fragment) {
    EXPECT_EQ(r.status, status) << r.err;
    EXPECT_EQ(r.err.rfind("nfc-viewer: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
}

TEST(Viewer, ErrorsAreOneLine) {
    const std::string viewer = NFC_VIEWER_PATH;
    expect_one_line_error(run(viewer + " /nonexistent/x.nfc"), 2, "no such file");
    expect_one_line_error(run(viewer + " " + vector_path("bunny_sdf_w16") + " --levels 32,100"), 2,
                          "not a level of 100");
    expect_one_line_error(run(viewer + " " + vector_path("bunny_sdf_w16") + " --frames 3"), 2,
                          "--screenshot");
    for (const char* bad : {"x", "-1", "99999999999"})
        expect_one_line_error(run(viewer + " " + vector_path("bunny_sdf_w16") +
                                  " --recording-capacity " + bad),
                              2, "--recording-capacity expects an integer");
    // No display: no X server at all (and no Wayland one).
    expect_one_line_error(run("env -u DISPLAY -u WAYLAND_DISPLAY " + viewer + " " +
                              vector_path("bunny_sdf_w16") + " --screenshot /tmp/x.png"),
                          1, "display");
}

}  // namespace
}  // namespace nfc_viewer::test
