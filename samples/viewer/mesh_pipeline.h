// The graphics pipelines that draw decoded meshes (filled, and wireframe where the device has
// fillModeNonSolid), from the SPIR-V compiled at build time (shaders/mesh.vert, mesh.frag).
#pragma once

#include <glm/glm.hpp>

#include "gpu_mesh.h"

namespace nfc_viewer {

enum class Shading { kLit = 0, kNormals = 1 };

// What mesh.frag draws (MeshPush::tint.w): the lit tint, the normals, or the lit vertex colours.
enum class ShaderMode { kTint = 0, kNormals = 1, kVertexColour = 2 };

// The push constants of shaders/mesh.vert and mesh.frag, in their layout.
struct MeshPush {
    glm::mat4 mvp;
    glm::vec4 light_dir;
    glm::vec4 tint;  // rgb colour, w: ShaderMode
};

class MeshPipeline {
public:
    MeshPipeline(VkDevice device, VkRenderPass render_pass, bool wireframe_supported);
    ~MeshPipeline();
    MeshPipeline(const MeshPipeline&) = delete;
    MeshPipeline& operator=(const MeshPipeline&) = delete;

    bool has_wireframe() const { return line_ != VK_NULL_HANDLE; }
    // Sets the viewport and scissor to `extent` and binds the filled or wireframe pipeline.
    void bind(VkCommandBuffer cmd, VkExtent2D extent, bool wireframe) const;
    // An uploaded mesh with vkCmdDrawIndexed, a recorded one with vkCmdDrawIndexedIndirect.
    // kVertexColour only for a mesh that is coloured().
    void draw(VkCommandBuffer cmd, const GpuMesh& mesh, const MeshPush& push) const;

private:
    VkDevice device_;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline fill_ = VK_NULL_HANDLE, line_ = VK_NULL_HANDLE;
};

}  // namespace nfc_viewer
