// The marching-cubes loop shared by the SDF and UDF meshers of the CPU path (extract.h): cells in
// order, the generated table, one welded vertex per grid edge numbered by first use. The meshers
// differ only in how a cell gets its case, which edges may carry a vertex, and where it sits.
#pragma once
#include <cstdint>
#include <vector>

#include "grid.h"
#include "mc_tables.h"
#include "mesh.h"

namespace nfd {

// A crossed grid edge: from vertex v (finest-level coordinates) along `axis`, with the corner
// values at its two ends.
struct CrossedEdge {
    uint32_t v[3];
    int axis;
    float fa, fb;
    uint32_t rank_a, rank_b;  // vertex ranks of the two ends in the finest level
};

// classify(cell, f, &case_index) -> bool: whether the cell is meshed, and its case (bit c: corner
// c inside). edge_valid(edge) -> bool: whether a triangle may use the edge (all three edges of a
// triangle must be valid). place(edge, u, n): the vertex in the unit frame and its normal.
// Vertices and normals go to `mesh` in the unit frame; returns the number of cells that emitted
// a triangle.
template <class Classify, class EdgeValid, class Place>
uint64_t march_cells(const SparseGrid& grid, Classify&& classify, EdgeValid&& edge_valid,
                     Place&& place, MeshData* mesh) {
    const GridLevel& level = grid.finest();
    const mc::Tables& t = mc::tables();
    constexpr uint32_t kNone = ~0u;
    // One slot per grid edge (vertex rank * 3 + axis): welding is a lookup, not a hash.
    std::vector<uint32_t> edge_vertex(size_t(level.vertices.size()) * 3, kNone);
    uint64_t active = 0;
    for (uint32_t packed : level.cells) {
        uint32_t c[3];
        unpack_coords(packed, c);
        float f[8];
        for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
        int index = 0;
        if (!classify(c, f, &index) || t.triangle_count[index] == 0) continue;
        bool emitted = false;
        for (int tri = 0; tri < t.triangle_count[index]; ++tri) {
            CrossedEdge edges[3];
            bool valid = true;
            for (int j = 0; j < 3; ++j) {
                const int e = t.triangles[index][3 * tri + j];
                const int a = mc::kEdgeCorners[e][0], b = mc::kEdgeCorners[e][1];
                const uint8_t* oa = mc::kCornerOffset[a];
                const uint8_t* ob = mc::kCornerOffset[b];
                CrossedEdge& edge = edges[j];
                edge = {{c[0] + oa[0], c[1] + oa[1], c[2] + oa[2]}, e / 4, f[a], f[b],
                        level.vertices.rank(c[0] + oa[0], c[1] + oa[1], c[2] + oa[2]),
                        level.vertices.rank(c[0] + ob[0], c[1] + ob[1], c[2] + ob[2])};
                valid = valid && edge_valid(edge);
            }
            if (!valid) continue;
            emitted = true;
            for (const CrossedEdge& edge : edges) {
                uint32_t& slot = edge_vertex[size_t(edge.rank_a) * 3 + size_t(edge.axis)];
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
        active += emitted;
    }
    return active;
}

// The unit-frame position of the point at t along a crossed edge.
inline void edge_point(const SparseGrid& grid, const CrossedEdge& edge, float t, float u[3]) {
    for (int j = 0; j < 3; ++j) u[j] = grid.coord(edge.v[j]);
    u[edge.axis] += t * (grid.coord(edge.v[edge.axis] + 1) - u[edge.axis]);
}

}  // namespace nfd
