// A decoded mesh as the viewer draws it: one interleaved vertex buffer (position, normal) and one
// index buffer.
//
// The single place where a mesh reaches the GPU. libnfdecode 0.2 returns meshes in host memory
// (nfd_mesh_get_data), so upload_mesh() copies them into buffers of the viewer's own; when the
// library can leave a job's results on the (adopted) device as VkBuffers, upload_mesh() becomes a
// wrap of those buffers and nothing else in the viewer changes.
#pragma once

#include <nfdecode/nfdecode.h>

#include "vk_device.h"

namespace nfc_viewer {

struct GpuMesh {
    VkBuffer vertices = VK_NULL_HANDLE, indices = VK_NULL_HANDLE;
    VkDeviceMemory vertex_memory = VK_NULL_HANDLE, index_memory = VK_NULL_HANDLE;
    uint32_t index_count = 0;
    bool empty() const { return index_count == 0; }
};

// Copies `data` (positions, normals, indices) into new buffers. An empty mesh gives an empty
// GpuMesh (no buffers). Throws std::runtime_error if Vulkan cannot allocate them.
GpuMesh upload_mesh(const VkDeviceContext& vk, const nfd_mesh_data& data);

// Frees the buffers (the GPU must be done with them: see FrameTarget::retire).
void destroy_mesh(VkDevice device, GpuMesh* mesh);

}  // namespace nfc_viewer
