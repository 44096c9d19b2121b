// Shared by the fuzz targets: a failed promise that says which, and one CPU context per process.
#pragma once
#include <nfdecode/nfdecode.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>

namespace {

// Says which check failed, then aborts (libFuzzer keeps the input).
inline void require_at(bool ok, const char* file, int line) {
    if (ok) return;
    std::fprintf(stderr, "%s:%d: check failed\n", file, line);
    std::abort();
}
#define require(ok) require_at((ok), __FILE__, __LINE__)

// Every value finite and, with `unit_interval` (colours), in [0, 1].
inline void require_finite(const float* v, size_t n, bool unit_interval = false) {
    for (size_t i = 0; i < n; ++i)
        require(std::isfinite(v[i]) && (!unit_interval || (v[i] >= 0.0f && v[i] <= 1.0f)));
}

// Reads a mesh's arrays and colours (NULL without), and requires what nfdecode.h promises of them:
// finite positions and normals, indices in range, colours in [0, 1].
inline void read_valid_mesh(const nfd_mesh* mesh, nfd_mesh_data* data, const float** colours) {
    require(nfd_mesh_get_data(mesh, data) == NFD_SUCCESS);
    require(nfd_mesh_get_colours(mesh, colours) == NFD_SUCCESS);
    require_finite(data->positions, 3 * data->vertex_count);
    require_finite(data->normals, 3 * data->vertex_count);
    for (size_t i = 0; i < 3 * data->triangle_count; ++i) require(data->indices[i] < data->vertex_count);
    if (*colours) require_finite(*colours, 3 * data->vertex_count, true);
}

// A single-threaded CPU context, made once; null if it cannot be (the target then does nothing).
inline nfd_context* cpu_context() {
    static nfd_context* context = [] {
        nfd_context_options co{};
        co.struct_size = sizeof co;
        co.device = NFD_DEVICE_CPU;
        co.cpu_threads = 1;
        nfd_context* c = nullptr;
        return nfd_context_create(&co, &c) == NFD_SUCCESS ? c : nullptr;
    }();
    return context;
}

}  // namespace
