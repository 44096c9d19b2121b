// The nfc-decode sample as a user meets it: a decode with --stats, a progressive one (--levels),
// and one-line errors with a non-zero exit status for bad command lines and bad files.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "export.h"
#include "test_util.h"

namespace nfd::test {
namespace {

struct CliRun {
    int status;
    std::string out, err;
};

CliRun run_cli(const std::string& args) {
    const std::string dir = std::filesystem::temp_directory_path().string();
    const std::string out = dir + "/nfd_cli_out_" + std::to_string(::getpid());
    const std::string err = dir + "/nfd_cli_err_" + std::to_string(::getpid());
    const int raw = std::system((std::string(NFD_CLI_PATH) + " " + args + " >" + out + " 2>" + err).c_str());
    CliRun r{WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, {}, {}};
    const Bytes o = read_bytes(out), e = read_bytes(err);
    r.out.assign(o.begin(), o.end());
    r.err.assign(e.begin(), e.end());
    std::remove(out.c_str());
    std::remove(err.c_str());
    return r;
}

std::string temp_file(const std::string& name, const Bytes& bytes) {
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("nfd_cli_" + std::to_string(::getpid()) + "_" + name))
                                 .string();
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                std::streamsize(bytes.size()));
    return path;
}

void expect_one_line_error(const CliRun& r, int status, const std::string& fragment) {
    EXPECT_EQ(r.status, status) << r.err;
    EXPECT_EQ(r.err.rfind("nfc-decode: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
}

TEST(Cli, DecodesToGlbAndPlyWithStats) {
    const std::string in = temp_file("blob.nfc", geom_file(closed_blob()));
    const std::string glb = in + ".glb", ply = in + ".ply";
    CliRun r = run_cli(in + " -o " + glb + " --resolution 32 --device cpu --stats");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    for (const char* line : {"file ", "device ", "read ", "parse ", "field ", "mesh ", "write ",
                             "vertices ", "triangles "})
        EXPECT_NE(r.out.find(line), std::string::npos) << line << " missing in\n" << r.out;
    const Bytes g = read_bytes(glb);
    ASSERT_GE(g.size(), 12u);
    EXPECT_EQ(std::string(g.begin(), g.begin() + 4), "glTF");

    r = run_cli(in + " -o " + ply + " --points 500 --device cpu --resolution 16");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(r.out.empty());  // quiet without --stats
    EXPECT_EQ(read_ply(ply).vertex_count(), 500u);
    for (const std::string& p : {in, glb, ply}) std::remove(p.c_str());
}

// --sample-band: the same mesh of a closed field from more field evaluations (--stats' count).
TEST(Cli, SampleBandGivesTheSameMeshFromMoreEvaluations) {
    const std::string in = temp_file("band.nfc", geom_file(closed_blob()));
    auto evaluated = [](const std::string& out) {
        const size_t at = out.find("points evaluated");
        EXPECT_NE(at, std::string::npos) << out;
        const size_t open = out.rfind('(', at);
        return std::stoull(out.substr(open + 1, at - open - 1));
    };
    const CliRun follow = run_cli(in + " -o " + in + ".f.ply --resolution 128 --device cpu --stats");
    const CliRun band =
        run_cli(in + " -o " + in + ".b.ply --resolution 128 --device cpu --stats --sample-band");
    ASSERT_EQ(follow.status, 0) << follow.err;
    ASSERT_EQ(band.status, 0) << band.err;
    EXPECT_GT(2 * evaluated(band.out), 3 * evaluated(follow.out));
    EXPECT_EQ(read_ply(in + ".f.ply").triangle_count(), read_ply(in + ".b.ply").triangle_count());
    for (const std::string& p : {in, in + ".f.ply", in + ".b.ply"}) std::remove(p.c_str());
}

// A file with colour: --points carries the colour of every point (the field's at the point), the
// mesh PLY its vertices', streamed or not; --no-colour drops it.
TEST(Cli, PointsAndMeshesCarryColour) {
    const std::string in = temp_file(
        "colour.nfc", coloured_file(closed_blob(), random_colour_siren(16, 8, 61)));
    const std::string points = in + ".points.ply", mesh = in + ".mesh.ply";
    CliRun r = run_cli(in + " -o " + points + " --points 800 --device cpu --resolution 32 --stats");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("with colour"), std::string::npos) << r.out;
    const MeshData cloud = read_ply(points);
    ASSERT_EQ(cloud.vertex_count(), 800u);
    ASSERT_EQ(cloud.colours.size(), 3 * 800u);
    // The written bytes are the field's colour at the written points.
    ParsedFile f;
    const Bytes bytes = read_bytes(in);
    ASSERT_EQ(parse_file(bytes.data(), bytes.size(), &f), NFD_SUCCESS);
    std::vector<float> rgb(3 * 800);
    evaluate_cpu(*f.colour, cloud.positions.data(), 800, rgb.data());  // frame: centre 0, scale 1
    for (size_t i = 0; i < rgb.size(); ++i)
        ASSERT_EQ(cloud.colours[i], float(colour_byte(rgb[i])) / 255.0f) << i;

    for (const std::string extra : {"", " --stream-chunk 7"}) {
        r = run_cli(in + " -o " + mesh + " --device cpu --resolution 32" + extra);
        ASSERT_EQ(r.status, 0) << r.err;
        const MeshData m = read_ply(mesh);
        EXPECT_EQ(m.colours.size(), m.positions.size()) << extra;
    }
    r = run_cli(in + " -o " + points + " --points 100 --device cpu --resolution 32 --no-colour");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(read_ply(points).colours.empty());
    for (const std::string& p : {in, points, mesh}) std::remove(p.c_str());
}

TEST(Cli, ErrorsAreOneLineWithNonZeroStatus) {
    const std::string good = temp_file("good.nfc", geom_file(closed_blob()));
    Bytes cut = geom_file(closed_blob());
    cut.resize(cut.size() / 2);
    const std::string truncated = temp_file("cut.nfc", cut);

    expect_one_line_error(run_cli(""), 2, "no input file");
    expect_one_line_error(run_cli(good), 2, "no output file");
    expect_one_line_error(run_cli(good + " -o out.obj"), 2, ".glb or .ply");
    expect_one_line_error(run_cli(good + " -o x.glb --resolution 7"), 2, "--resolution");
    expect_one_line_error(run_cli(good + " -o x.glb --resolution 12abc"), 2, "--resolution");
    expect_one_line_error(run_cli(good + " -o x.glb --device gpu"), 2, "--device");
    expect_one_line_error(run_cli(good + " -o x.glb --threads 0"), 2, "--threads");
    expect_one_line_error(run_cli(good + " -o x.glb --threads -2"), 2, "--threads");
    expect_one_line_error(run_cli(good + " -o x.glb --points 5"), 2, "point cloud");
    expect_one_line_error(run_cli(good + " -o x.vdb --points 5"), 2, "point cloud");
    expect_one_line_error(run_cli(good + " -o x.glb --frobnicate"), 2, "unknown option");
    expect_one_line_error(run_cli(good + " " + good + " -o x.glb"), 2, "more than one input");
    expect_one_line_error(run_cli("/nonexistent.nfc -o x.glb"), 1, "cannot open");
    expect_one_line_error(run_cli(truncated + " -o x.glb"), 1, "truncated");
    expect_one_line_error(run_cli(good + " -o /nonexistent-dir/x.glb --device cpu --resolution 8"), 1,
                          "could not be written");
#if NFD_WITH_OPENVDB
    expect_one_line_error(run_cli(good + " -o /nonexistent-dir/x.vdb --device cpu --resolution 8"), 1,
                          "could not be written");
#else
    expect_one_line_error(run_cli(good + " -o x.vdb --device cpu --resolution 8"), 1,
                          "built without OpenVDB");
#endif
    for (const std::string& p : {good, truncated}) std::remove(p.c_str());
}

// --stream-chunk feeds the file through nfd_stream: the output is the plain decode's, byte for byte.
TEST(Cli, StreamedInputWritesTheSameFile) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    const std::string dir = std::filesystem::temp_directory_path().string() + "/nfd_cli_stream_" +
                            std::to_string(::getpid());
    const std::string common = " --device cpu --resolution 48 -o " + dir;
    ASSERT_EQ(run_cli(in + common + "plain.glb").status, 0);
    const Bytes plain = read_bytes(dir + "plain.glb");
    ASSERT_GT(plain.size(), 1000u);
    for (const char* chunk : {"1", "7", "100000"}) {
        const std::string out = dir + "streamed" + chunk + ".glb";
        const CliRun r = run_cli(in + common + "streamed" + chunk + ".glb --stream-chunk " + chunk);
        ASSERT_EQ(r.status, 0) << chunk << r.err;
        EXPECT_TRUE(read_bytes(out) == plain) << "--stream-chunk " << chunk;
        std::remove(out.c_str());
    }
    // The thread count changes nothing either.
    for (const char* threads : {"1", "3"}) {
        const std::string out = dir + "threads" + threads + ".glb";
        const CliRun r = run_cli(in + common + "threads" + threads + ".glb --threads " + threads);
        ASSERT_EQ(r.status, 0) << threads << r.err;
        EXPECT_TRUE(read_bytes(out) == plain) << "--threads " << threads;
        std::remove(out.c_str());
    }
    const CliRun stats = run_cli(in + common + "stats.glb --stream-chunk 64 --stats");
    ASSERT_EQ(stats.status, 0) << stats.err;
    EXPECT_NE(stats.out.find("geometry "), std::string::npos) << stats.out;
    for (const char* name : {"plain.glb", "stats.glb"}) std::remove((dir + name).c_str());
}

// 1500 bytes at 8 KB/s take at least 0.18 s to arrive.
TEST(Cli, BandwidthPacesTheStream) {
    const std::string in = golden_path("tshirt_udf_w16", ".nfc");
    ASSERT_EQ(read_bytes(in).size(), 1500u);
    const std::string out =
        std::filesystem::temp_directory_path().string() + "/nfd_cli_paced_" + std::to_string(::getpid()) + ".glb";
    const auto t0 = std::chrono::steady_clock::now();
    const CliRun r = run_cli(in + " -o " + out + " --device cpu --resolution 8 --stream-chunk 100 "
                             "--bandwidth 8KB/s");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_GE(seconds, 1500.0 / 8192.0);
    std::remove(out.c_str());
}

TEST(Cli, StreamErrors) {
    const std::string good = temp_file("sgood.nfc", geom_file(closed_blob()));
    Bytes cut = geom_file(closed_blob());
    cut.resize(cut.size() - 3);
    const std::string truncated = temp_file("scut.nfc", cut);
    Bytes flipped = geom_file(closed_blob());
    flipped[40] ^= 0x10;
    const std::string corrupt = temp_file("sflip.nfc", flipped);
    const std::string out = " -o x.glb --device cpu --resolution 8";

    expect_one_line_error(run_cli(truncated + out + " --stream-chunk 5"), 1, "truncated");
    expect_one_line_error(run_cli(truncated + out + " --stream-chunk 1 --bandwidth 1MB/s"), 1,
                          "truncated");
    expect_one_line_error(run_cli(corrupt + out + " --stream-chunk 3"), 1, "corrupt");
    expect_one_line_error(run_cli("/nonexistent.nfc" + out + " --stream-chunk 3"), 1, "cannot open");
    expect_one_line_error(run_cli(good + out + " --stream-chunk 0"), 2, "--stream-chunk");
    expect_one_line_error(run_cli(good + out + " --stream-chunk x"), 2, "--stream-chunk");
    for (const char* rate : {"fast", "256", "256kb/s", "256 KB/s", "0KB/s", "-1MB/s", "1e999B/s",
                             "3GB/s", "KB/s", "nanB/s"})
        expect_one_line_error(run_cli(good + out + " --stream-chunk 4 --bandwidth '" + rate + "'"),
                              2, "--bandwidth");
    expect_one_line_error(run_cli(good + out + " --bandwidth 1MB/s"), 2, "--stream-chunk");
    for (const std::string& p : {good, truncated, corrupt}) std::remove(p.c_str());
}

// --levels writes the one-shot decode's file at its last level, --write-levels every level, and
// --stats=json one object per level then a summary whose counts add up.
TEST(Cli, ProgressiveLevelsMatchTheOneShotFile) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    const std::string base = (std::filesystem::temp_directory_path() /
                              ("nfd_cli_" + std::to_string(::getpid()) + "_levels"))
                                 .string();
    for (const char* device : {"cpu", "auto"}) {
        SCOPED_TRACE(device);
        const std::string one = base + "_one.glb", prog = base + ".glb";
        ASSERT_EQ(run_cli(in + " -o " + one + " --resolution 128 --device " + device).status, 0);
        const CliRun r = run_cli(in + " -o " + prog + " --levels 32,64,128 --write-levels " +
                                 "--stats=json --device " + device);
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_EQ(read_bytes(prog), read_bytes(one));
        for (uint32_t res : {32u, 64u, 128u})
            EXPECT_TRUE(std::filesystem::exists(base + "." + std::to_string(res) + ".glb")) << res;
        EXPECT_EQ(read_bytes(base + ".128.glb"), read_bytes(one));

        std::istringstream lines(r.out);
        std::string line;
        std::vector<nlohmann::json> objects;
        while (std::getline(lines, line)) objects.push_back(nlohmann::json::parse(line));
        ASSERT_EQ(objects.size(), 4u) << r.out;
        uint64_t points = 0;
        double elapsed = 0;
        for (size_t i = 0; i < 3; ++i) {
            const nlohmann::json& o = objects[i];
            EXPECT_EQ(o.at("resolution").get<uint32_t>(), 32u << i);
            EXPECT_GE(o.at("elapsed_ms").get<double>(), elapsed);
            elapsed = o.at("elapsed_ms").get<double>();
            EXPECT_GT(o.at("triangles").get<uint64_t>(), 0u);
            points += o.at("points_evaluated").get<uint64_t>();
        }
        const nlohmann::json& summary = objects.back();
        EXPECT_TRUE(summary.at("summary").get<bool>());
        EXPECT_EQ(summary.at("points_evaluated").get<uint64_t>(), points);
        EXPECT_GE(summary.at("elapsed_ms").get<double>(), elapsed);
        // Device memory (nfd_context_get_device_memory): none on the CPU path.
        const uint64_t buffers = summary.at("device_buffers").get<uint64_t>();
        EXPECT_LE(summary.at("device_allocations").get<uint64_t>(), buffers);
        if (std::string(device) == "cpu") EXPECT_EQ(buffers, 0u);
        for (const std::string& p : {one, prog, base + ".32.glb", base + ".64.glb", base + ".128.glb"})
            std::remove(p.c_str());
    }
}

// --levels with --stream-chunk: the levels start from the streamed asset, the clock from the first
// byte fed, and the geometry's arrival (geometry_ms) comes before the first level; a truncated
// stream still fails the run with one line.
TEST(Cli, StreamedProgressiveLevelsMatchTheOneShotFile) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    const std::string base = (std::filesystem::temp_directory_path() /
                              ("nfd_cli_" + std::to_string(::getpid()) + "_streamed_levels"))
                                 .string();
    const std::string one = base + "_one.ply", prog = base + ".ply";
    ASSERT_EQ(run_cli(in + " -o " + one + " --resolution 64 --device cpu").status, 0);
    const CliRun r = run_cli(in + " -o " + prog + " --levels 32,64 --stream-chunk 7 " +
                             "--bandwidth 64KB/s --stats=json --device cpu");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_bytes(prog), read_bytes(one));
    std::istringstream lines(r.out);
    std::string line;
    std::vector<nlohmann::json> objects;
    while (std::getline(lines, line)) objects.push_back(nlohmann::json::parse(line));
    ASSERT_EQ(objects.size(), 3u) << r.out;
    const double geometry = objects.back().at("geometry_ms").get<double>();
    // 64 KB/s: the golden file's bytes take a measurable time to arrive before the first level.
    EXPECT_GT(geometry, 1000.0 * double(read_bytes(in).size()) / (64 * 1024) * 0.9);
    EXPECT_GE(objects[0].at("elapsed_ms").get<double>(), geometry);

    Bytes bytes = read_bytes(in);
    bytes.resize(bytes.size() - 5);
    const std::string truncated = base + "_truncated.nfc";
    std::FILE* f = std::fopen(truncated.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    expect_one_line_error(run_cli(truncated + " -o " + prog + " --levels 32,64 --stream-chunk 7"),
                          1, "truncated");
    for (const std::string& p : {one, prog, truncated}) std::remove(p.c_str());
}

TEST(Cli, BadLevelListsAreOneLineErrors) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    expect_one_line_error(run_cli(in + " -o x.glb --levels 32,100"), 2, "not a level of 100");
    expect_one_line_error(run_cli(in + " -o x.glb --levels 64,32,128"), 2, "ascending");
    expect_one_line_error(run_cli(in + " -o x.glb --levels 32,,64"), 2, "--levels");
    expect_one_line_error(run_cli(in + " -o x.glb --levels 32,64 --resolution 128"), 2,
                          "--resolution");
    expect_one_line_error(run_cli(in + " -o x.vdb --levels 32,64"), 2, "--levels");
    expect_one_line_error(run_cli(in + " -o x.glb --write-levels"), 2, "need --levels");
}

// --pipeline-cache: the first run writes the cache file, a later run starts from it and
// rewrites it, a damaged file is ignored and replaced, and a cache that cannot be saved is a
// warning (the decode still succeeds). On the CPU path there is nothing to save.
TEST(Cli, PipelineCacheFileIsKeptAcrossRuns) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    const std::string base = temp_file("pipelines", {});
    const std::string cache = base + ".bin", out = base + ".glb";
    std::remove(cache.c_str());
    const std::string common = in + " -o " + out + " --resolution 32 --pipeline-cache ";
    ASSERT_EQ(run_cli(common + cache + " --device cpu").status, 0);
    EXPECT_FALSE(std::filesystem::exists(cache));
#if !NFD_WITH_VULKAN
    std::remove(base.c_str());
    GTEST_SKIP() << "built without Vulkan";
#endif
    const CliRun first = run_cli(common + cache + " --device vulkan");
    if (first.status != 0 && first.err.find("device") != std::string::npos) {
        std::remove(base.c_str());
        return skip_without_vulkan(first.err);
    }
    ASSERT_EQ(first.status, 0) << first.err;
    EXPECT_TRUE(first.err.empty()) << first.err;
    const Bytes saved = read_bytes(cache);
    ASSERT_GE(saved.size(), 52u + 32u);  // the envelope and the driver's header at least
    EXPECT_EQ(std::string(saved.begin(), saved.begin() + 4), "NFPC");
    const Bytes mesh = read_bytes(out);
    ASSERT_EQ(run_cli(common + cache + " --device vulkan").status, 0);
    EXPECT_TRUE(read_bytes(out) == mesh);
    std::ofstream(cache, std::ios::binary) << "not a pipeline cache";
    const CliRun damaged = run_cli(common + cache + " --device vulkan");
    ASSERT_EQ(damaged.status, 0) << damaged.err;
    EXPECT_TRUE(read_bytes(out) == mesh);
    EXPECT_EQ(read_bytes(cache).size(), saved.size());
    // Below a regular file: no directory can be made there, even by root.
    const CliRun unsaved = run_cli(common + base + "/pipelines.bin --device vulkan");
    EXPECT_EQ(unsaved.status, 0) << unsaved.err;
    EXPECT_EQ(unsaved.err.rfind("nfc-decode: warning: pipeline cache not saved", 0), 0u)
        << unsaved.err;
    for (const std::string& p : {base, cache, out}) std::remove(p.c_str());
}

}  // namespace
}  // namespace nfd::test
