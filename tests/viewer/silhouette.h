// Silhouettes for the viewer test: a CPU rasterisation of decoded meshes through the viewer's own
// camera and layout (samples/viewer/scene.h), the foreground of a screenshot, and their overlap;
// and the colours the viewer's lit shading gives a coloured mesh.
#pragma once

#include <nfdecode/nfdecode.h>

#include <cstdint>
#include <vector>

#include "scene.h"

namespace nfc_viewer::test {

// One byte per pixel, rows top first: 1 where a shape covers the pixel.
struct Mask {
    int width = 0, height = 0;
    std::vector<uint8_t> covered;
    Mask(int w, int h) : width(w), height(h), covered(size_t(w) * size_t(h), 0) {}
    double coverage() const;  // covered fraction of the image
};

// Marks every pixel whose centre lies in a triangle of `mesh` projected by `mvp` (either
// winding: the viewer does not cull), as the Vulkan viewport (0, 0, width, height) maps clip space.
void rasterize(const nfd_mesh_data& mesh, const glm::mat4& mvp, Mask* mask);

// What samples/viewer/shaders/mesh.frag draws of a mesh with per-vertex `colours` (3 floats a
// vertex) in lit mode: per pixel the nearest triangle's interpolated colour times the two-sided
// Lambert 0.3 + 0.7 |n . l| of its interpolated normal, `light` the direction towards the light
// (the model is a uniform scale and a translation: normals need no transform). Pixels rows top
// first, RGB in [0, 1]; `mask` marks those drawn (as rasterize does).
struct Shaded {
    Mask mask;
    std::vector<glm::vec3> rgb;
    std::vector<float> depth;  // clip depth of the nearest triangle so far (the far plane is 1)
    Shaded(int w, int h)
        : mask(w, h), rgb(size_t(w) * size_t(h), glm::vec3(0.0f)), depth(rgb.size(), 2.0f) {}
};
void shade(const nfd_mesh_data& mesh, const float* colours, const glm::mat4& mvp,
           const glm::vec3& light, Shaded* image);

// The pixels of an RGBA8 image (rows top first) that differ from kBackground by more than
// `tolerance` (0..255) in some channel.
Mask foreground(const unsigned char* rgba, int width, int height, int tolerance = 8);

// Intersection over union of two masks of one size (1 when both are empty).
double iou(const Mask& a, const Mask& b);

// `m` moved by (dx, dy) pixels, what moves out of the image dropped.
Mask shifted(const Mask& m, int dx, int dy);

}  // namespace nfc_viewer::test
