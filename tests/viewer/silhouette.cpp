#include "silhouette.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace nfc_viewer::test {

double Mask::coverage() const {
    size_t n = 0;
    for (uint8_t c : covered) n += c;
    return covered.empty() ? 0 : double(n) / double(covered.size());
}

namespace {

// Calls visit(pixel index, triangle, barycentric weights of its corners, clip depth) for every
// pixel centre inside a triangle of `mesh` projected by `mvp` (either winding), as the Vulkan
// viewport (0, 0, width, height) maps clip space. Weights and depth are interpolated in screen
// space: exact for the depth, and within rounding of perspective-correct interpolation for
// triangles of a few pixels, as these meshes' are.
template <typename Visit>
void for_each_pixel(const nfd_mesh_data& mesh, const glm::mat4& mvp, int width, int height,
                    Visit visit) {
    std::vector<glm::vec3> pixels(mesh.vertex_count);  // x, y, depth
    std::vector<bool> in_front(mesh.vertex_count);
    for (size_t v = 0; v < mesh.vertex_count; ++v) {
        const float* p = mesh.positions + 3 * v;
        const glm::vec4 clip = mvp * glm::vec4(p[0], p[1], p[2], 1.0f);
        in_front[v] = clip.w > 0;
        pixels[v] = glm::vec3(clip_to_pixel(clip, width, height), clip.z / clip.w);
    }
    for (size_t t = 0; t < mesh.triangle_count; ++t) {
        const uint32_t* i = mesh.indices + 3 * t;
        if (!in_front[i[0]] || !in_front[i[1]] || !in_front[i[2]]) continue;
        const glm::vec3 a = pixels[i[0]], b = pixels[i[1]], c = pixels[i[2]];
        const float area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if (area == 0) continue;
        const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x}))));
        const int x1 = std::min(width - 1, int(std::ceil(std::max({a.x, b.x, c.x}))));
        const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y}))));
        const int y1 = std::min(height - 1, int(std::ceil(std::max({a.y, b.y, c.y}))));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                const glm::vec2 p(float(x) + 0.5f, float(y) + 0.5f);
                // Edge functions scaled by the area's sign: all >= 0 inside, either winding.
                const float s = area > 0 ? 1.0f : -1.0f;
                const float e0 = s * ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x));
                const float e1 = s * ((c.x - b.x) * (p.y - b.y) - (c.y - b.y) * (p.x - b.x));
                const float e2 = s * ((a.x - c.x) * (p.y - c.y) - (a.y - c.y) * (p.x - c.x));
                if (e0 < 0 || e1 < 0 || e2 < 0) continue;
                const glm::vec3 w = glm::vec3(e1, e2, e0) / std::abs(area);  // of a, b, c
                visit(size_t(y) * size_t(width) + size_t(x), i, w, w.x * a.z + w.y * b.z + w.z * c.z);
            }
    }
}

glm::vec3 vec3_at(const float* array, uint32_t index) {
    return glm::vec3(array[3 * index], array[3 * index + 1], array[3 * index + 2]);
}

}  // namespace

void rasterize(const nfd_mesh_data& mesh, const glm::mat4& mvp, Mask* mask) {
    for_each_pixel(mesh, mvp, mask->width, mask->height,
                   [&](size_t pixel, const uint32_t*, const glm::vec3&, float) {
                       mask->covered[pixel] = 1;
                   });
}

void shade(const nfd_mesh_data& mesh, const float* colours, const glm::mat4& mvp,
           const glm::vec3& light, Shaded* image) {
    const glm::vec3 l = glm::normalize(light);
    for_each_pixel(mesh, mvp, image->mask.width, image->mask.height,
                   [&](size_t pixel, const uint32_t* i, const glm::vec3& w, float depth) {
                       if (depth >= image->depth[pixel]) return;  // VK_COMPARE_OP_LESS
                       image->depth[pixel] = depth;
                       image->mask.covered[pixel] = 1;
                       const glm::vec3 n = w.x * vec3_at(mesh.normals, i[0]) +
                                           w.y * vec3_at(mesh.normals, i[1]) +
                                           w.z * vec3_at(mesh.normals, i[2]);
                       const glm::vec3 colour = w.x * vec3_at(colours, i[0]) +
                                                w.y * vec3_at(colours, i[1]) +
                                                w.z * vec3_at(colours, i[2]);
                       const float diffuse = std::abs(glm::dot(glm::normalize(n), l));
                       image->rgb[pixel] = colour * (0.3f + 0.7f * diffuse);
                   });
}

Mask foreground(const unsigned char* rgba, int width, int height, int tolerance) {
    Mask m(width, height);
    int background[3];
    for (int c = 0; c < 3; ++c) background[c] = int(std::lround(kBackground[c] * 255.0f));
    for (size_t i = 0; i < m.covered.size(); ++i)
        for (int c = 0; c < 3; ++c)
            if (std::abs(int(rgba[4 * i + c]) - background[c]) > tolerance) m.covered[i] = 1;
    return m;
}

double iou(const Mask& a, const Mask& b) {
    size_t both = 0, either = 0;
    for (size_t i = 0; i < a.covered.size(); ++i) {
        both += a.covered[i] & b.covered[i];
        either += a.covered[i] | b.covered[i];
    }
    return either ? double(both) / double(either) : 1.0;
}

Mask shifted(const Mask& m, int dx, int dy) {
    Mask out(m.width, m.height);
    for (int y = 0; y < m.height; ++y)
        for (int x = 0; x < m.width; ++x) {
            const int sx = x - dx, sy = y - dy;
            if (sx >= 0 && sy >= 0 && sx < m.width && sy < m.height)
                out.covered[size_t(y) * m.width + x] = m.covered[size_t(sy) * m.width + sx];
        }
    return out;
}

}  // namespace nfc_viewer::test
