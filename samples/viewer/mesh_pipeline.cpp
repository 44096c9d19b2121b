#include "mesh_pipeline.h"

#include "viewer_shaders.h"  // generated: nfc_viewer_spirv_mesh_vert, nfc_viewer_spirv_mesh_frag

namespace nfc_viewer {
namespace {

VkShaderModule create_module(VkDevice device, const uint32_t* code, size_t bytes) {
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = bytes;
    info.pCode = code;
    VkShaderModule module;
    vk_check(vkCreateShaderModule(device, &info, nullptr, &module), "vkCreateShaderModule");
    return module;
}

VkPipeline create_pipeline(VkDevice device, VkRenderPass render_pass, VkPipelineLayout layout,
                           VkShaderModule vert, VkShaderModule frag, VkPolygonMode mode) {
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0].sType = stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vert;
    stages[0].pName = "main";
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = frag;
    stages[1].pName = "main";
    // Positions, normals and colours as three streams (GpuMesh): the layout of nfd_device_mesh's
    // buffers plus nfd_mesh_get_colours'.
    const VkVertexInputBindingDescription bindings[3] = {
        {0, 3 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX},
        {1, 3 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX},
        {2, 3 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX}};
    const VkVertexInputAttributeDescription attributes[3] = {
        {0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
        {1, 1, VK_FORMAT_R32G32B32_SFLOAT, 0},
        {2, 2, VK_FORMAT_R32G32B32_SFLOAT, 0}};
    VkPipelineVertexInputStateCreateInfo input{};
    input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    input.vertexBindingDescriptionCount = 3;
    input.pVertexBindingDescriptions = bindings;
    input.vertexAttributeDescriptionCount = 3;
    input.pVertexAttributeDescriptions = attributes;
    VkPipelineInputAssemblyStateCreateInfo assembly{};
    assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo viewport{};
    viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
    viewport.viewportCount = viewport.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.polygonMode = mode;
    raster.cullMode = VK_CULL_MODE_NONE;  // UDF surfaces are open: both sides show
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{};
    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo depth{};
    depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
    depth.depthTestEnable = depth.depthWriteEnable = VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_LESS;
    VkPipelineColorBlendAttachmentState blend_attachment{};
    blend_attachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                      VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{};
    blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
    blend.attachmentCount = 1;
    blend.pAttachments = &blend_attachment;
    const VkDynamicState dynamic_states[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
    dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamic_states;
    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.stageCount = 2;
    info.pStages = stages;
    info.pVertexInputState = &input;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewport;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depth;
    info.pColorBlendState = &blend;
    info.pDynamicState = &dynamic;
    info.layout = layout;
    info.renderPass = render_pass;
    VkPipeline pipeline;
    vk_check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
             "vkCreateGraphicsPipelines");
    return pipeline;
}

}  // namespace

MeshPipeline::MeshPipeline(VkDevice device, VkRenderPass render_pass, bool wireframe_supported)
    : device_(device) {
    VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                              sizeof(MeshPush)};
    VkPipelineLayoutCreateInfo layout{};
    layout.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout.pushConstantRangeCount = 1;
    layout.pPushConstantRanges = &range;
    vk_check(vkCreatePipelineLayout(device, &layout, nullptr, &layout_), "vkCreatePipelineLayout");
    const VkShaderModule vert =
        create_module(device, nfc_viewer_spirv_mesh_vert, sizeof nfc_viewer_spirv_mesh_vert);
    const VkShaderModule frag =
        create_module(device, nfc_viewer_spirv_mesh_frag, sizeof nfc_viewer_spirv_mesh_frag);
    fill_ = create_pipeline(device, render_pass, layout_, vert, frag, VK_POLYGON_MODE_FILL);
    if (wireframe_supported)
        line_ = create_pipeline(device, render_pass, layout_, vert, frag, VK_POLYGON_MODE_LINE);
    vkDestroyShaderModule(device, vert, nullptr);
    vkDestroyShaderModule(device, frag, nullptr);
}

MeshPipeline::~MeshPipeline() {
    vkDestroyPipeline(device_, fill_, nullptr);
    vkDestroyPipeline(device_, line_, nullptr);
    vkDestroyPipelineLayout(device_, layout_, nullptr);
}

void MeshPipeline::bind(VkCommandBuffer cmd, VkExtent2D extent, bool wireframe) const {
    const VkViewport viewport{0, 0, float(extent.width), float(extent.height), 0, 1};
    const VkRect2D scissor{{0, 0}, extent};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, wireframe && line_ ? line_ : fill_);
}

void MeshPipeline::draw(VkCommandBuffer cmd, const GpuMesh& mesh, const MeshPush& push) const {
    if (mesh.empty()) return;
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                       sizeof push, &push);
    // A mesh without colours binds its normals as binding 2, a stream of the right size that
    // the shader then does not use (ShaderMode): one pipeline, nothing allocated for it.
    const bool coloured = mesh.coloured();
    const VkBuffer streams[3] = {mesh.positions, mesh.normals,
                                 coloured ? mesh.colours : mesh.normals};
    const VkDeviceSize offsets[3] = {0, mesh.normals_offset,
                                     coloured ? mesh.colours_offset : mesh.normals_offset};
    vkCmdBindVertexBuffers(cmd, 0, 3, streams, offsets);
    vkCmdBindIndexBuffer(cmd, mesh.indices, 0, VK_INDEX_TYPE_UINT32);
    if (mesh.draw)  // the decode's own record: its count never comes to the host
        vkCmdDrawIndexedIndirect(cmd, mesh.draw, 0, 1, sizeof(VkDrawIndexedIndirectCommand));
    else
        vkCmdDrawIndexed(cmd, mesh.index_count, 1, 0, 0, 0);
}

}  // namespace nfc_viewer
