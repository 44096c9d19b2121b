// The envelope around a Vulkan driver's pipeline-cache bytes (nfd_context_get_pipeline_cache):
// what lets a host store the bytes in a file and hand them back to a later context safely.
//
// Drivers check the header of VkPipelineCacheCreateInfo's data, but not all of them survive a
// body that is truncated or damaged on disk, or written by another driver build with the same
// header. So the bytes travel in an envelope that is checked before the driver sees them (the
// scheme of "Robust pipeline cache serialization", A. Kapoulkine, 2019): a magic, the size and
// CRC-32 of the driver's bytes, and the device they were made on (vendor, device ID, driver
// version, pipeline-cache UUID, pointer size). Anything that does not match is ignored: a stale
// or damaged cache costs a compile, never a failure.
//
// Layout (little-endian): "NFPC", u32 envelope version (1), u32 vendor ID, u32 device ID, u32
// driver version, u8[16] pipeline-cache UUID, u32 pointer size of the writer, u64 size n, u32
// CRC-32 of the n bytes, then the driver's n bytes (which begin with Vulkan's own header).
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace nfd {

struct PipelineCacheKey {
    uint32_t vendor_id = 0, device_id = 0, driver_version = 0;
    uint8_t cache_uuid[16] = {};
};

constexpr size_t kPipelineCacheEnvelopeBytes = 4 + 4 + 12 + 16 + 4 + 8 + 4;
// Larger blobs are ignored unread: drivers' caches of a few dozen kernels are far smaller.
constexpr size_t kMaxPipelineCacheBytes = size_t(256) << 20;

// The envelope of `size` driver bytes made on `key`'s device.
std::vector<uint8_t> wrap_pipeline_cache(const PipelineCacheKey& key, const uint8_t* driver_bytes,
                                         size_t size);

// The driver's bytes inside `blob` if it is an intact envelope made on `key`'s device, by a
// library of this pointer size, whose bytes start with a Vulkan cache header (version one) for
// the same device; else *driver_bytes = nullptr, *size = 0 and false.
bool open_pipeline_cache(const PipelineCacheKey& key, const void* blob, size_t blob_size,
                         const uint8_t** driver_bytes, size_t* size);

}  // namespace nfd
