#include "overlay.h"

#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>

#include <cstdio>
#include <stdexcept>

namespace nfc_viewer {
namespace {

void check_imgui(VkResult result) { vk_check(result, "ImGui Vulkan backend"); }

std::string kib(uint64_t bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f", double(bytes) / 1024.0);
    return text;
}

std::string thousands(size_t n) {
    char text[32];
    if (n >= 1000) std::snprintf(text, sizeof text, "%.1fk", double(n) / 1000.0);
    else std::snprintf(text, sizeof text, "%zu", n);
    return text;
}

const char* state_of(const StreamedAsset& s, const AssetView& v) {
    if (v.failed()) return "failed";
    if (v.final()) return "done";
    if (s.phase.load(std::memory_order_acquire) == Arrival::kStreaming) return "streaming";
    return v.levels.empty() ? "decoding" : "refining";
}

}  // namespace

Overlay::Overlay(VkDeviceContext* vk, const FrameTarget& frames) : device_(vk->device()) {
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
    ImGui::StyleColorsDark();
    if (!ImGui_ImplGlfw_InitForVulkan(vk->window(), true))
        throw std::runtime_error("ImGui GLFW backend failed");

    const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4};
    VkDescriptorPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    pool.maxSets = 4;
    pool.poolSizeCount = 1;
    pool.pPoolSizes = &size;
    vk_check(vkCreateDescriptorPool(device_, &pool, nullptr, &pool_), "vkCreateDescriptorPool");

    ImGui_ImplVulkan_InitInfo info{};
    info.Instance = vk->instance();
    info.PhysicalDevice = vk->physical();
    info.Device = vk->device();
    info.QueueFamily = vk->family();
    info.Queue = vk->queue();
    info.DescriptorPool = pool_;
    info.MinImageCount = 2;
    info.ImageCount = std::max(2u, frames.swapchain_image_count());
    info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
    info.CheckVkResultFn = check_imgui;
    if (!ImGui_ImplVulkan_Init(&info, frames.render_pass()))
        throw std::runtime_error("ImGui Vulkan backend failed");

    // The font atlas: one-off upload through a command buffer of a pool of its own.
    const VkCommandPool command_pool = vk->create_command_pool(0);
    const VkCommandBuffer cmd = vk->allocate_command_buffer(command_pool);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vk_check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
    ImGui_ImplVulkan_CreateFontsTexture(cmd);
    vk_check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    vk->submit_and_wait(cmd);
    ImGui_ImplVulkan_DestroyFontUploadObjects();
    vkDestroyCommandPool(device_, command_pool, nullptr);
}

Overlay::~Overlay() {
    ImGui_ImplVulkan_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    vkDestroyDescriptorPool(device_, pool_, nullptr);
}

bool Overlay::wants_mouse() const { return ImGui::GetIO().WantCaptureMouse; }
bool Overlay::wants_keyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }

void Overlay::draw(VkCommandBuffer cmd, const OverlayStatus& status,
                   const std::vector<StreamedAsset*>& streamed, const std::vector<AssetView>& views) {
    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    // Bottom left, over the grid's margin rather than its first cell.
    const ImVec2 display = ImGui::GetIO().DisplaySize;
    ImGui::SetNextWindowPos(ImVec2(8, display.y - 8), ImGuiCond_Always, ImVec2(0, 1));
    ImGui::SetNextWindowBgAlpha(0.75f);
    ImGui::Begin("nfc-viewer", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
    ImGui::Text("render: %s   decode: %s", status.render_device.c_str(), status.decode_device.c_str());
    ImGui::Text("frame %.2f ms (average %.2f ms)   shading: %s%s   colour: %s", status.frame_ms,
                status.frame_ms_average, status.shading, status.wireframe ? ", wireframe" : "",
                status.colour);
    size_t total_triangles = 0;
    if (ImGui::BeginTable("assets", 7, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
        ImGui::TableSetupColumn("asset");
        ImGui::TableSetupColumn("KiB received");
        ImGui::TableSetupColumn("state");
        ImGui::TableSetupColumn("triangles");
        ImGui::TableSetupColumn("levels: cells / decode ms");
        ImGui::TableSetupColumn("final mesh");
        ImGui::TableSetupColumn("colour");
        ImGui::TableHeadersRow();
        for (size_t i = 0; i < views.size(); ++i) {
            const StreamedAsset& s = *streamed[i];
            const AssetView& v = views[i];
            total_triangles += v.triangles();
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(s.name.c_str());
            ImGui::TableNextColumn();
            const uint32_t size = s.file_size.load(std::memory_order_relaxed);
            ImGui::Text("%s / %s", kib(s.bytes_received.load(std::memory_order_relaxed)).c_str(),
                        size ? kib(size).c_str() : "?");
            ImGui::TableNextColumn();
            if (v.failed()) ImGui::TextColored(ImVec4(1, 0.35f, 0.3f, 1), "failed: %s", v.error.c_str());
            else ImGui::TextUnformatted(state_of(s, v));
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(thousands(v.triangles()).c_str());
            ImGui::TableNextColumn();
            std::string levels;
            for (const LevelRecord& l : v.levels) {
                char text[48];
                std::snprintf(text, sizeof text, "%s%u / %.0f", levels.empty() ? "" : ", ",
                              l.resolution, l.decode_ms);
                levels += text;
            }
            ImGui::TextUnformatted(levels.c_str());
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(final_mesh_source(v));
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(colour_source(s, v).c_str());
        }
        ImGui::EndTable();
    }
    ImGui::Text("%s triangles in all", thousands(total_triangles).c_str());
    ImGui::TextDisabled(
        "drag: rotate  right drag: pan  wheel: zoom  R reset  W wire  N shading  C colour  O overlay");
    ImGui::End();
    ImGui::Render();
    ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cmd);
}

}  // namespace nfc_viewer
