// Recording a decode into the host's command buffer (nfd_recording): the test plays an engine
// with its own device (host_vulkan.h), lends it to libnfdecode, records golden-vector decodes
// into its own command buffers, submits and waits itself, and checks that the mesh equals the
// library's own submission byte for byte, that the VkBuffers and the indirect draw record it hands
// out hold that mesh (copied with the host's own commands), and that too small capacities end in
// NFD_ERROR_CAPACITY_EXCEEDED with capacities that work on the next try.
#include <gtest/gtest.h>
#include <vulkan/vulkan.h>

#include <cstring>
#include <string>
#include <vector>

#include "host_vulkan.h"
#include "nfdecode/nfdecode.h"
#include "test_util.h"

namespace nfd::test {
namespace {

struct HostMesh {
    std::vector<float> positions, normals;
    std::vector<uint32_t> indices;
    bool operator==(const HostMesh& o) const {
        return positions == o.positions && normals == o.normals && indices == o.indices;
    }
};

HostMesh host_copy(const nfd_mesh* mesh) {
    nfd_mesh_data d;
    EXPECT_EQ(nfd_mesh_get_data(mesh, &d), NFD_SUCCESS);
    HostMesh m;
    m.positions.assign(d.positions, d.positions + 3 * d.vertex_count);
    m.normals.assign(d.normals, d.normals + 3 * d.vertex_count);
    m.indices.assign(d.indices, d.indices + 3 * d.triangle_count);
    return m;
}

VkBuffer vk_buffer(uint64_t handle) {
    VkBuffer b;
    std::memcpy(&b, &handle, sizeof b);
    return b;
}

class Record : public ::testing::Test {
protected:
    void SetUp() override {
        skip_without_vulkan(host_.create());
        if (IsSkipped() || HasFatalFailure()) return;
        lent_ = host_.lend();
        nfd_context_options options{};
        options.struct_size = sizeof options;
        options.adopt = &lent_;
        ASSERT_EQ(nfd_context_create(&options, &ctx_), NFD_SUCCESS);
        VkCommandPoolCreateInfo pool{};
        pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pool.queueFamilyIndex = host_.family;
        ASSERT_EQ(vkCreateCommandPool(host_.device, &pool, nullptr, &pool_), VK_SUCCESS);
    }
    void TearDown() override {
        for (nfd_asset* a : assets_) nfd_asset_destroy(a);
        nfd_context_destroy(ctx_);
        if (pool_) vkDestroyCommandPool(host_.device, pool_, nullptr);
    }

    nfd_asset* golden(const std::string& name) {
        const Bytes bytes = read_bytes(golden_path(name, ".nfc"));
        nfd_asset* asset = nullptr;
        EXPECT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
        assets_.push_back(asset);
        return asset;
    }

    HostMesh own_submission(const nfd_asset* asset, uint32_t resolution) {
        nfd_mesh_options options{};
        options.resolution = resolution;
        nfd_mesh* mesh = nullptr;
        EXPECT_EQ(nfd_mesh_extract(ctx_, asset, &options, &mesh), NFD_SUCCESS);
        if (!mesh) return {};
        HostMesh m = host_copy(mesh);
        nfd_mesh_destroy(mesh);
        return m;
    }

    // What an engine does: records the decode into its command buffer, then its own copies of the
    // mesh buffers and the draw record into host-visible buffers, submits, waits, finishes.
    struct Run {
        nfd_result finish = NFD_ERROR_INTERNAL;
        nfd_recording_result result{};
        HostMesh read_back, copied;  // nfd_recording_read_mesh; the host's copies of the VkBuffers
        uint32_t draw[5] = {};
    };
    Run run(const nfd_asset* asset, const nfd_recording_options& options) {
        Run out;
        nfd_recording* rec = nullptr;
        nfd_result r = nfd_recording_create(ctx_, asset, &options, &rec);
        EXPECT_EQ(r, NFD_SUCCESS) << nfd_result_string(r);
        if (r != NFD_SUCCESS) return out;
        nfd_device_mesh dm;
        EXPECT_EQ(nfd_recording_get_mesh(rec, &dm), NFD_SUCCESS);

        VkCommandBuffer cmd = host_.begin_commands(pool_);
        EXPECT_NE(cmd, VK_NULL_HANDLE);
        r = nfd_recording_record(rec, cmd);
        EXPECT_EQ(r, NFD_SUCCESS) << nfd_result_string(r);
        EXPECT_EQ(nfd_recording_record(rec, cmd), NFD_ERROR_INVALID_ARGUMENT);  // once
        HostVulkan::HostBuffer positions, normals, indices, draw;
        const VkDeviceSize vertex_bytes = VkDeviceSize(dm.vertex_capacity) * 12;
        const VkDeviceSize index_bytes = VkDeviceSize(dm.triangle_capacity) * 12;
        EXPECT_TRUE(host_.make_host_buffer(vertex_bytes, &positions));
        EXPECT_TRUE(host_.make_host_buffer(vertex_bytes, &normals));
        EXPECT_TRUE(host_.make_host_buffer(index_bytes, &indices));
        EXPECT_TRUE(host_.make_host_buffer(20, &draw));
        auto copy = [&](uint64_t from, const HostVulkan::HostBuffer& to, VkDeviceSize size) {
            const VkBufferCopy region{0, 0, size};
            vkCmdCopyBuffer(cmd, vk_buffer(from), to.buffer, 1, &region);
        };
        copy(dm.positions, positions, vertex_bytes);
        copy(dm.normals, normals, vertex_bytes);
        copy(dm.indices, indices, index_bytes);
        copy(dm.draw, draw, 20);
        VkMemoryBarrier to_host{};
        to_host.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
        to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                             &to_host, 0, nullptr, 0, nullptr);
        EXPECT_TRUE(host_.submit_and_wait(cmd));

        out.result.struct_size = sizeof out.result;
        out.finish = nfd_recording_finish(rec, &out.result);
        nfd_recording_result again{};
        EXPECT_EQ(nfd_recording_finish(rec, &again), out.finish);  // the scratch is gone by now
        EXPECT_EQ(again.triangle_count, out.result.triangle_count);
        EXPECT_EQ(again.needed_cells, out.result.needed_cells);
        std::memcpy(out.draw, draw.data, 20);
        if (out.finish == NFD_SUCCESS) {
            nfd_mesh* mesh = nullptr;
            EXPECT_EQ(nfd_recording_read_mesh(rec, &mesh), NFD_SUCCESS);
            if (mesh) out.read_back = host_copy(mesh);
            nfd_mesh_destroy(mesh);
            const size_t v = 3 * size_t(out.result.vertex_count);
            const size_t t = 3 * size_t(out.result.triangle_count);
            const float* p = static_cast<const float*>(positions.data);
            const float* n = static_cast<const float*>(normals.data);
            const uint32_t* i = static_cast<const uint32_t*>(indices.data);
            out.copied.positions.assign(p, p + v);
            out.copied.normals.assign(n, n + v);
            out.copied.indices.assign(i, i + t);
        } else {
            nfd_mesh* mesh = nullptr;
            EXPECT_EQ(nfd_recording_read_mesh(rec, &mesh), NFD_ERROR_INVALID_ARGUMENT);
        }
        for (HostVulkan::HostBuffer* b : {&positions, &normals, &indices, &draw}) host_.destroy(*b);
        vkFreeCommandBuffers(host_.device, pool_, 1, &cmd);
        nfd_recording_destroy(rec);
        return out;
    }

    HostVulkan host_;
    nfd_vulkan_device lent_{};
    nfd_context* ctx_ = nullptr;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    std::vector<nfd_asset*> assets_;
};

// SDF and UDF golden vectors at a resolution with one and with three refinement levels: the
// recorded decode's mesh is the library's own submission's, in read_mesh, in the VkBuffers the
// host copied, and in the draw record.
TEST_F(Record, HostCommandBufferGivesTheOwnSubmissionsMesh) {
    for (const char* name : {"bunny_sdf_w32", "tshirt_udf_w16"}) {
        for (uint32_t resolution : {64u, 256u}) {
            SCOPED_TRACE(std::string(name) + " at " + std::to_string(resolution));
            const nfd_asset* asset = golden(name);
            const HostMesh own = own_submission(asset, resolution);
            ASSERT_FALSE(own.indices.empty());
            nfd_recording_options options{};
            options.struct_size = sizeof options;
            options.resolution = resolution;
            const Run rec = run(asset, options);
            ASSERT_EQ(rec.finish, NFD_SUCCESS) << nfd_result_string(rec.finish);
            EXPECT_TRUE(rec.read_back == own);
            EXPECT_TRUE(rec.copied == own);
            EXPECT_EQ(rec.result.triangle_count * 3, own.indices.size());
            EXPECT_EQ(rec.draw[0], own.indices.size());  // indexCount
            EXPECT_EQ(rec.draw[1], 1u);                  // instanceCount
            EXPECT_GT(rec.result.stats.points_evaluated, 0u);
            EXPECT_GT(rec.result.stats.active_cells, 0u);
        }
    }
}

// Capacities far too small: an overflow (nothing drawn), needed capacities above the given ones;
// retrying with them converges to the own submission's mesh within a few tries.
TEST_F(Record, OverflowGivesNeededCapacitiesThatWork) {
    for (const char* name : {"bunny_sdf_w16", "bunny_scans_udf_w16"}) {
        SCOPED_TRACE(name);
        const nfd_asset* asset = golden(name);
        const HostMesh own = own_submission(asset, 128);
        nfd_recording_options options{};
        options.struct_size = sizeof options;
        options.resolution = 128;
        options.max_cells = options.max_gradient_points = options.max_vertices =
            options.max_triangles = 8;
        Run rec = run(asset, options);
        ASSERT_EQ(rec.finish, NFD_ERROR_CAPACITY_EXCEEDED);
        EXPECT_EQ(rec.draw[0], 0u);
        EXPECT_EQ(rec.result.triangle_count, 0u);
        EXPECT_GT(rec.result.needed_cells, 8u);
        int tries = 1;
        while (rec.finish == NFD_ERROR_CAPACITY_EXCEEDED && tries < 6) {
            const nfd_recording_options before = options;
            options.max_cells = rec.result.needed_cells;
            options.max_gradient_points = rec.result.needed_gradient_points;
            options.max_vertices = rec.result.needed_vertices;
            options.max_triangles = rec.result.needed_triangles;
            EXPECT_NE(std::memcmp(&before, &options, sizeof options), 0) << "no capacity grew";
            rec = run(asset, options);
            ++tries;
        }
        ASSERT_EQ(rec.finish, NFD_SUCCESS) << "after " << tries << " tries";
        EXPECT_TRUE(rec.read_back == own);
        EXPECT_EQ(rec.draw[0], own.indices.size());
    }
}

// Hostile values that pass the CRC (flipped bytes of SDF and UDF networks, re-sealed), recorded
// at 16 cells: each ends in a finite mesh, a capacity overflow, or an error code, never a crash.
TEST_F(Record, AcceptedDamageRecordsFiniteMeshesOrErrors) {
    size_t meshed = 0, files = 0;
    for (uint32_t field : {0u, 1u}) {
        for_each_accepted_damaged_file(
            geom_payload(random_siren(8, 8, 7, field)), 53, {0xFF},
            [&](size_t i, const Bytes& bytes, const Geometry&) {
                SCOPED_TRACE(i);
                nfd_asset* asset = nullptr;
                ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);
                assets_.push_back(asset);
                nfd_recording_options options{};
                options.resolution = 16;
                const Run rec = run(asset, options);
                ++files;
                ASSERT_TRUE(rec.finish == NFD_SUCCESS || rec.finish == NFD_ERROR_CAPACITY_EXCEEDED)
                    << nfd_result_string(rec.finish);
                for (float v : rec.read_back.positions) ASSERT_TRUE(std::isfinite(v));
                for (float v : rec.read_back.normals) ASSERT_TRUE(std::isfinite(v));
                for (uint32_t k : rec.read_back.indices)
                    ASSERT_LT(k, rec.read_back.positions.size() / 3);
                meshed += !rec.read_back.indices.empty();
            });
    }
    EXPECT_GT(files, 10u);
    EXPECT_GT(meshed, 0u);
}

TEST_F(Record, RejectsWhatItCannotRecord) {
    const nfd_asset* asset = golden("bunny_sdf_w16");
    nfd_recording* rec = reinterpret_cast<nfd_recording*>(0x1);
    EXPECT_EQ(nfd_recording_create(nullptr, asset, nullptr, &rec), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(rec, nullptr);
    EXPECT_EQ(nfd_recording_create(ctx_, asset, nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context_options cpu_options{};
    cpu_options.device = NFD_DEVICE_CPU;
    nfd_context* cpu = nullptr;
    ASSERT_EQ(nfd_context_create(&cpu_options, &cpu), NFD_SUCCESS);
    EXPECT_EQ(nfd_recording_create(cpu, asset, nullptr, &rec), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context_destroy(cpu);
    nfd_recording_options options{};
    options.resolution = 4096;
    EXPECT_EQ(nfd_recording_create(ctx_, asset, &options, &rec), NFD_ERROR_LIMIT_EXCEEDED);
    options.resolution = 64;
    options.max_cells = NFD_MAX_RECORDING_CELLS + 1;
    EXPECT_EQ(nfd_recording_create(ctx_, asset, &options, &rec), NFD_ERROR_LIMIT_EXCEEDED);
    options.max_cells = 0;
    for (uint32_t* capacity :
         {&options.max_gradient_points, &options.max_vertices, &options.max_triangles}) {
        *capacity = NFD_MAX_RECORDING_ITEMS + 1;
        EXPECT_EQ(nfd_recording_create(ctx_, asset, &options, &rec), NFD_ERROR_LIMIT_EXCEEDED);
        *capacity = UINT32_MAX;
        EXPECT_EQ(nfd_recording_create(ctx_, asset, &options, &rec), NFD_ERROR_LIMIT_EXCEEDED);
        *capacity = 0;
    }
    options.struct_size = sizeof options + 8;  // a newer header's struct: its unknown tail...
    std::vector<uint8_t> newer(sizeof options + 8, 0xFF);  // ...not zero
    std::memcpy(newer.data(), &options, sizeof options);
    EXPECT_EQ(nfd_recording_create(ctx_, asset,
                                   reinterpret_cast<const nfd_recording_options*>(newer.data()),
                                   &rec),
              NFD_ERROR_INVALID_ARGUMENT);
    options.struct_size = 0;
    ASSERT_EQ(nfd_recording_create(ctx_, asset, &options, &rec), NFD_SUCCESS);
    nfd_recording_result result{};
    EXPECT_EQ(nfd_recording_finish(rec, &result), NFD_ERROR_INVALID_ARGUMENT);  // not recorded
    nfd_mesh* mesh = nullptr;
    EXPECT_EQ(nfd_recording_read_mesh(rec, &mesh), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_recording_record(rec, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    result.struct_size = 4;
    EXPECT_EQ(nfd_recording_finish(rec, &result), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_recording_get_mesh(rec, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_recording_destroy(rec);  // never recorded: nothing pending
    nfd_recording_destroy(nullptr);
}

}  // namespace
}  // namespace nfd::test
