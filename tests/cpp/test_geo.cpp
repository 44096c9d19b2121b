// Geo-referenced frames (FORMAT.md `fram`, 1.2; nfdecode.h "Positions and the offset"): the
// golden range-scan cloud placed 600 km east and 200 km north of its origin, in metres, decodes
// with its frame error under a millimetre in the PLY, glTF and VDB outputs, on every device.
//
// The check: the same network in a file whose frame is centred at zero (its "twin") decodes to
// the local positions u * scale; the geo file's output must be the exact center plus those, to
// 1 mm. f32 output coordinates there have a step of 6 cm (shown below), so the test fails
// without the 64-bit frame.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#if NFD_WITH_OPENVDB
#include <openvdb/openvdb.h>
#endif

#include "colour_util.h"
#include "test_util.h"

namespace nfd::test {
namespace {

constexpr double kFrameTolerance = 1e-3;  // metres: the acceptance's 1 mm
const char* const kGeoVector = "bunny_scans_geo_udf_w16";

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("nfd_geo_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

double load_f64(const Bytes& b, size_t at) {
    double v;
    std::memcpy(&v, b.data() + at, 8);
    return v;
}

// The golden geo file, its `fram` values read from the bytes, and its twin: GEOM alone with the
// center set to zero (format 1.0), the same network and scale.
struct GeoFiles {
    Bytes geo, twin;
    double center[3];
    double scale;
};

GeoFiles geo_files() {
    GeoFiles f;
    f.geo = read_bytes(golden_path(kGeoVector, ".nfc"));
    const uint32_t geom_length = uint32_t(f.geo[20]) | uint32_t(f.geo[21]) << 8 |
                                 uint32_t(f.geo[22]) << 16 | uint32_t(f.geo[23]) << 24;
    const size_t frame_at = 16 + 12 + geom_length;
    if (std::string(f.geo.begin() + long(frame_at), f.geo.begin() + long(frame_at) + 4) != "fram")
        throw std::runtime_error("the geo vector's second chunk is not fram");
    for (int a = 0; a < 3; ++a) f.center[a] = load_f64(f.geo, frame_at + 8 + 8 * size_t(a));
    f.scale = load_f64(f.geo, frame_at + 32);
    Bytes geom(f.geo.begin() + 24, f.geo.begin() + 24 + long(geom_length));
    for (size_t at = 5; at < 17; ++at) geom[at] = 0;  // GEOM's f32 center (after type, d*)
    f.twin = file({chunk("GEOM", geom)});
    return f;
}

// max over vertices of |written - (center + twin)|, the frame error of an output.
double frame_error(const std::vector<double>& written, const double center[3],
                   const std::vector<float>& twin) {
    EXPECT_EQ(written.size(), twin.size());
    double worst = 0;
    for (size_t i = 0; i < std::min(written.size(), twin.size()); ++i)
        worst = std::max(worst, std::fabs(written[i] - (center[i % 3] + double(twin[i]))));
    return worst;
}

TEST(Geo, TheFrameIsExactAndPositionsAreLocal) {
    const GeoFiles f = geo_files();
    EXPECT_GT(std::fabs(f.center[0]), 5e5);  // what the vector is for
    const AssetPtr geo = make_asset(f.geo), twin = make_asset(f.twin);
    nfd_asset_frame frame{};
    frame.struct_size = sizeof frame;
    ASSERT_EQ(nfd_asset_get_frame(geo.get(), &frame), NFD_SUCCESS);
    EXPECT_EQ(frame.exact64, 1);
    for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(frame.center[a], f.center[a]);
        EXPECT_EQ(frame.offset[a], f.center[a]);
    }
    EXPECT_EQ(frame.scale, f.scale);
    nfd_asset_info info{};
    ASSERT_EQ(nfd_asset_get_info(geo.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.format_minor, 2u);
    EXPECT_EQ(info.center[0], float(f.center[0]));  // a 1.0 reader's frame

    // Files without the chunk: the f32 frame widened, no offset.
    ASSERT_EQ(nfd_asset_get_frame(twin.get(), &frame), NFD_SUCCESS);
    EXPECT_EQ(frame.exact64, 0);
    EXPECT_EQ(frame.center[0], 0.0);
    EXPECT_EQ(frame.offset[1], 0.0);
    nfd_asset_frame small{};
    small.struct_size = 8;  // below the layout
    EXPECT_EQ(nfd_asset_get_frame(geo.get(), &small), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_asset_get_frame(nullptr, &frame), NFD_ERROR_INVALID_ARGUMENT);

    for (const ContextPtr& ctx : cpu_and_vulkan_contexts()) {
        SCOPED_TRACE(nfd_context_device_name(ctx.get()));
        const MeshPtr mesh = extract(ctx.get(), geo.get(), 128);
        const MeshArrays local = arrays_of(mesh.get());
        EXPECT_TRUE(local.same_geometry(arrays_of(extract(ctx.get(), twin.get(), 128).get())));
        EXPECT_GT(local.indices.size(), 3000u);
        double offset[3];
        EXPECT_EQ(nfd_mesh_get_offset(nullptr, offset), NFD_ERROR_INVALID_ARGUMENT);
        EXPECT_EQ(nfd_mesh_get_offset(mesh.get(), nullptr), NFD_ERROR_INVALID_ARGUMENT);
        ASSERT_EQ(nfd_mesh_get_offset(mesh.get(), offset), NFD_SUCCESS);
        for (int a = 0; a < 3; ++a) EXPECT_EQ(offset[a], f.center[a]);
        // Without the 64-bit frame positions would be f32 at 600 km: a 6 cm step, which moves
        // vertices by more than the tolerance. This is what the test guards against.
        double snapped = 0;
        for (size_t i = 0; i < local.positions.size(); ++i) {
            const double exact = f.center[i % 3] + double(local.positions[i]);
            snapped = std::max(snapped, std::fabs(double(float(exact)) - exact));
        }
        EXPECT_GT(snapped, 10 * kFrameTolerance);
    }
}

// Progressive levels and queue jobs carry the offset with their meshes, as nfd_mesh_extract's.
TEST(Geo, ProgressiveLevelsAndQueueJobsCarryTheOffset) {
    const GeoFiles f = geo_files();
    const AssetPtr geo = make_asset(f.geo);
    for (const ContextPtr& ctx : cpu_and_vulkan_contexts()) {
        SCOPED_TRACE(nfd_context_device_name(ctx.get()));
        nfd_extraction_options eo{};
        eo.struct_size = sizeof eo;
        eo.resolution = 64;
        nfd_extraction* ex = nullptr;
        ASSERT_EQ(nfd_extraction_create(ctx.get(), geo.get(), &eo, &ex), NFD_SUCCESS);
        nfd_extraction_level level{};
        level.struct_size = sizeof level;
        do {
            nfd_mesh* m = nullptr;
            ASSERT_EQ(nfd_extraction_step(ex, &m, &level), NFD_SUCCESS);
            const MeshPtr mesh(m);
            double offset[3];
            ASSERT_EQ(nfd_mesh_get_offset(mesh.get(), offset), NFD_SUCCESS);
            for (int a = 0; a < 3; ++a) EXPECT_EQ(offset[a], f.center[a]) << level.resolution;
        } while (!level.done);
        nfd_extraction_destroy(ex);

        nfd_queue* q = nullptr;
        ASSERT_EQ(nfd_queue_create(ctx.get(), nullptr, &q), NFD_SUCCESS);
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = 64;
        nfd_job* job = nullptr;
        ASSERT_EQ(nfd_queue_submit(q, geo.get(), &mo, nullptr, &job), NFD_SUCCESS);
        ASSERT_EQ(nfd_job_wait(job, UINT64_MAX), NFD_JOB_DONE);
        nfd_mesh* m = nullptr;
        ASSERT_EQ(nfd_job_take_mesh(job, &m), NFD_SUCCESS);
        const MeshPtr mesh(m);
        double offset[3];
        ASSERT_EQ(nfd_mesh_get_offset(mesh.get(), offset), NFD_SUCCESS);
        for (int a = 0; a < 3; ++a) EXPECT_EQ(offset[a], f.center[a]);
        EXPECT_TRUE(arrays_of(mesh.get()).same_geometry(arrays_of(extract(ctx.get(), geo.get(), 64).get())));
        nfd_job_destroy(job);
        nfd_queue_destroy(q);
    }
}

// Acceptance: the mesh PLY, the point PLY and nfc-decode's outputs hold offset + position in
// double, within 1 mm of the exact placement.
TEST(Geo, PlyHasTheExactPositions) {
    const GeoFiles f = geo_files();
    const ContextPtr ctx = cpu_context();
    const AssetPtr geo = make_asset(f.geo), twin = make_asset(f.twin);
    const MeshPtr mesh = extract(ctx.get(), geo.get(), 128);
    const MeshPtr twin_mesh = extract(ctx.get(), twin.get(), 128);
    const std::string ply = temp_path("mesh.ply");
    ASSERT_EQ(nfd_mesh_write_ply(mesh.get(), ply.c_str()), NFD_SUCCESS);
    std::vector<double> written;
    const MeshData read = read_ply(ply, &written);
    EXPECT_EQ(std_vector(read.indices), arrays_of(twin_mesh.get()).indices);
    EXPECT_LE(frame_error(written, f.center, arrays_of(twin_mesh.get()).positions), kFrameTolerance);
    const Bytes ply_bytes = read_bytes(ply);
    const std::string header(ply_bytes.begin(), ply_bytes.begin() + 200);
    EXPECT_NE(header.find("property double x"), std::string::npos) << header;

    // Points: sampled on the local mesh (seed 0, as nfc-decode --points), written with the
    // mesh's offset.
    const size_t n = 2000;
    std::vector<float> points(3 * n), twin_points(3 * n);
    ASSERT_EQ(nfd_mesh_sample_points(mesh.get(), n, 0, points.data(), nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_sample_points(twin_mesh.get(), n, 0, twin_points.data(), nullptr),
              NFD_SUCCESS);
    double offset[3];
    ASSERT_EQ(nfd_mesh_get_offset(mesh.get(), offset), NFD_SUCCESS);
    ASSERT_EQ(nfd_points_write_placed_ply(points.data(), nullptr, nullptr, n, offset, ply.c_str()),
              NFD_SUCCESS);
    written.clear();
    read_ply(ply, &written);
    EXPECT_LE(frame_error(written, f.center, twin_points), kFrameTolerance);
    // A zero offset (or none) keeps the float layout of earlier versions.
    const double zero[3] = {0, 0, 0};
    ASSERT_EQ(nfd_points_write_placed_ply(points.data(), nullptr, nullptr, n, zero, ply.c_str()),
              NFD_SUCCESS);
    const Bytes plain = read_bytes(ply);
    EXPECT_NE(std::string(plain.begin(), plain.begin() + 200).find("property float x"),
              std::string::npos);
    EXPECT_EQ(nfd_points_write_placed_ply(nullptr, nullptr, nullptr, 3, offset, ply.c_str()),
              NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_points_write_placed_ply(points.data(), nullptr, nullptr, n, offset, nullptr),
              NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_points_write_placed_ply(points.data(), nullptr, nullptr, n, offset,
                                          "/nonexistent-dir/x.ply"),
              NFD_ERROR_IO);
    std::remove(ply.c_str());

#ifdef NFD_CLI_PATH
    const std::string in = temp_path("geo.nfc"), out = temp_path("cli.ply");
    std::ofstream(in, std::ios::binary)
        .write(reinterpret_cast<const char*>(f.geo.data()), std::streamsize(f.geo.size()));
    for (const std::string extra : {"", " --points 2000"}) {
        const std::string cmd = std::string(NFD_CLI_PATH) + " " + in + " -o " + out +
                                " --device cpu --resolution 128" + extra;
        ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
        written.clear();
        read_ply(out, &written);
        EXPECT_LE(frame_error(written, f.center,
                              extra.empty() ? arrays_of(twin_mesh.get()).positions : twin_points),
                  kFrameTolerance)
            << extra;
    }
    std::remove(in.c_str());
    std::remove(out.c_str());
#endif
}

// Acceptance: the glTF node carries the exact center as its translation; positions stay local
// f32, as an engine wants them.
TEST(Geo, GltfNodeCarriesTheOffset) {
    const GeoFiles f = geo_files();
    const ContextPtr ctx = cpu_context();
    const AssetPtr geo = make_asset(f.geo), twin = make_asset(f.twin);
    const MeshPtr mesh = extract(ctx.get(), geo.get(), 128);
    const std::string glb = temp_path("mesh.glb");
    ASSERT_EQ(nfd_mesh_write_glb(mesh.get(), glb.c_str()), NFD_SUCCESS);
    const Bytes bytes = read_bytes(glb);
    std::remove(glb.c_str());
    ASSERT_GE(bytes.size(), 20u);
    const uint32_t json_length = uint32_t(bytes[12]) | uint32_t(bytes[13]) << 8 |
                                 uint32_t(bytes[14]) << 16 | uint32_t(bytes[15]) << 24;
    const nlohmann::json doc =
        nlohmann::json::parse(bytes.begin() + 20, bytes.begin() + 20 + json_length);
    const auto& translation = doc.at("nodes").at(0).at("translation");
    ASSERT_EQ(translation.size(), 3u);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(translation[size_t(a)].get<double>(), f.center[a]);
    // POSITION is local: its bounds are those of the twin's mesh, within the unit ball's scale.
    const auto& bounds = doc.at("accessors").at(0);
    const std::vector<float> twin_positions = arrays_of(extract(ctx.get(), twin.get(), 128).get()).positions;
    for (int a = 0; a < 3; ++a) {
        float lo = INFINITY;
        for (size_t i = size_t(a); i < twin_positions.size(); i += 3) lo = std::min(lo, twin_positions[i]);
        EXPECT_EQ(bounds.at("min")[size_t(a)].get<double>(), double(lo));
        // The frame error at the lowest vertex: translation + local vs center + twin.
        EXPECT_LE(std::fabs(translation[size_t(a)].get<double>() + bounds.at("min")[size_t(a)].get<double>() -
                            (f.center[a] + double(lo))),
                  kFrameTolerance);
    }
}

#if NFD_WITH_OPENVDB
// Acceptance: the VDB transform, in double, places every voxel within 1 mm of center + its twin
// position.
TEST(Geo, VdbTransformIsExact) {
    const GeoFiles f = geo_files();
    const ContextPtr ctx = cpu_context();
    const AssetPtr geo = make_asset(f.geo), twin = make_asset(f.twin);
    nfd_grid_options go{};
    go.struct_size = sizeof go;
    go.resolution = 64;
    nfd_grid *grid = nullptr, *twin_grid = nullptr;
    ASSERT_EQ(nfd_grid_extract(ctx.get(), geo.get(), &go, &grid), NFD_SUCCESS);
    ASSERT_EQ(nfd_grid_extract(ctx.get(), twin.get(), &go, &twin_grid), NFD_SUCCESS);
    double offset[3];
    ASSERT_EQ(nfd_grid_get_offset(grid, offset), NFD_SUCCESS);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(offset[a], f.center[a]);
    nfd_grid_voxels v{}, t{};
    ASSERT_EQ(nfd_grid_get_voxels(grid, &v), NFD_SUCCESS);
    ASSERT_EQ(nfd_grid_get_voxels(twin_grid, &t), NFD_SUCCESS);
    ASSERT_EQ(v.count, t.count);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(v.origin[a], t.origin[a]);  // both -scale: local
    const std::string path = temp_path("grid.vdb");
    ASSERT_EQ(nfd_grid_write_vdb(grid, path.c_str(), "geo.nfc"), NFD_SUCCESS);
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    const openvdb::GridBase::Ptr read = file.readGrid("distance");
    file.close();
    std::remove(path.c_str());
    const openvdb::math::Transform& xf = read->transform();
    double worst = 0;
    ASSERT_TRUE(std::equal(v.ijk, v.ijk + 3 * v.count, t.ijk));  // the same voxels
    for (size_t n = 0; n < v.count; n += 97) {
        const int32_t* ijk = v.ijk + 3 * n;
        const openvdb::Vec3d world = xf.indexToWorld(openvdb::Coord(ijk[0], ijk[1], ijk[2]));
        for (int a = 0; a < 3; ++a) {
            const double twin_position = double(ijk[a]) * double(t.voxel_size) + double(t.origin[a]);
            worst = std::max(worst, std::fabs(world[a] - (f.center[a] + twin_position)));
        }
    }
    EXPECT_LE(worst, kFrameTolerance);
    nfd_grid_destroy(grid);
    nfd_grid_destroy(twin_grid);
}
#endif

}  // namespace
}  // namespace nfd::test
