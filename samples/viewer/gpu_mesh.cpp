#include "gpu_mesh.h"

#include <cstring>

namespace nfc_viewer {

GpuMesh upload_mesh(const VkDeviceContext& vk, const nfd_mesh_data& data) {
    GpuMesh m;
    if (data.triangle_count == 0 || data.vertex_count == 0) return m;
    const VkDevice device = vk.device();
    // Host-visible memory written in place: on lavapipe and unified-memory GPUs this is the
    // device's memory; a discrete GPU would want a staging copy to device-local memory here.
    const VkDeviceSize vertex_bytes = VkDeviceSize(data.vertex_count) * 6 * sizeof(float);
    const VkDeviceSize index_bytes = VkDeviceSize(data.triangle_count) * 3 * sizeof(uint32_t);
    vk.create_host_buffer(vertex_bytes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, &m.vertices,
                          &m.vertex_memory);
    vk.create_host_buffer(index_bytes, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, &m.indices, &m.index_memory);
    void* mapped = nullptr;
    vk_check(vkMapMemory(device, m.vertex_memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    float* v = static_cast<float*>(mapped);
    for (size_t i = 0; i < data.vertex_count; ++i, v += 6) {
        std::memcpy(v, data.positions + 3 * i, 3 * sizeof(float));
        std::memcpy(v + 3, data.normals + 3 * i, 3 * sizeof(float));
    }
    vkUnmapMemory(device, m.vertex_memory);
    vk_check(vkMapMemory(device, m.index_memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    std::memcpy(mapped, data.indices, size_t(index_bytes));
    vkUnmapMemory(device, m.index_memory);
    m.index_count = uint32_t(data.triangle_count * 3);
    return m;
}

void destroy_mesh(VkDevice device, GpuMesh* mesh) {
    vkDestroyBuffer(device, mesh->vertices, nullptr);
    vkDestroyBuffer(device, mesh->indices, nullptr);
    vkFreeMemory(device, mesh->vertex_memory, nullptr);
    vkFreeMemory(device, mesh->index_memory, nullptr);
    *mesh = GpuMesh{};
}

}  // namespace nfc_viewer
