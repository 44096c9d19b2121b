// CPU reference of the UDF mesher (extract.h, steps 1-7): pseudo-signs from the gradients at the
// corners of each near cell, marching cubes on them, and the edge filter that drops the faces the
// pseudo-signs invent where there is no surface.
#include <cmath>

#include "extract.h"
#include "marching.h"

namespace nfd {
namespace {

float dot3(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Step 2's canonical direction: the largest-magnitude component (lowest axis on ties) positive.
// False when the vector is zero or not finite.
bool canonical_direction(const float v[3], float out[3]) {
    int major = 0;
    for (int a = 1; a < 3; ++a)
        if (std::fabs(v[a]) > std::fabs(v[major])) major = a;
    if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])) || v[major] == 0.0f)
        return false;
    const float s = v[major] > 0.0f ? 1.0f : -1.0f;
    for (int a = 0; a < 3; ++a) out[a] = s * v[a];
    return true;
}

}  // namespace

nfd_result mesh_udf_cpu(const GridLevel& level, const OutputFrame& frame, unsigned threads,
                        MeshData* mesh, uint64_t* active_cells) {
    if (level.near.size() != level.cells.size() ||
        level.gradient_flags.size() != level.vertices.size() ||
        level.gradients.size() != size_t(3) * level.vertices.size())
        return NFD_ERROR_INTERNAL;  // the level's gradients were not evaluated
    auto gradient = [&](uint32_t rank) { return level.gradients.data() + size_t(3) * rank; };
    const float max_edge_sum = udf_edge_limit(level.cell_size);
    nfd::vector<uint8_t> meshed;
    *active_cells = march_cells(
        level, threads, level.meshed_cells(level.near.data(), &meshed),  // step 1
        [&](const uint32_t*, const float* f, const uint32_t* r, int* index) {
            int nearest = 0;
            for (int k = 1; k < 8; ++k)
                if (f[k] < f[nearest]) nearest = k;
            float n[3];
            if (!canonical_direction(gradient(r[nearest]), n)) return false;  // step 2
            for (int k = 0; k < 8; ++k)  // step 3
                *index |= int(dot3(gradient(r[k]), n) < 0.0f) << k;
            return true;
        },
        [&](const CrossedEdge& e) { return e.fa + e.fb <= max_edge_sum; },  // step 5
        [&](const CrossedEdge& e, float p[3], float n[3]) {
            const float sum = e.fa + e.fb;
            edge_point(level, e, sum > 0.0f ? e.fa / sum : 0.5f, frame, p);  // step 4
            const float *ga = gradient(e.ra), *gb = gradient(e.rb);
            const float d[3] = {ga[0] - gb[0], ga[1] - gb[1], ga[2] - gb[2]};
            float m[3];
            const float len = std::sqrt(dot3(d, d));
            if (canonical_direction(d, m) && len > 0.0f && std::isfinite(len)) {  // step 6
                for (int a = 0; a < 3; ++a) n[a] = m[a] / len;
            } else {
                n[0] = n[1] = n[2] = 0.0f;
                n[e.axis] = 1.0f;
            }
        },
        mesh);
    return NFD_SUCCESS;
}

}  // namespace nfd
