// CPU reference of the SDF mesher (extract.h): marching cubes on the finest cells with a sign
// change, normals from the grid values around each crossed edge.
#include <cmath>

#include "extract.h"
#include "marching.h"

namespace nfd {
namespace {

// Derivative along axis b at vertex w (value fw) in units of 1 / cell: central where both
// neighbours were evaluated, one-sided where one was (the domain boundary, the edge of the band).
// One neighbour is a corner of the cell the vertex is placed from (`in_cell`, on the `in_cell_hi`
// side); only the other is looked up.
float grid_derivative(const GridLevel& level, int64_t w[3], float fw, int b, float in_cell,
                      bool in_cell_hi) {
    uint32_t r;
    w[b] += in_cell_hi ? -1 : 1;
    const bool has_other = level.vertices.find(w[0], w[1], w[2], &r);
    w[b] -= in_cell_hi ? -1 : 1;
    if (!has_other) return in_cell_hi ? in_cell - fw : fw - in_cell;
    const float other = level.values[r];
    return in_cell_hi ? 0.5f * (in_cell - other) : 0.5f * (other - in_cell);
}

// extract.h's vertex normal on a crossed edge, crossed at t. The four cells around a crossed edge
// all have a sign change, so in the band the neighbour values are ones already evaluated: normals
// cost no field evaluation.
void edge_normal(const GridLevel& level, const CrossedEdge& e, float t, float n[3]) {
    float g[3];
    g[e.axis] = e.fb - e.fa;
    int corner_a = 0;  // the edge's lower end as a corner of its cell
    for (int a = 0; a < 3; ++a) corner_a |= int(e.v[a] - e.cell[a]) << a;
    const int corner_b = corner_a | 1 << e.axis;
    for (int b = 0; b < 3; ++b) {
        if (b == e.axis) continue;
        const bool hi = (corner_a >> b & 1) == 0;  // the cell's neighbour lies above the edge
        const int across = 1 << b;
        int64_t w[3] = {e.v[0], e.v[1], e.v[2]};
        const float d0 = grid_derivative(level, w, e.fa, b, e.cell_values[corner_a ^ across], hi);
        ++w[e.axis];
        const float d1 = grid_derivative(level, w, e.fb, b, e.cell_values[corner_b ^ across], hi);
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

nfd_result mesh_sdf_cpu(const GridLevel& level, const OutputFrame& frame, unsigned threads,
                        MeshData* mesh, uint64_t* active_cells) {
    nfd::vector<uint8_t> meshed;
    *active_cells = march_cells(
        level, threads, level.meshed_cells(nullptr, &meshed),
        [](const uint32_t*, const float* f, const uint32_t*, int* index) {
            for (int k = 0; k < 8; ++k) *index |= int(f[k] < 0.0f) << k;
            return true;
        },
        [](const CrossedEdge&) { return true; },
        [&](const CrossedEdge& e, float p[3], float n[3]) {
            float t = e.fa / (e.fa - e.fb);              // fa, fb differ in sign
            if (!(t >= 0.0f && t <= 1.0f)) t = 0.5f;     // an infinite corner
            edge_point(level, e, t, frame, p);
            edge_normal(level, e, t, n);
        },
        mesh);
    return NFD_SUCCESS;
}

}  // namespace nfd
