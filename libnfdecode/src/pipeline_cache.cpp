#include "pipeline_cache.h"

#include <cstring>

#include "bitstream.h"

namespace nfd {
namespace {

constexpr uint8_t kMagic[4] = {'N', 'F', 'P', 'C'};
constexpr uint32_t kEnvelopeVersion = 1;
// Vulkan's header: u32 length, u32 version (VK_PIPELINE_CACHE_HEADER_VERSION_ONE = 1), u32
// vendor ID, u32 device ID, u8[16] UUID.
constexpr size_t kVulkanHeaderBytes = 32;

void put32(std::vector<uint8_t>& out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}

}  // namespace

std::vector<uint8_t> wrap_pipeline_cache(const PipelineCacheKey& key, const uint8_t* driver_bytes,
                                         size_t size) {
    std::vector<uint8_t> out(kMagic, kMagic + 4);
    out.reserve(kPipelineCacheEnvelopeBytes + size);
    put32(out, kEnvelopeVersion);
    put32(out, key.vendor_id);
    put32(out, key.device_id);
    put32(out, key.driver_version);
    out.insert(out.end(), key.cache_uuid, key.cache_uuid + 16);
    put32(out, uint32_t(sizeof(void*)));
    put32(out, uint32_t(uint64_t(size)));
    put32(out, uint32_t(uint64_t(size) >> 32));
    put32(out, crc32(driver_bytes, size));
    out.insert(out.end(), driver_bytes, driver_bytes + size);
    return out;
}

bool open_pipeline_cache(const PipelineCacheKey& key, const void* blob, size_t blob_size,
                         const uint8_t** driver_bytes, size_t* size) {
    *driver_bytes = nullptr;
    *size = 0;
    if (!blob || blob_size < kPipelineCacheEnvelopeBytes || blob_size > kMaxPipelineCacheBytes)
        return false;
    const auto* p = static_cast<const uint8_t*>(blob);
    const uint8_t* body = p + kPipelineCacheEnvelopeBytes;
    const size_t n = blob_size - kPipelineCacheEnvelopeBytes;
    const uint64_t announced = uint64_t(load_u32(p + 40)) | uint64_t(load_u32(p + 44)) << 32;
    if (std::memcmp(p, kMagic, 4) != 0 || load_u32(p + 4) != kEnvelopeVersion ||
        load_u32(p + 8) != key.vendor_id || load_u32(p + 12) != key.device_id ||
        load_u32(p + 16) != key.driver_version || std::memcmp(p + 20, key.cache_uuid, 16) != 0 ||
        load_u32(p + 36) != sizeof(void*) || announced != n || load_u32(p + 48) != crc32(body, n))
        return false;
    // The driver's own header, for the same device: a mismatch means an envelope written around
    // another driver's bytes.
    if (n < kVulkanHeaderBytes || load_u32(body) < kVulkanHeaderBytes || load_u32(body) > n ||
        load_u32(body + 4) != 1 || load_u32(body + 8) != key.vendor_id ||
        load_u32(body + 12) != key.device_id || std::memcmp(body + 16, key.cache_uuid, 16) != 0)
        return false;
    *driver_bytes = body;
    *size = n;
    return true;
}

}  // namespace nfd
