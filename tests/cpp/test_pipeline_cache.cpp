// Pipeline caches carried across contexts (nfd_context_get_pipeline_cache,
// nfd_context_options.pipeline_cache; pipeline_cache.h): the envelope opens only when it is
// intact and was made on the same device, and any other bytes are ignored, never an error.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <cstring>
#include <vector>

#include "pipeline_cache.h"
#include "test_util.h"

namespace nfd::test {
namespace {

PipelineCacheKey test_key() {
    PipelineCacheKey key;
    key.vendor_id = 0x10005;
    key.device_id = 0x1234;
    key.driver_version = 0x5803006;
    for (int i = 0; i < 16; ++i) key.cache_uuid[i] = uint8_t(17 * i + 3);
    return key;
}

// What a driver returns: Vulkan's 32-byte header for `key`, then `body` bytes of its own.
std::vector<uint8_t> driver_bytes(const PipelineCacheKey& key, size_t body) {
    std::vector<uint8_t> out(32 + body);
    const uint32_t words[4] = {32, 1, key.vendor_id, key.device_id};
    for (int w = 0; w < 4; ++w)
        for (int b = 0; b < 4; ++b) out[4 * w + b] = uint8_t(words[w] >> (8 * b));
    std::memcpy(out.data() + 16, key.cache_uuid, 16);
    for (size_t i = 0; i < body; ++i) out[32 + i] = uint8_t(i * 7 + 1);
    return out;
}

bool opens(const PipelineCacheKey& key, const std::vector<uint8_t>& blob) {
    const uint8_t* bytes = nullptr;
    size_t size = 1;
    const bool ok = open_pipeline_cache(key, blob.data(), blob.size(), &bytes, &size);
    EXPECT_EQ(ok, bytes != nullptr);
    EXPECT_EQ(ok, size != 0);
    return ok;
}

TEST(PipelineCache, EnvelopeGivesBackTheDriversBytes) {
    const PipelineCacheKey key = test_key();
    const std::vector<uint8_t> inner = driver_bytes(key, 300);
    const std::vector<uint8_t> blob = wrap_pipeline_cache(key, inner.data(), inner.size());
    ASSERT_EQ(blob.size(), kPipelineCacheEnvelopeBytes + inner.size());
    const uint8_t* bytes = nullptr;
    size_t size = 0;
    ASSERT_TRUE(open_pipeline_cache(key, blob.data(), blob.size(), &bytes, &size));
    ASSERT_EQ(size, inner.size());
    EXPECT_EQ(std::memcmp(bytes, inner.data(), size), 0);
    EXPECT_EQ(bytes, blob.data() + kPipelineCacheEnvelopeBytes);  // no copy
}

TEST(PipelineCache, AnotherDeviceOrDriverIsIgnored) {
    const PipelineCacheKey key = test_key();
    const std::vector<uint8_t> inner = driver_bytes(key, 40);
    const std::vector<uint8_t> blob = wrap_pipeline_cache(key, inner.data(), inner.size());
    for (int field = 0; field < 4; ++field) {
        PipelineCacheKey other = key;
        if (field == 0) other.vendor_id ^= 1;
        if (field == 1) other.device_id ^= 1;
        if (field == 2) other.driver_version += 1;  // a driver update: its kernels compile anew
        if (field == 3) other.cache_uuid[15] ^= 0x80;
        EXPECT_FALSE(opens(other, blob)) << field;
    }
    // An intact envelope around bytes whose Vulkan header names another device, or is not one.
    PipelineCacheKey other = key;
    other.cache_uuid[0] ^= 1;
    const std::vector<uint8_t> foreign = driver_bytes(other, 40);
    EXPECT_FALSE(opens(key, wrap_pipeline_cache(key, foreign.data(), foreign.size())));
    std::vector<uint8_t> bad_header = inner;
    bad_header[0] = 200;  // a header longer than the bytes
    EXPECT_FALSE(opens(key, wrap_pipeline_cache(key, bad_header.data(), bad_header.size())));
    bad_header = inner;
    bad_header[4] = 2;  // a header version this library does not know
    EXPECT_FALSE(opens(key, wrap_pipeline_cache(key, bad_header.data(), bad_header.size())));
    EXPECT_FALSE(opens(key, wrap_pipeline_cache(key, inner.data(), 31)));  // no whole header
}

// A cache file damaged or cut short on disk: every truncation and every flipped bit is refused.
TEST(PipelineCache, DamagedOrTruncatedBytesAreIgnored) {
    const PipelineCacheKey key = test_key();
    const std::vector<uint8_t> inner = driver_bytes(key, 64);
    const std::vector<uint8_t> blob = wrap_pipeline_cache(key, inner.data(), inner.size());
    ASSERT_TRUE(opens(key, blob));
    for (size_t n = 0; n < blob.size(); ++n)
        EXPECT_FALSE(opens(key, std::vector<uint8_t>(blob.begin(), blob.begin() + n))) << n;
    std::vector<uint8_t> longer = blob;
    longer.push_back(0);
    EXPECT_FALSE(opens(key, longer));
    for (size_t i = 0; i < blob.size(); ++i)
        for (int bit = 0; bit < 8; ++bit) {
            std::vector<uint8_t> damaged = blob;
            damaged[i] ^= uint8_t(1u << bit);
            EXPECT_FALSE(opens(key, damaged)) << i << " " << bit;
        }
    const uint8_t* bytes = blob.data();
    size_t size = 1;
    EXPECT_FALSE(open_pipeline_cache(key, nullptr, 100, &bytes, &size));
    EXPECT_EQ(bytes, nullptr);
    EXPECT_EQ(size, 0u);
    // Past the cap: refused before a byte is read (ASan would see a read past `blob`).
    EXPECT_FALSE(open_pipeline_cache(key, blob.data(), kMaxPipelineCacheBytes + 1, &bytes, &size));
}

TEST(PipelineCache, CpuContextHasNone) {
    nfd_context_options o = {};
    o.struct_size = sizeof o;
    o.device = NFD_DEVICE_CPU;
    const uint8_t junk[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    o.pipeline_cache = junk;  // ignored on the CPU
    o.pipeline_cache_size = sizeof junk;
    nfd_context* cpu = nullptr;
    ASSERT_EQ(nfd_context_create(&o, &cpu), NFD_SUCCESS);
    size_t size = 99;
    EXPECT_EQ(nfd_context_get_pipeline_cache(cpu, nullptr, &size), NFD_SUCCESS);
    EXPECT_EQ(size, 0u);
    uint8_t out[4] = {};
    size = sizeof out;
    EXPECT_EQ(nfd_context_get_pipeline_cache(cpu, out, &size), NFD_SUCCESS);
    EXPECT_EQ(size, 0u);
    EXPECT_EQ(nfd_context_get_pipeline_cache(cpu, out, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_context_get_pipeline_cache(nullptr, out, &size), NFD_ERROR_INVALID_ARGUMENT);
    nfd_context_destroy(cpu);
}

#if NFD_WITH_VULKAN
nfd_context* vulkan_context(const void* cache, size_t cache_size) {
    nfd_context_options o = {};
    o.struct_size = sizeof o;
    o.device = NFD_DEVICE_VULKAN;
    o.pipeline_cache = cache;
    o.pipeline_cache_size = cache_size;
    nfd_context* ctx = nullptr;
    return nfd_context_create(&o, &ctx) == NFD_SUCCESS ? ctx : nullptr;
}

std::vector<float> mesh_positions(nfd_context* ctx, const Bytes& file) {
    nfd_asset* asset = nullptr;
    nfd_mesh* mesh = nullptr;
    nfd_mesh_options mo = {};
    mo.struct_size = sizeof mo;
    mo.resolution = 64;
    std::vector<float> positions;
    EXPECT_EQ(nfd_asset_create(file.data(), file.size(), &asset), NFD_SUCCESS);
    EXPECT_EQ(nfd_mesh_extract(ctx, asset, &mo, &mesh), NFD_SUCCESS);
    nfd_mesh_data data{};
    if (mesh && nfd_mesh_get_data(mesh, &data) == NFD_SUCCESS)
        positions.assign(data.positions, data.positions + 3 * data.vertex_count);
    nfd_mesh_destroy(mesh);
    nfd_asset_destroy(asset);
    return positions;
}

// What a host does across runs: decode, save the cache, start the next context from it. The
// saved bytes (with this driver's own, whatever it keeps), the same meshes; damaged bytes
// start an empty cache instead.
TEST(PipelineCache, VulkanContextSavesAndReusesItsCache) {
    nfd_context* first = vulkan_context(nullptr, 0);
    if (!first) {
        skip_without_vulkan("no Vulkan device");
        return;
    }
    const Bytes file = read_bytes(golden_path("bunny_scans_udf_w16", ".nfc"));
    const std::vector<float> expected = mesh_positions(first, file);
    ASSERT_FALSE(expected.empty());
    size_t size = 0;
    ASSERT_EQ(nfd_context_get_pipeline_cache(first, nullptr, &size), NFD_SUCCESS);
    ASSERT_GE(size, kPipelineCacheEnvelopeBytes + 32);  // the envelope, the driver's header
    std::vector<uint8_t> saved(size);
    size_t small = size - 1;
    EXPECT_EQ(nfd_context_get_pipeline_cache(first, saved.data(), &small),
              NFD_ERROR_LIMIT_EXCEEDED);
    EXPECT_EQ(small, size);
    ASSERT_EQ(nfd_context_get_pipeline_cache(first, saved.data(), &size), NFD_SUCCESS);
    ASSERT_EQ(size, saved.size());
    EXPECT_EQ(std::memcmp(saved.data(), "NFPC", 4), 0);
    nfd_context_destroy(first);

    std::vector<uint8_t> damaged = saved;
    damaged.back() ^= 0x40;
    const std::vector<std::vector<uint8_t>> starts = {
        saved, damaged, std::vector<uint8_t>(saved.begin(), saved.end() - 1), {7, 7, 7}};
    for (size_t k = 0; k < starts.size(); ++k) {
        SCOPED_TRACE(k);
        nfd_context* next = vulkan_context(starts[k].data(), starts[k].size());
        ASSERT_NE(next, nullptr);
        EXPECT_EQ(mesh_positions(next, file), expected);
        size_t again = 0;
        EXPECT_EQ(nfd_context_get_pipeline_cache(next, nullptr, &again), NFD_SUCCESS);
        EXPECT_GE(again, kPipelineCacheEnvelopeBytes + 32);
        nfd_context_destroy(next);
    }
}
#endif

}  // namespace
}  // namespace nfd::test
