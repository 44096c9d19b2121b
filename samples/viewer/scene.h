// The viewer's scene geometry: where each asset sits in the grid, the orbit camera, and the clip
// conventions. Header-only (GLM), shared by nfc-viewer and its silhouette test
// (tests/viewer/), so that the test's CPU rasterisation sees exactly what the viewer draws.
#pragma once

#define GLM_FORCE_DEPTH_ZERO_TO_ONE  // Vulkan clip depth 0..1
#define GLM_FORCE_RADIANS
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace nfc_viewer {

// The clear colour (linear RGB, written unchanged to the UNORM target): anything else in a
// screenshot without the overlay is a shape.
constexpr float kBackground[3] = {0.09f, 0.10f, 0.12f};

// Grid cells are this many unit-cube widths apart (each asset is scaled into [-1, 1]^3).
constexpr float kCellSpacing = 2.5f;

// Columns of the grid for `count` assets: near-square, wider than tall.
inline int grid_columns(size_t count) {
    return std::max(1, int(std::ceil(std::sqrt(double(count)))));
}

// The centre of cell `index` of `count`: rows top to bottom along -y, columns along +x, the grid
// centred on the origin in the z = 0 plane.
inline glm::vec3 cell_center(size_t index, size_t count) {
    const int columns = grid_columns(count);
    const int rows = int((count + size_t(columns) - 1) / size_t(columns));
    const int col = int(index % size_t(columns)), row = int(index / size_t(columns));
    return glm::vec3((float(col) - 0.5f * float(columns - 1)) * kCellSpacing,
                     (0.5f * float(rows - 1) - float(row)) * kCellSpacing, 0.0f);
}

// The model matrix of an asset: its original frame (original = unit * scale + center, from
// nfd_asset_info) mapped back onto the unit cube, then moved to its cell.
inline glm::mat4 model_matrix(size_t index, size_t count, const float center[3], float scale) {
    const float s = scale > 0 ? 1.0f / scale : 1.0f;
    glm::mat4 m = glm::translate(glm::mat4(1.0f), cell_center(index, count));
    m = glm::scale(m, glm::vec3(s));
    return glm::translate(m, -glm::vec3(center[0], center[1], center[2]));
}

// An orbit camera around `target`: yaw about +y, pitch above the z = 0 plane, at `distance`.
struct OrbitCamera {
    glm::vec3 target{0.0f};
    float yaw = 0.35f, pitch = 0.25f, distance = 4.0f;
    float fov_y = glm::radians(40.0f);

    // The camera that frames a grid of `count` assets at this aspect ratio (width / height).
    static OrbitCamera framing(size_t count, float aspect) {
        OrbitCamera c;
        const int columns = grid_columns(count);
        const int rows = int((std::max<size_t>(count, 1) + size_t(columns) - 1) / size_t(columns));
        // Half extents of the grid plus a margin of 1.2 unit-cube half widths (the shapes rarely
        // reach the cube's corners), from the grid's front plane (z = 1).
        const float half_w = 0.5f * float(columns - 1) * kCellSpacing + 1.2f;
        const float half_h = 0.5f * float(rows - 1) * kCellSpacing + 1.2f;
        const float tan_y = std::tan(0.5f * c.fov_y), tan_x = tan_y * aspect;
        c.distance = std::max(half_h / tan_y, half_w / tan_x) + 1.0f;
        return c;
    }

    glm::vec3 eye() const {
        const glm::vec3 dir(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                            std::cos(pitch) * std::cos(yaw));
        return target + distance * dir;
    }
    glm::mat4 view() const { return glm::lookAt(eye(), target, glm::vec3(0, 1, 0)); }
    // Vulkan clip space: y down (GLM's GL convention flipped), depth 0..1.
    glm::mat4 projection(float aspect) const {
        glm::mat4 p = glm::perspective(fov_y, aspect, 0.05f * distance, 20.0f * distance);
        p[1][1] *= -1.0f;
        return p;
    }
};

// Pixel coordinates (x right, y down, pixel centres at +0.5) of a clip-space position, as the
// Vulkan viewport (0, 0, width, height) maps it.
inline glm::vec2 clip_to_pixel(const glm::vec4& clip, int width, int height) {
    return glm::vec2((clip.x / clip.w * 0.5f + 0.5f) * float(width),
                     (clip.y / clip.w * 0.5f + 0.5f) * float(height));
}

}  // namespace nfc_viewer
