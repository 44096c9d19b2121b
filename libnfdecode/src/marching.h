// The marching-cubes loop shared by the SDF and UDF meshers of the CPU path (extract.h): cells in
// order, the generated table, one welded vertex per grid edge numbered by first use. The meshers
// differ only in how a cell gets its case, which edges may carry a vertex, and where it sits.
#pragma once
#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "grid.h"
#include "mc_tables.h"
#include "mesh.h"
#include "parallel.h"

#include "host_memory.h"

namespace nfd {

// A crossed grid edge, seen from one of its cells: from vertex v (coordinates of the level meshed)
// along `axis`, with the corner values and the level's vertex ranks at its two ends, and that
// cell's lowest corner and eight corner values (mc::kCornerOffset order), which hold one neighbour
// of each end across each other axis.
struct CrossedEdge {
    uint32_t v[3];
    int axis;
    float fa, fb;
    uint32_t ra, rb;
    const uint32_t* cell;
    const float* cell_values;
};

namespace marching_detail {

static_assert(mc::kMaxTrianglesPerCase <= 8, "a cell's emitted triangles are one bit each of a byte");
constexpr size_t kOrderRun = 16384;       // visited cells per run of the passes after the first
constexpr size_t kIndexGrain = 65536;     // indices per parallel slice at least
constexpr uint32_t kPlaced = 1u << 31;    // edge_owner entry: the edge's vertex, not its owner
constexpr uint32_t kOwnedKey = 1u << 31;  // a cell's key of an edge whose vertex the cell makes

// fn(e) for the table edge of every corner of the triangles of case `index` whose bit is set in
// `emitted`, in table order: the order in which the triangles' indices are written.
template <class Fn>
void for_each_emitted_edge(int index, uint8_t emitted, Fn&& fn) {
    const mc::Tables& t = mc::tables();
    for (int tri = 0; tri < t.triangle_count[index]; ++tri)
        if (emitted >> tri & 1)
            for (int j = 0; j < 3; ++j) fn(int(t.triangles[index][3 * tri + j]));
}

inline CrossedEdge crossed_edge(const uint32_t c[3], int e, const float f[8], const uint32_t r[8]) {
    const int a = mc::kEdgeCorners[e][0], b = mc::kEdgeCorners[e][1];
    const uint8_t* o = mc::kCornerOffset[a];
    return {{c[0] + o[0], c[1] + o[1], c[2] + o[2]}, e / 4, f[a], f[b], r[a], r[b], c, f};
}

// A grid edge's slot in the welding table: the level's rank of its lower end (`corner_ranks` of
// the cell, VertexSet::cell_ranks), times 3, plus its axis. At most 3 * 1025^3 < 2^32.
inline uint32_t edge_key(const uint32_t corner_ranks[8], int e) {
    return corner_ranks[mc::kEdgeCorners[e][0]] * 3 + uint32_t(e / 4);
}

inline void atomic_min(uint32_t* slot, uint32_t value) {
    uint32_t seen = __atomic_load_n(slot, __ATOMIC_RELAXED);
    while (value < seen &&
           !__atomic_compare_exchange_n(slot, &seen, value, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
    }
}

// Whether keys[p] is the first occurrence of its key in keys[0..p] (those before p may carry
// kOwnedKey): a cell writes at most 3 * 5 keys.
inline bool first_occurrence(const uint32_t* keys, size_t p) {
    for (size_t q = 0; q < p; ++q)
        if ((keys[q] & ~kOwnedKey) == keys[p]) return false;
    return true;
}

}  // namespace marching_detail

// The cells of `level` (the finest, or a coarser one meshed as if it were: progressive.h), or
// those of them with only[i] != 0 where `only` is given (the others emit nothing).
// classify(cell, f, ranks, &case_index) -> bool (f and ranks: the cell's corner values and vertex
// ranks, mc::kCornerOffset order): whether the cell is meshed, and its case (bit c: corner
// c inside). edge_valid(edge) -> bool: whether a triangle may use the edge (all three edges of a
// triangle must be valid). place(edge, p, n): the vertex (edge_point) and its normal. Vertices
// and normals go to `mesh`; returns the number of cells that emitted a triangle.
// mesh_bytes_bound (extract.h) bounds what it allocates. Every pass runs on `threads`
// (as evaluate_cpu's), so the three callbacks must be safe to call concurrently; the output does
// not depend on them, and is the one a single loop over the cells would give (each vertex made at
// its edge's first use): std::length_error past 2^31 visited cells or vertices.
template <class Classify, class EdgeValid, class Place>
uint64_t march_cells(const GridLevel& level, unsigned threads, const uint8_t* only,
                     Classify&& classify, EdgeValid&& edge_valid, Place&& place, MeshData* mesh) {
    using namespace marching_detail;
    const mc::Tables& t = mc::tables();
    // Pass 1, over the visited cells: each one's case and the triangles it emits (bit tri). About
    // one visited cell in four emits; eight siblings read their 27 corners once.
    const size_t visited = level.cells.size();
    nfd::vector<uint8_t> cases(visited), emitted(visited);
    auto visit = [&](size_t i, const uint32_t c[3], const float f[8], const uint32_t r[8]) {
        int index = 0;
        uint8_t mask = 0;
        if (classify(c, f, r, &index))
            for (int tri = 0; tri < t.triangle_count[index]; ++tri) {
                bool valid = true;
                for (int j = 0; j < 3 && valid; ++j)
                    valid = edge_valid(crossed_edge(c, t.triangles[index][3 * tri + j], f, r));
                mask |= uint8_t(valid) << tri;
            }
        cases[i] = uint8_t(index);
        emitted[i] = mask;
    };
    parallel_for(visited, 16384, threads, [&](size_t begin, size_t end) {
        level.for_each_cell(begin, end, only, visit);
    });

    // The visited cells go by runs of kOrderRun, in order: each pass below walks a run's emitting
    // cells in turn, and what a run starts at (its first triangle, then its first vertex) comes
    // from the counts of the runs before it, so no per-cell table is needed.
    if (visited >= kPlaced || uint64_t(level.vertices.size()) * 3 >= kOwnedKey)
        throw std::length_error("march_cells: too many cells or vertices");
    const size_t runs = (visited + kOrderRun - 1) / kOrderRun;
    nfd::vector<uint64_t> run_cells(runs + 1), run_triangles(runs + 1), run_vertices(runs + 1);
    for_each_range(visited, kOrderRun, threads, [&](size_t run, size_t first, size_t last) {
        uint64_t cells = 0, triangles = 0;
        for (size_t i = first; i < last; ++i) {
            cells += emitted[i] != 0;
            triangles += popcount64(emitted[i]);
        }
        run_cells[run + 1] = cells;
        run_triangles[run + 1] = triangles;
    });
    for (size_t run = 0; run < runs; ++run) {
        run_cells[run + 1] += run_cells[run];
        run_triangles[run + 1] += run_triangles[run];
    }
    mesh->indices.resize(size_t(3) * run_triangles[runs]);
    uint32_t* const keys = mesh->indices.data();  // edge keys first, vertex indices at the end
    // fn(i, its keys) for the emitting cells of a run, in order.
    auto for_each_emitting = [&](size_t run, size_t first, size_t last, auto&& fn) {
        uint32_t* key = keys + size_t(3) * run_triangles[run];
        for (size_t i = first; i < last; ++i) {
            if (!emitted[i]) continue;
            fn(uint32_t(i), key);
            key += size_t(3) * popcount64(emitted[i]);
        }
    };

    // Pass 2: each emitting cell writes the keys of its triangles' edges, and an edge's owner is
    // the first cell to use it (its index among the visited ones): the one that makes its vertex
    // in a single loop over the cells. The owner table (3 slots a vertex: 14 MB at 512 for the
    // bunny) is filled on threads.
    nfd::uninitialized_vector<uint32_t> edge_owner(size_t(level.vertices.size()) * 3);
    parallel_for(edge_owner.size(), 1 << 20, threads, [&](size_t begin, size_t end) {
        std::fill(edge_owner.begin() + begin, edge_owner.begin() + end, ~0u);
    });
    for_each_range(visited, kOrderRun, threads, [&](size_t run, size_t first, size_t last) {
        for_each_emitting(run, first, last, [&](uint32_t i, uint32_t* key) {
            uint32_t c[3], r[8];
            unpack_coords(level.cells[i], c);
            level.vertices.cell_ranks(c[0], c[1], c[2], r);
            for_each_emitted_edge(cases[i], emitted[i], [&](int e) {
                *key = edge_key(r, e);
                atomic_min(&edge_owner[*key++], i);
            });
        });
    });

    // Pass 3: the vertices each run makes (its cells' owned edges, once each), each marked in its
    // cell's keys (kOwnedKey); their prefix sums number them in first-use order. No branch
    // waits on the owner table's scattered reads here, so they overlap.
    for_each_range(visited, kOrderRun, threads, [&](size_t run, size_t first, size_t last) {
        uint64_t made = 0;
        for_each_emitting(run, first, last, [&](uint32_t i, uint32_t* cell_keys) {
            for (size_t p = 0, n = 3 * size_t(popcount64(emitted[i])); p < n; ++p) {
                const bool owned = edge_owner[cell_keys[p]] == i && first_occurrence(cell_keys, p);
                cell_keys[p] |= owned ? kOwnedKey : 0u;
                made += owned;
            }
        });
        run_vertices[run + 1] = made;
    });
    for (size_t run = 0; run < runs; ++run) run_vertices[run + 1] += run_vertices[run];
    const size_t vertex_count = run_vertices[runs];
    if (vertex_count >= kPlaced) throw std::length_error("march_cells: too many vertices");
    mesh->positions.resize(3 * vertex_count);
    mesh->normals.resize(3 * vertex_count);

    // Pass 4: each cell places the vertices its keys mark, and their owner entries become the
    // vertices (kPlaced set; each entry has one owner, so no other thread writes or reads it).
    for_each_range(visited, kOrderRun, threads, [&](size_t run, size_t first, size_t last) {
        uint32_t vertex = uint32_t(run_vertices[run]);
        for_each_emitting(run, first, last, [&](uint32_t i, uint32_t* key) {
            uint32_t c[3], r[8];
            float f[8];
            bool read = false;  // the corners, read at the cell's first vertex
            for_each_emitted_edge(cases[i], emitted[i], [&](int e) {
                const uint32_t k = *key;
                *key++ = k & ~kOwnedKey;
                if (!(k & kOwnedKey)) return;
                if (!read) {
                    unpack_coords(level.cells[i], c);
                    level.corners(c, f, r);
                    read = true;
                }
                place(crossed_edge(c, e, f, r), &mesh->positions[3 * size_t(vertex)],
                      &mesh->normals[3 * size_t(vertex)]);
                edge_owner[k & ~kOwnedKey] = vertex++ | kPlaced;
            });
        });
    });

    // Pass 5: keys become vertex indices.
    parallel_for(mesh->indices.size(), kIndexGrain, threads, [&](size_t begin, size_t end) {
        for (size_t p = begin; p < end; ++p) keys[p] = edge_owner[keys[p]] & ~kPlaced;
    });
    return run_cells[runs];
}

// The point at t along a crossed edge, in `frame`: its unit-frame position u, then u * scale +
// center.
inline void edge_point(const GridLevel& level, const CrossedEdge& edge, float t,
                       const OutputFrame& frame, float p[3]) {
    float u[3];
    for (int j = 0; j < 3; ++j) u[j] = level.coord(edge.v[j]);
    u[edge.axis] += t * (level.coord(edge.v[edge.axis] + 1) - u[edge.axis]);
    for (int j = 0; j < 3; ++j) p[j] = u[j] * frame.scale + frame.center[j];
}

}  // namespace nfd
