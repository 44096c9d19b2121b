// The marching-cubes loop shared by the SDF and UDF meshers of the CPU path (extract.h): cells in
// order, the generated table, one welded vertex per grid edge numbered by first use. The meshers
// differ only in how a cell gets its case, which edges may carry a vertex, and where it sits.
#pragma once
#include <cstdint>
#include <vector>

#include "grid.h"
#include "mc_tables.h"
#include "mesh.h"
#include "parallel.h"

#include "host_memory.h"

namespace nfd {

// A crossed grid edge: from vertex v (coordinates of the level meshed) along `axis`, with the corner
// values at its two ends.
struct CrossedEdge {
    uint32_t v[3];
    int axis;
    float fa, fb;
};

// The cells of `level` (the finest, or a coarser one meshed as if it were: progressive.h).
// classify(cell, f, &case_index) -> bool: whether the cell is meshed, and its case (bit c: corner
// c inside). edge_valid(edge) -> bool: whether a triangle may use the edge (all three edges of a
// triangle must be valid). place(edge, u, n): the vertex in the unit frame and its normal.
// Vertices and normals go to `mesh` in the unit frame; returns the number of cells that emitted
// a triangle. mesh_bytes_bound (extract.h) bounds what it allocates. `threads` (as evaluate_cpu's)
// run the first pass, so classify must be safe to call concurrently; the output does not depend
// on them.
template <class Classify, class EdgeValid, class Place>
uint64_t march_cells(const GridLevel& level, unsigned threads, Classify&& classify,
                     EdgeValid&& edge_valid, Place&& place, MeshData* mesh) {
    const mc::Tables& t = mc::tables();
    // Pass 1, over slices of the cells at once: each cell's case, 0 where it has no triangle (case
    // 0 has none). It reads eight corners of every visited cell, of which about one in four has
    // triangles; welding then needs a slot per grid edge of those cells only (a few percent of the
    // band's vertices), not of the whole finest level.
    nfd::vector<uint8_t> cases(level.cells.size());
    parallel_for(level.cells.size(), 16384, threads, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            uint32_t c[3];
            unpack_coords(level.cells[i], c);
            float f[8];
            for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
            int index = 0;
            const bool meshed = classify(c, f, &index) && t.triangle_count[index] != 0;
            cases[i] = meshed ? uint8_t(index) : uint8_t(0);
        }
    });
    VertexSet corners(level.cells_per_axis + 1);
    size_t max_triangles = 0;  // exact for SDF, an upper bound where edge_valid drops some
    for (size_t i = 0; i < cases.size(); ++i) {
        if (!cases[i]) continue;
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        for (const auto& o : mc::kCornerOffset) corners.insert(c[0] + o[0], c[1] + o[1], c[2] + o[2]);
        max_triangles += t.triangle_count[cases[i]];
    }
    corners.finish();
    mesh->indices.reserve(3 * max_triangles);

    // Pass 2: triangles in cell order, one vertex per grid edge (corner rank * 3 + axis).
    constexpr uint32_t kNone = ~0u;
    nfd::vector<uint32_t> edge_vertex(size_t(corners.size()) * 3, kNone);
    uint64_t emitting = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
        if (!cases[i]) continue;
        uint32_t c[3];
        unpack_coords(level.cells[i], c);
        float f[8];
        for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
        const int index = cases[i];
        bool emitted = false;
        for (int tri = 0; tri < t.triangle_count[index]; ++tri) {
            CrossedEdge edges[3];
            bool valid = true;
            for (int j = 0; j < 3; ++j) {
                const int e = t.triangles[index][3 * tri + j];
                const int a = mc::kEdgeCorners[e][0], b = mc::kEdgeCorners[e][1];
                const uint8_t* o = mc::kCornerOffset[a];
                edges[j] = {{c[0] + o[0], c[1] + o[1], c[2] + o[2]}, e / 4, f[a], f[b]};
                valid = valid && edge_valid(edges[j]);
            }
            if (!valid) continue;
            emitted = true;
            for (const CrossedEdge& edge : edges) {
                const size_t key = size_t(corners.rank(edge.v[0], edge.v[1], edge.v[2])) * 3;
                uint32_t& slot = edge_vertex[key + size_t(edge.axis)];
                if (slot == kNone) {
                    float u[3], n[3];
                    place(edge, u, n);
                    slot = uint32_t(mesh->positions.size() / 3);
                    mesh->positions.insert(mesh->positions.end(), u, u + 3);
                    mesh->normals.insert(mesh->normals.end(), n, n + 3);
                }
                mesh->indices.push_back(slot);
            }
        }
        emitting += emitted;
    }
    return emitting;
}

// The unit-frame position of the point at t along a crossed edge.
inline void edge_point(const GridLevel& level, const CrossedEdge& edge, float t, float u[3]) {
    for (int j = 0; j < 3; ++j) u[j] = level.coord(edge.v[j]);
    u[edge.axis] += t * (level.coord(edge.v[edge.axis] + 1) - u[edge.axis]);
}

}  // namespace nfd
