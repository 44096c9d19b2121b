// What a failing Vulkan driver does to the library (issue 13, item 4), on lavapipe with faults
// injected into the Vulkan layer (gpu/vk_context.h, inject_fault): device creation failing,
// device memory running out at every allocation of a decode in turn, a lost device, and no driver
// at all (nfc-decode with an empty loader configuration). Each gives its result code, never an
// abort; only AUTO falls back to the CPU; the queue survives a failed job.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "colour_util.h"
#include "gpu/faults.h"
#include "test_util.h"

namespace nfd::test {
namespace {

class GpuFaults : public ::testing::Test {
protected:
    void SetUp() override {
        vulkan_ = make_context(NFD_DEVICE_VULKAN);
        if (!vulkan_) skip_without_vulkan("no Vulkan device");
        asset_ = make_asset(read_bytes(golden_path("bunny_sdf_w16", ".nfc")));
    }
    void TearDown() override {  // a fault a test armed but did not reach must not leak out
        for (int k = 0; k < int(gpu::Fault::Count); ++k) gpu::inject_fault(gpu::Fault(k), 0);
    }
    nfd_result extract_into(nfd_context* ctx, MeshPtr* out) {
        nfd_mesh_options mo{};
        mo.struct_size = sizeof mo;
        mo.resolution = 32;
        nfd_mesh* m = nullptr;
        const nfd_result r = nfd_mesh_extract(ctx, asset_.get(), &mo, &m);
        EXPECT_EQ(r == NFD_SUCCESS, m != nullptr);
        out->reset(m);
        return r;
    }
    ContextPtr vulkan_;
    AssetPtr asset_;
};

TEST_F(GpuFaults, DeviceCreationFailureIsAnErrorAndAutoFallsBackToTheCpu) {
    gpu::inject_fault(gpu::Fault::DeviceCreation, 1);
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_VULKAN;
    nfd_context* c = reinterpret_cast<nfd_context*>(0x1);
    EXPECT_EQ(nfd_context_create(&co, &c), NFD_ERROR_DEVICE_UNAVAILABLE);
    EXPECT_EQ(c, nullptr);
    gpu::inject_fault(gpu::Fault::DeviceCreation, 1);
    co.device = NFD_DEVICE_AUTO;
    ASSERT_EQ(nfd_context_create(&co, &c), NFD_SUCCESS);
    const ContextPtr automatic(c);
    EXPECT_EQ(nfd_context_device_kind(automatic.get()), NFD_DEVICE_CPU);
    MeshPtr mesh;
    EXPECT_EQ(extract_into(automatic.get(), &mesh), NFD_SUCCESS);
}

// Device memory exhausted at the 1st, 2nd, ... allocation of a decode: each is
// NFD_ERROR_OUT_OF_MEMORY, the context stays usable, and the next decode is the fault-free one.
TEST_F(GpuFaults, DeviceMemoryExhaustionAtEveryAllocation) {
    MeshPtr reference;
    ASSERT_EQ(extract_into(vulkan_.get(), &reference), NFD_SUCCESS);
    const MeshArrays expected = arrays_of(reference.get());
    int failures = 0;
    for (int at = 1; at <= 200; ++at) {
        gpu::inject_fault(gpu::Fault::Allocation, at);
        MeshPtr mesh;
        const nfd_result r = extract_into(vulkan_.get(), &mesh);
        gpu::inject_fault(gpu::Fault::Allocation, 0);
        if (r == NFD_SUCCESS) {  // the decode needed fewer allocations: every point was reached
            EXPECT_TRUE(arrays_of(mesh.get()).same_geometry(expected));
            break;
        }
        ASSERT_EQ(r, NFD_ERROR_OUT_OF_MEMORY) << "allocation " << at;
        ++failures;
        MeshPtr again;
        ASSERT_EQ(extract_into(vulkan_.get(), &again), NFD_SUCCESS) << "after allocation " << at;
        EXPECT_TRUE(arrays_of(again.get()).same_geometry(expected)) << at;
    }
    EXPECT_GT(failures, 3);  // a decode allocates several buffers, each one was made to fail
    EXPECT_LT(failures, 200);
}

// A lost device: the failing call and every later one on that context report NFD_ERROR_DEVICE
// (a lost device stays lost); destroying it is safe, and a new context decodes.
TEST_F(GpuFaults, LostDeviceStaysLostAndANewContextWorks) {
    gpu::inject_fault(gpu::Fault::Submission, 2);
    MeshPtr mesh;
    EXPECT_EQ(extract_into(vulkan_.get(), &mesh), NFD_ERROR_DEVICE);
    EXPECT_EQ(extract_into(vulkan_.get(), &mesh), NFD_ERROR_DEVICE);
    const float point[3] = {0, 0, 0};
    float value = 0;
    EXPECT_EQ(nfd_asset_evaluate(vulkan_.get(), asset_.get(), point, 1, &value), NFD_ERROR_DEVICE);
    vulkan_.reset();
    const ContextPtr fresh = make_context(NFD_DEVICE_VULKAN);
    ASSERT_TRUE(fresh);
    EXPECT_EQ(extract_into(fresh.get(), &mesh), NFD_SUCCESS);
}

// A resolution-32 job through the queue; DONE exactly when it succeeds.
nfd_result run_job_at_32(nfd_queue* q, const nfd_asset* asset, MeshPtr* out) {
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = 32;
    nfd_job_status s = NFD_JOB_QUEUED;
    const nfd_result r = run_job(q, asset, mo, out, &s);
    EXPECT_EQ(s == NFD_JOB_DONE, r == NFD_SUCCESS) << s;
    return r;
}

// The queue survives failed jobs: out of device memory fails that job only; after a lost device
// its jobs fail with NFD_ERROR_DEVICE and the queue still shuts down cleanly.
TEST_F(GpuFaults, QueueSurvivesFailedJobs) {
    nfd_queue* q = nullptr;
    ASSERT_EQ(nfd_queue_create(vulkan_.get(), nullptr, &q), NFD_SUCCESS);
    MeshPtr reference, mesh;
    ASSERT_EQ(run_job_at_32(q, asset_.get(), &reference), NFD_SUCCESS);
    gpu::inject_fault(gpu::Fault::Allocation, 1);
    EXPECT_EQ(run_job_at_32(q, asset_.get(), &mesh), NFD_ERROR_OUT_OF_MEMORY);
    ASSERT_EQ(run_job_at_32(q, asset_.get(), &mesh), NFD_SUCCESS);
    EXPECT_TRUE(arrays_of(mesh.get()).same_geometry(arrays_of(reference.get())));
    gpu::inject_fault(gpu::Fault::Submission, 1);
    EXPECT_EQ(run_job_at_32(q, asset_.get(), &mesh), NFD_ERROR_DEVICE);
    EXPECT_EQ(run_job_at_32(q, asset_.get(), &mesh), NFD_ERROR_DEVICE);
    nfd_queue_destroy(q);
}

#ifdef NFD_CLI_PATH
// No Vulkan driver at all (the loader finds no ICD): an explicit Vulkan request is a one-line
// error, AUTO decodes on the CPU.
TEST(NoVulkanDriver, VulkanRequestFailsAndAutoUsesTheCpu) {
    const std::string in = golden_path("bunny_sdf_w16", ".nfc");
    const std::string out = std::string(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp") +
                            "/nfd_no_driver.ply";
    const std::string env = "VK_ICD_FILENAMES=/nonexistent/icd.json VK_DRIVER_FILES=/nonexistent/icd.json ";
    const std::string base = env + NFD_CLI_PATH + " " + in + " -o " + out + " --resolution 32";
    const int vulkan = std::system((base + " --device vulkan 2>/dev/null").c_str());
    ASSERT_TRUE(WIFEXITED(vulkan));
    EXPECT_EQ(WEXITSTATUS(vulkan), 1);
    const int automatic = std::system((base + " --device auto").c_str());
    ASSERT_TRUE(WIFEXITED(automatic));
    EXPECT_EQ(WEXITSTATUS(automatic), 0);
    std::remove(out.c_str());
}
#endif

}  // namespace
}  // namespace nfd::test
