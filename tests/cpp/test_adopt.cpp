// Device adoption through the C API (nfd_context_options.adopt): the test plays the host engine.
// It creates its own instance and device with the Vulkan loader, lends them to libnfdecode, decodes
// a golden vector through the adopted device and on the CPU, and checks that the device is still
// the host's to use (and destroy) after nfd_context_destroy. Skips only when no Vulkan device
// exists at all, unless NFD_REQUIRE_VULKAN is set.
#include <gtest/gtest.h>
#include <vulkan/vulkan.h>

#include <vector>

#include "host_vulkan.h"
#include "nfdecode/nfdecode.h"
#include "test_util.h"

namespace nfd::test {
namespace {

class Adopt : public ::testing::Test {
protected:
    void SetUp() override { skip_without_vulkan(host_.create()); }

    // Runs on the host's queue after libnfdecode is done with it: a fence-signalling submit and a
    // device-wide wait, which fail if the library destroyed or broke the device or queue.
    void expect_host_device_works() {
        VkFenceCreateInfo info{};
        info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VkFence fence = VK_NULL_HANDLE;
        ASSERT_EQ(vkCreateFence(host_.device, &info, nullptr, &fence), VK_SUCCESS);
        EXPECT_EQ(vkQueueSubmit(host_.queue, 0, nullptr, fence), VK_SUCCESS);
        EXPECT_EQ(vkWaitForFences(host_.device, 1, &fence, VK_TRUE, 10'000'000'000ull), VK_SUCCESS);
        vkDestroyFence(host_.device, fence, nullptr);
        EXPECT_EQ(vkDeviceWaitIdle(host_.device), VK_SUCCESS);
    }

    HostVulkan host_;
};

MeshData extract(nfd_context* context, const nfd_asset* asset, uint32_t resolution) {
    MeshData m;
    nfd_mesh_options options{};
    options.resolution = resolution;
    nfd_mesh* mesh = nullptr;
    const nfd_result r = nfd_mesh_extract(context, asset, &options, &mesh);
    EXPECT_EQ(r, NFD_SUCCESS) << nfd_result_string(r);
    if (r != NFD_SUCCESS) return m;
    nfd_mesh_data data;
    EXPECT_EQ(nfd_mesh_get_data(mesh, &data), NFD_SUCCESS);
    m.positions.assign(data.positions, data.positions + 3 * data.vertex_count);
    m.indices.assign(data.indices, data.indices + 3 * data.triangle_count);
    nfd_mesh_destroy(mesh);
    return m;
}

// A golden vector decoded through the adopted device equals the CPU decode; destroying the context
// leaves the host's device, queue and instance alive. A second adoption, given the host's own
// vkGetInstanceProcAddr instead of the loader's, evaluates the field like the CPU.
TEST_F(Adopt, DecodesLikeTheCpuAndLeavesTheHostDeviceAlive) {
    const Bytes bytes = read_bytes(golden_path("bunny_sdf_w32", ".nfc"));
    nfd_asset* asset = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &asset), NFD_SUCCESS);

    const nfd_vulkan_device lent = host_.lend();
    nfd_context_options options{};
    options.adopt = &lent;
    nfd_context* adopted = nullptr;
    nfd_result r = nfd_context_create(&options, &adopted);
    ASSERT_EQ(r, NFD_SUCCESS) << nfd_result_string(r);
    EXPECT_EQ(nfd_context_device_kind(adopted), NFD_DEVICE_VULKAN);
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(host_.physical, &properties);
    EXPECT_STREQ(nfd_context_device_name(adopted), properties.deviceName);

    nfd_context_options cpu_options{};
    cpu_options.device = NFD_DEVICE_CPU;
    nfd_context* cpu = nullptr;
    ASSERT_EQ(nfd_context_create(&cpu_options, &cpu), NFD_SUCCESS);

    // The GPU emits vertices in another order than the CPU: match them by position, then compare
    // the triangles through that map (same triangles, same winding).
    const uint32_t resolution = 64;
    const MeshData gpu_mesh = extract(adopted, asset, resolution);
    const MeshData cpu_mesh = extract(cpu, asset, resolution);
    ASSERT_GT(cpu_mesh.triangle_count(), 0u);
    ASSERT_EQ(gpu_mesh.vertex_count(), cpu_mesh.vertex_count());
    ASSERT_EQ(gpu_mesh.triangle_count(), cpu_mesh.triangle_count());
    nfd_asset_info info;
    ASSERT_EQ(nfd_asset_get_info(asset, &info), NFD_SUCCESS);
    const std::vector<int64_t> map =
        match_vertices(gpu_mesh, cpu_mesh, 2.0f / float(resolution) * info.scale, 1e-5f);
    for (size_t i = 0; i < map.size(); ++i)
        ASSERT_GE(map[i], 0) << "GPU vertex " << i << " has no CPU vertex within 1e-5";
    EXPECT_TRUE(triangles(gpu_mesh, &map) == triangles(cpu_mesh, nullptr));

    nfd_context_destroy(adopted);
    expect_host_device_works();

    // Adopting the same device again works: nothing of the first context's remains on it.
    nfd_vulkan_device with_proc = lent;
    with_proc.get_instance_proc_addr = reinterpret_cast<void*>(&vkGetInstanceProcAddr);
    options.adopt = &with_proc;
    options.device = NFD_DEVICE_VULKAN;
    r = nfd_context_create(&options, &adopted);
    ASSERT_EQ(r, NFD_SUCCESS) << nfd_result_string(r);
    const std::vector<float> points = {0.0f, 0.0f, 0.0f, 0.1f, -0.2f, 0.3f, 1.0f, 1.0f, -1.0f};
    std::vector<float> gpu_values(3), cpu_values(3);
    ASSERT_EQ(nfd_asset_evaluate(adopted, asset, points.data(), 3, gpu_values.data()), NFD_SUCCESS);
    ASSERT_EQ(nfd_asset_evaluate(cpu, asset, points.data(), 3, cpu_values.data()), NFD_SUCCESS);
    for (size_t i = 0; i < 3; ++i) EXPECT_NEAR(gpu_values[i], cpu_values[i], 1e-5) << i;
    nfd_context_destroy(adopted);
    expect_host_device_works();

    nfd_context_destroy(cpu);
    nfd_asset_destroy(asset);
}

// Bad adoption requests give an error code and no context, never a crash, and leave the host's
// device usable.
TEST_F(Adopt, RejectsInvalidDevices) {
    struct Case {
        const char* what;
        nfd_vulkan_device device;
    };
    std::vector<Case> cases;
    auto add = [&](const char* what, auto edit) {
        nfd_vulkan_device d = host_.lend();
        edit(d);
        cases.push_back({what, d});
    };
    add("queue family UINT32_MAX", [](nfd_vulkan_device& d) { d.queue_family_index = UINT32_MAX; });
    add("queue family past the last",
        [this](nfd_vulkan_device& d) { d.queue_family_index = host_.family_count; });
    add("NULL device", [](nfd_vulkan_device& d) { d.device = nullptr; });
    add("NULL queue", [](nfd_vulkan_device& d) { d.queue = nullptr; });
    add("NULL physical device", [](nfd_vulkan_device& d) { d.physical_device = nullptr; });
    add("NULL instance", [](nfd_vulkan_device& d) { d.instance = nullptr; });
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        for (nfd_device_kind kind : {NFD_DEVICE_AUTO, NFD_DEVICE_VULKAN}) {
            nfd_context_options options{};
            options.device = kind;
            options.adopt = &c.device;
            nfd_context* context = reinterpret_cast<nfd_context*>(0x1);
            const nfd_result r = nfd_context_create(&options, &context);
            EXPECT_EQ(r, NFD_ERROR_INVALID_ARGUMENT) << nfd_result_string(r);
            EXPECT_EQ(context, nullptr);
            nfd_context_destroy(r == NFD_SUCCESS ? context : nullptr);
        }
    }
    // A valid device with the CPU path requested is a contradiction, not a fallback.
    const nfd_vulkan_device lent = host_.lend();
    nfd_context_options options{};
    options.device = NFD_DEVICE_CPU;
    options.adopt = &lent;
    nfd_context* context = nullptr;
    EXPECT_EQ(nfd_context_create(&options, &context), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(context, nullptr);
    expect_host_device_works();
}

}  // namespace
}  // namespace nfd::test
