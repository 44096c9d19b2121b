// A mesh as the frame draws it: a position, a normal and maybe a colour vertex stream (3 floats
// each, bindings 0, 1 and 2 of MeshPipeline), 32-bit indices, and either an index count (vkCmdDrawIndexed) or an
// indirect draw record on the device (vkCmdDrawIndexedIndirect). Two kinds, one draw path:
//   uploaded  a host mesh (nfd_mesh_data: the queue's levels, or every level on the CPU decode)
//             copied into buffers of the viewer's own, positions, normals then colours (when
//             the mesh has them) in one buffer;
//   recorded  the buffers of an nfd_recording the viewer recorded into its command buffer
//             (recorded_final.h): drawn where the decode left them, zero copy, through the draw
//             record the decode wrote; no count comes back to the host for drawing. Geometry
//             only: a recording has no colour.
#pragma once

#include <nfdecode/nfdecode.h>

#include "vk_device.h"

namespace nfc_viewer {

struct GpuMesh {
    VkBuffer positions = VK_NULL_HANDLE, normals = VK_NULL_HANDLE, indices = VK_NULL_HANDLE;
    VkDeviceSize normals_offset = 0;   // into `normals`
    VkBuffer colours = VK_NULL_HANDLE;  // RGB in [0, 1]; none when the mesh has no colour
    VkDeviceSize colours_offset = 0;    // into `colours`
    VkBuffer draw = VK_NULL_HANDLE;    // recorded: one VkDrawIndexedIndirectCommand at offset 0
    uint32_t index_count = 0;          // uploaded: what is drawn; recorded: what the decode
                                       // reported (the overlay's; the draw reads the record)
    // Ownership: the uploaded buffers' memory, or the recording that owns its buffers.
    VkDeviceMemory vertex_memory = VK_NULL_HANDLE, index_memory = VK_NULL_HANDLE;
    nfd_recording* recording = nullptr;

    bool empty() const { return index_count == 0; }
    bool recorded() const { return recording != nullptr; }
    bool coloured() const { return colours != VK_NULL_HANDLE; }
};

// Copies `data` (positions, normals, indices) and `colours` (3 floats a vertex, or NULL:
// nfd_mesh_get_colours) into new buffers. An empty mesh gives an empty GpuMesh (no buffers).
// Throws std::runtime_error if Vulkan cannot allocate them.
GpuMesh upload_mesh(const VkDeviceContext& vk, const nfd_mesh_data& data, const float* colours);

// Takes over `recording` (finished with `result`: NFD_SUCCESS) and draws from its buffers.
GpuMesh wrap_recording(nfd_recording* recording, const nfd_recording_result& result);

// Frees the buffers, or destroys the recording (the GPU must be done with them: see
// FrameTarget::retire; a recording's context and asset must still be alive).
void destroy_mesh(VkDevice device, GpuMesh* mesh);

}  // namespace nfc_viewer
