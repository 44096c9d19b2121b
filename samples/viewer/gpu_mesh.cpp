#include "gpu_mesh.h"

#include <cstring>

namespace nfc_viewer {
namespace {

VkBuffer as_buffer(uint64_t handle) {  // nfd_device_mesh's handles are VkBuffer values
    VkBuffer b;
    static_assert(sizeof b == sizeof handle, "64-bit Vulkan handles");
    std::memcpy(&b, &handle, sizeof b);
    return b;
}

}  // namespace

GpuMesh upload_mesh(const VkDeviceContext& vk, const nfd_mesh_data& data, const float* colours) {
    GpuMesh m;
    if (data.triangle_count == 0 || data.vertex_count == 0) return m;
    const VkDevice device = vk.device();
    // Host-visible memory written in place: on lavapipe and unified-memory GPUs this is the
    // device's memory; a discrete GPU would want a staging copy to device-local memory here.
    const size_t stream_bytes = size_t(data.vertex_count) * 3 * sizeof(float);
    const VkDeviceSize index_bytes = VkDeviceSize(data.triangle_count) * 3 * sizeof(uint32_t);
    const int streams = colours ? 3 : 2;
    vk.create_host_buffer(streams * stream_bytes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, &m.positions,
                          &m.vertex_memory);
    m.normals = m.positions;
    m.normals_offset = stream_bytes;
    if (colours) {
        m.colours = m.positions;
        m.colours_offset = 2 * stream_bytes;
    }
    vk.create_host_buffer(index_bytes, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, &m.indices, &m.index_memory);
    void* mapped = nullptr;
    vk_check(vkMapMemory(device, m.vertex_memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    std::memcpy(mapped, data.positions, stream_bytes);
    std::memcpy(static_cast<char*>(mapped) + stream_bytes, data.normals, stream_bytes);
    if (colours) std::memcpy(static_cast<char*>(mapped) + 2 * stream_bytes, colours, stream_bytes);
    vkUnmapMemory(device, m.vertex_memory);
    vk_check(vkMapMemory(device, m.index_memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    std::memcpy(mapped, data.indices, size_t(index_bytes));
    vkUnmapMemory(device, m.index_memory);
    m.index_count = uint32_t(data.triangle_count * 3);
    return m;
}

GpuMesh wrap_recording(nfd_recording* recording, const nfd_recording_result& result) {
    nfd_device_mesh dm{};
    nfd_recording_get_mesh(recording, &dm);
    GpuMesh m;
    m.positions = as_buffer(dm.positions);
    m.normals = as_buffer(dm.normals);
    m.indices = as_buffer(dm.indices);
    m.draw = as_buffer(dm.draw);
    m.index_count = 3 * result.triangle_count;
    m.recording = recording;
    return m;
}

void destroy_mesh(VkDevice device, GpuMesh* mesh) {
    if (mesh->recording) {
        nfd_recording_destroy(mesh->recording);
    } else {
        vkDestroyBuffer(device, mesh->positions, nullptr);
        vkDestroyBuffer(device, mesh->indices, nullptr);
        vkFreeMemory(device, mesh->vertex_memory, nullptr);
        vkFreeMemory(device, mesh->index_memory, nullptr);
    }
    *mesh = GpuMesh{};
}

}  // namespace nfc_viewer
