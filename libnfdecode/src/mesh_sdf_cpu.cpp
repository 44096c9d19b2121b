// CPU reference of the SDF mesher (extract.h): marching cubes on the finest cells with a sign
// change, normals from the grid values around each crossed edge.
#include <cmath>

#include "extract.h"
#include "marching.h"

namespace nfd {
namespace {

// Derivative along axis b at vertex w (value fw) in units of 1 / cell: central where both
// neighbours were evaluated, one-sided where one was (the domain boundary, the edge of the band).
float grid_derivative(const GridLevel& level, int64_t w[3], float fw, int b) {
    uint32_t r;
    float hi = 0.0f, lo = 0.0f;
    ++w[b];
    const bool has_hi = level.vertices.find(w[0], w[1], w[2], &r);
    if (has_hi) hi = level.values[r];
    w[b] -= 2;
    const bool has_lo = level.vertices.find(w[0], w[1], w[2], &r);
    if (has_lo) lo = level.values[r];
    ++w[b];
    if (has_hi && has_lo) return 0.5f * (hi - lo);
    if (has_hi) return hi - fw;
    if (has_lo) return fw - lo;
    return 0.0f;
}

// extract.h's vertex normal on a crossed edge, crossed at t. The four cells around a crossed edge
// all have a sign change, so in the band the neighbour values are ones already evaluated: normals
// cost no field evaluation.
void edge_normal(const GridLevel& level, const CrossedEdge& e, float t, float n[3]) {
    float g[3];
    g[e.axis] = e.fb - e.fa;
    for (int b = 0; b < 3; ++b) {
        if (b == e.axis) continue;
        int64_t w[3] = {e.v[0], e.v[1], e.v[2]};
        const float d0 = grid_derivative(level, w, e.fa, b);
        ++w[e.axis];
        const float d1 = grid_derivative(level, w, e.fb, b);
        g[b] = d0 + t * (d1 - d0);
    }
    const float len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (len > 0.0f && std::isfinite(len)) {
        for (int a = 0; a < 3; ++a) n[a] = g[a] / len;
    } else {  // flat field at the vertex: its edge still tells inside from outside
        n[0] = n[1] = n[2] = 0.0f;
        n[e.axis] = e.fa < 0.0f ? 1.0f : -1.0f;
    }
}

}  // namespace

nfd_result mesh_sdf_cpu(const GridLevel& level, unsigned threads, MeshData* mesh,
                        uint64_t* active_cells) {
    *active_cells = march_cells(
        level, threads,
        [](const uint32_t*, const float* f, int* index) {
            for (int k = 0; k < 8; ++k) *index |= int(f[k] < 0.0f) << k;
            return true;
        },
        [](const CrossedEdge&) { return true; },
        [&](const CrossedEdge& e, float u[3], float n[3]) {
            float t = e.fa / (e.fa - e.fb);              // fa, fb differ in sign
            if (!(t >= 0.0f && t <= 1.0f)) t = 0.5f;     // an infinite corner
            edge_point(level, e, t, u);
            edge_normal(level, e, t, n);
        },
        mesh);
    return NFD_SUCCESS;
}

}  // namespace nfd
