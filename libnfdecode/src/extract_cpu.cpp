// CPU reference of the sparse coarse-to-fine extraction (extract.h). Each level keeps a list of
// cells; their corners are collected in a VertexSet (a bitmap with ranks), evaluated once, and the
// cells that may contain the surface pass their eight children to the next level. At the finest
// level marching cubes runs on the cells with a sign change. The GPU path (gpu/) mirrors this.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "extract.h"
#include "mc_tables.h"

namespace nfd {
namespace {

constexpr uint32_t kMinCoarse = 32;
constexpr size_t kEvalChunk = size_t(1) << 20;  // points per evaluate_cpu call: bounds scratch

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

uint32_t cells_at_level(uint32_t resolution, uint32_t level) {
    return (resolution + (1u << level) - 1) >> level;
}

// Cell coordinates are < 1024 at every level and vertex coordinates <= 1024: 11 bits each.
uint32_t pack(uint32_t x, uint32_t y, uint32_t z) { return x | y << 11 | z << 22; }
void unpack(uint32_t c, uint32_t* xyz) {
    xyz[0] = c & 0x7FF;
    xyz[1] = c >> 11 & 0x7FF;
    xyz[2] = c >> 22;
}

// The vertices of one level's cells as a bitmap over its (n+1)^3 grid, with a prefix count per
// 64-bit word so that a vertex's rank (its slot in the value array) is one popcount away. Dense
// ranks need no hashing; the price is 1.5 bits per grid vertex (25 MiB at resolution 512).
class VertexSet {
public:
    explicit VertexSet(uint32_t cells_per_axis)
        : side_(uint64_t(cells_per_axis) + 1), bits_((side_ * side_ * side_ + 63) / 64) {}

    uint64_t side() const { return side_; }
    uint64_t index(uint32_t x, uint32_t y, uint32_t z) const { return (z * side_ + y) * side_ + x; }
    void insert(uint64_t i) { bits_[i >> 6] |= uint64_t(1) << (i & 63); }
    bool contains(uint64_t i) const { return bits_[i >> 6] >> (i & 63) & 1; }
    void finish() {
        prefix_.resize(bits_.size());
        uint32_t total = 0;
        for (size_t w = 0; w < bits_.size(); ++w) {
            prefix_[w] = total;
            total += uint32_t(__builtin_popcountll(bits_[w]));
        }
        size_ = total;
    }
    uint32_t rank(uint64_t i) const {
        const uint64_t below = bits_[i >> 6] & ((uint64_t(1) << (i & 63)) - 1);
        return prefix_[i >> 6] + uint32_t(__builtin_popcountll(below));
    }
    uint32_t size() const { return size_; }
    // fn(rank, x, y, z) for every vertex, in rank order.
    template <class Fn>
    void for_each(Fn&& fn) const {
        uint32_t r = 0;
        for (size_t w = 0; w < bits_.size(); ++w) {
            for (uint64_t b = bits_[w]; b; b &= b - 1) {
                const uint64_t i = w * 64 + uint64_t(__builtin_ctzll(b));
                fn(r++, uint32_t(i % side_), uint32_t(i / side_ % side_),
                   uint32_t(i / (side_ * side_)));
            }
        }
    }

private:
    uint64_t side_;
    std::vector<uint64_t> bits_;
    std::vector<uint32_t> prefix_;
    uint32_t size_ = 0;
};

struct Grid {
    uint32_t resolution;
    float step;  // fine cell edge in the unit frame
    float coord(uint32_t fine_index) const { return -1.0f + float(fine_index) * step; }
};

// Evaluates points in chunks: `emit(k, xyz)` writes the k-th point, `store(k, value)` takes its
// value. Keeps scratch memory at kEvalChunk points whatever the level size.
template <class Emit, class Store>
void evaluate_chunked(const Network& net, size_t count, unsigned threads, Emit&& emit,
                      Store&& store) {
    std::vector<float> xyz(3 * std::min(count, kEvalChunk)), values(std::min(count, kEvalChunk));
    for (size_t begin = 0; begin < count; begin += kEvalChunk) {
        const size_t n = std::min(kEvalChunk, count - begin);
        for (size_t k = 0; k < n; ++k) emit(begin + k, &xyz[3 * k]);
        evaluate_cpu(net, xyz.data(), n, values.data(), threads);
        for (size_t k = 0; k < n; ++k) store(begin + k, values[k]);
    }
}

struct Level {
    uint32_t level = 0;
    VertexSet vertices{0};
    std::vector<float> values;  // by vertex rank
    float corner(const uint32_t* cell, int c) const {
        const uint8_t* o = mc::kCornerOffset[c];
        return values[vertices.rank(vertices.index(cell[0] + o[0], cell[1] + o[1], cell[2] + o[2]))];
    }
    // The value at vertex v, if v is on the grid and was evaluated (a corner of a visited cell).
    bool find(const int64_t v[3], float* f) const {
        for (int a = 0; a < 3; ++a)
            if (v[a] < 0 || uint64_t(v[a]) >= vertices.side()) return false;
        const uint64_t i = vertices.index(uint32_t(v[0]), uint32_t(v[1]), uint32_t(v[2]));
        if (!vertices.contains(i)) return false;
        *f = values[vertices.rank(i)];
        return true;
    }
};

// Collects and evaluates the corners of `cells`. Vertices with all-even coordinates were corners of
// the parent level (every child's even corners are its parent's corners) and are copied, not
// re-evaluated: one evaluation in eight saved.
Level evaluate_level(const Network& net, const Grid& grid, uint32_t level,
                     const std::vector<uint32_t>& cells, const Level* parent, unsigned threads,
                     uint64_t* evaluated) {
    Level out;
    out.level = level;
    out.vertices = VertexSet(cells_at_level(grid.resolution, level));
    for (uint32_t packed : cells) {
        uint32_t c[3];
        unpack(packed, c);
        for (const auto& o : mc::kCornerOffset)
            out.vertices.insert(out.vertices.index(c[0] + o[0], c[1] + o[1], c[2] + o[2]));
    }
    out.vertices.finish();
    out.values.resize(out.vertices.size());

    std::vector<uint32_t> todo;  // packed vertex coordinates to evaluate, with their ranks
    std::vector<uint32_t> todo_rank;
    out.vertices.for_each([&](uint32_t r, uint32_t x, uint32_t y, uint32_t z) {
        if (parent && ((x | y | z) & 1) == 0) {
            const VertexSet& pv = parent->vertices;
            out.values[r] = parent->values[pv.rank(pv.index(x / 2, y / 2, z / 2))];
        } else {
            todo.push_back(pack(x, y, z));
            todo_rank.push_back(r);
        }
    });
    evaluate_chunked(
        net, todo.size(), threads,
        [&](size_t k, float* xyz) {
            uint32_t v[3];
            unpack(todo[k], v);
            for (int a = 0; a < 3; ++a) xyz[a] = grid.coord(v[a] << level);
        },
        [&](size_t k, float value) { out.values[todo_rank[k]] = value; });
    *evaluated += todo.size();
    return out;
}

std::vector<uint32_t> refine(const Grid& grid, const Level& level,
                             const std::vector<uint32_t>& cells) {
    const float h = grid.step * float(1u << level.level);
    const uint32_t child_cells = cells_at_level(grid.resolution, level.level - 1);
    std::vector<uint32_t> children;
    for (uint32_t packed : cells) {
        uint32_t c[3];
        unpack(packed, c);
        float f[8];
        for (int k = 0; k < 8; ++k) f[k] = level.corner(c, k);
        if (!cell_may_contain_surface(f, h)) continue;
        for (const auto& o : mc::kCornerOffset) {
            const uint32_t x = 2 * c[0] + o[0], y = 2 * c[1] + o[1], z = 2 * c[2] + o[2];
            if (x < child_cells && y < child_cells && z < child_cells)
                children.push_back(pack(x, y, z));
        }
    }
    return children;
}

// Derivative along axis b at vertex w (value fw) in units of 1 / cell: central where both
// neighbours were evaluated, one-sided where one was (the domain boundary, the edge of the band).
float grid_derivative(const Level& level, int64_t w[3], float fw, int b) {
    float hi = 0.0f, lo = 0.0f;
    ++w[b];
    const bool has_hi = level.find(w, &hi);
    w[b] -= 2;
    const bool has_lo = level.find(w, &lo);
    ++w[b];
    if (has_hi && has_lo) return 0.5f * (hi - lo);
    if (has_hi) return hi - fw;
    if (has_lo) return fw - lo;
    return 0.0f;
}

// extract.h's vertex normal on the grid edge from v (value fa) along `axis` (value fb), crossed at
// t. The four cells around a crossed edge all have a sign change, so in the band the neighbour
// values are ones already evaluated: normals cost no field evaluation.
void edge_normal(const Level& level, const uint32_t v[3], int axis, float fa, float fb, float t,
                 float n[3]) {
    float g[3];
    g[axis] = fb - fa;
    for (int b = 0; b < 3; ++b) {
        if (b == axis) continue;
        int64_t w[3] = {v[0], v[1], v[2]};
        const float d0 = grid_derivative(level, w, fa, b);
        ++w[axis];
        const float d1 = grid_derivative(level, w, fb, b);
        g[b] = d0 + t * (d1 - d0);
    }
    const float len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (len > 0.0f && std::isfinite(len)) {
        for (int a = 0; a < 3; ++a) n[a] = g[a] / len;
    } else {  // flat field at the vertex: its edge still tells inside from outside
        n[0] = n[1] = n[2] = 0.0f;
        n[axis] = fa < 0.0f ? 1.0f : -1.0f;
    }
}

// Vertices (unit frame) and normals go to `mesh`; the caller maps positions to the original frame.
void marching_cubes(const Grid& grid, const Level& level, const std::vector<uint32_t>& cells,
                    MeshData* mesh, uint64_t* active_cells) {
    const mc::Tables& t = mc::tables();
    constexpr uint32_t kNone = ~0u;
    // One slot per grid edge (vertex rank * 3 + axis): welding is a lookup, not a hash.
    std::vector<uint32_t> edge_vertex(size_t(level.vertices.size()) * 3, kNone);
    for (uint32_t packed : cells) {
        uint32_t c[3];
        unpack(packed, c);
        float f[8];
        int index = 0;
        for (int k = 0; k < 8; ++k) {
            f[k] = level.corner(c, k);
            index |= int(f[k] < 0.0f) << k;
        }
        if (t.triangle_count[index] == 0) continue;
        ++*active_cells;
        for (int k = 0; k < 3 * t.triangle_count[index]; ++k) {
            const int e = t.triangles[index][k];
            const int a = mc::kEdgeCorners[e][0], b = mc::kEdgeCorners[e][1], axis = e / 4;
            const uint8_t* o = mc::kCornerOffset[a];
            const uint32_t v[3] = {c[0] + o[0], c[1] + o[1], c[2] + o[2]};
            uint32_t& slot =
                edge_vertex[size_t(level.vertices.rank(level.vertices.index(v[0], v[1], v[2]))) *
                                3 + size_t(axis)];
            if (slot == kNone) {
                float u[3], n[3];
                for (int j = 0; j < 3; ++j) u[j] = grid.coord(v[j]);
                float t_cross = f[a] / (f[a] - f[b]);  // f[a], f[b] differ in sign
                if (!(t_cross >= 0.0f && t_cross <= 1.0f)) t_cross = 0.5f;  // an infinite corner
                u[axis] += t_cross * (grid.coord(v[axis] + 1) - u[axis]);
                edge_normal(level, v, axis, f[a], f[b], t_cross, n);
                slot = uint32_t(mesh->positions.size() / 3);
                mesh->positions.insert(mesh->positions.end(), u, u + 3);
                mesh->normals.insert(mesh->normals.end(), n, n + 3);
            }
            mesh->indices.push_back(slot);
        }
    }
}

}  // namespace

uint32_t refinement_levels(uint32_t resolution) {
    uint32_t levels = 0;
    while (levels < 31 && cells_at_level(resolution, levels + 1) >= kMinCoarse) ++levels;
    return levels;
}

uint32_t coarse_resolution(uint32_t resolution) {
    return cells_at_level(resolution, refinement_levels(resolution));
}

bool cell_may_contain_surface(const float corner_values[8], float h) {
    bool negative = false, positive = false;
    float min_abs = INFINITY;
    for (int k = 0; k < 8; ++k) {
        const float f = corner_values[k];
        negative |= f < 0.0f;
        positive |= f >= 0.0f;
        min_abs = std::min(min_abs, std::fabs(f));
    }
    // NaN corners fail every comparison: the cell is dropped rather than meshed from garbage.
    return (negative && positive) || min_abs <= kLipschitzMargin * h * 0.8660254f;  // sqrt(3)/2
}

nfd_result extract_mesh_cpu(const Geometry& geometry, uint32_t resolution, MeshData* mesh,
                            ExtractStats* stats, unsigned threads) {
    if (resolution < NFD_MIN_RESOLUTION || resolution > NFD_MAX_RESOLUTION)
        return NFD_ERROR_LIMIT_EXCEEDED;
    if (geometry.field != FieldType::Sdf) return NFD_ERROR_UNSUPPORTED_FEATURE;
    const Network& net = geometry.network;
    const Grid grid{resolution, 2.0f / float(resolution)};
    ExtractStats st;

    const auto t_field = std::chrono::steady_clock::now();
    const uint32_t levels = refinement_levels(resolution);
    const uint32_t coarse = cells_at_level(resolution, levels);
    std::vector<uint32_t> cells;
    cells.reserve(size_t(coarse) * coarse * coarse);
    for (uint32_t z = 0; z < coarse; ++z)
        for (uint32_t y = 0; y < coarse; ++y)
            for (uint32_t x = 0; x < coarse; ++x) cells.push_back(pack(x, y, z));

    Level level;
    for (uint32_t l = levels;; --l) {
        Level next = evaluate_level(net, grid, l, cells, l == levels ? nullptr : &level, threads,
                                    &st.points_evaluated);
        level = std::move(next);
        if (l == 0) break;
        cells = refine(grid, level, cells);
    }
    st.seconds_field = seconds_since(t_field);

    const auto t_mesh = std::chrono::steady_clock::now();
    MeshData out;
    marching_cubes(grid, level, cells, &out, &st.active_cells);
    for (size_t i = 0; i < out.positions.size(); ++i)
        out.positions[i] = out.positions[i] * geometry.scale + geometry.center[i % 3];
    st.seconds_mesh = seconds_since(t_mesh);

    *mesh = std::move(out);
    if (stats) *stats = st;
    return NFD_SUCCESS;
}

}  // namespace nfd
