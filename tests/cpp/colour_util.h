// Helpers of the API-level tests (colour, VDB, geo frames, limits): handles that
// free themselves, a mesh as plain arrays, the golden vectors' colour files.
#pragma once
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_util.h"

namespace nfd::test {

struct ContextFree {
    void operator()(nfd_context* c) const { nfd_context_destroy(c); }
};
struct AssetFree {
    void operator()(nfd_asset* a) const { nfd_asset_destroy(a); }
};
struct MeshFree {
    void operator()(nfd_mesh* m) const { nfd_mesh_destroy(m); }
};
using ContextPtr = std::unique_ptr<nfd_context, ContextFree>;
using AssetPtr = std::unique_ptr<nfd_asset, AssetFree>;
using MeshPtr = std::unique_ptr<nfd_mesh, MeshFree>;

// A context of `kind`, or null when it cannot be created (no Vulkan device).
inline ContextPtr make_context(nfd_device_kind kind) {
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = kind;
    nfd_context* c = nullptr;
    return ContextPtr(nfd_context_create(&co, &c) == NFD_SUCCESS ? c : nullptr);
}
inline ContextPtr cpu_context() { return make_context(NFD_DEVICE_CPU); }

// The CPU context and, where there is a Vulkan device, a Vulkan one.
inline std::vector<ContextPtr> cpu_and_vulkan_contexts() {
    std::vector<ContextPtr> all;
    all.push_back(cpu_context());
    if (ContextPtr vk = make_context(NFD_DEVICE_VULKAN)) all.push_back(std::move(vk));
    return all;
}

inline AssetPtr make_asset(const Bytes& bytes) {
    nfd_asset* a = nullptr;
    if (nfd_asset_create(bytes.data(), bytes.size(), &a) != NFD_SUCCESS)
        throw std::runtime_error("file does not parse");
    return AssetPtr(a);
}

inline MeshPtr extract(nfd_context* ctx, const nfd_asset* asset, uint32_t resolution,
                       bool skip_colour = false) {
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    mo.skip_colour = skip_colour;
    nfd_mesh* m = nullptr;
    if (nfd_mesh_extract(ctx, asset, &mo, &m) != NFD_SUCCESS)
        throw std::runtime_error("extraction failed");
    return MeshPtr(m);
}

// Submits one decode to the queue, waits for it and takes its mesh (null unless DONE): the job's
// result, and its final status in *status when given.
inline nfd_result run_job(nfd_queue* q, const nfd_asset* asset, const nfd_mesh_options& mo,
                          MeshPtr* out, nfd_job_status* status = nullptr) {
    nfd_job* job = nullptr;
    const nfd_result submitted = nfd_queue_submit(q, asset, &mo, nullptr, &job);
    if (submitted != NFD_SUCCESS) return submitted;
    const nfd_job_status s = nfd_job_wait(job, UINT64_MAX);
    if (status) *status = s;
    nfd_mesh* m = nullptr;
    const nfd_result r = nfd_job_take_mesh(job, &m);
    out->reset(m);
    nfd_job_destroy(job);
    return r;
}

struct MeshArrays {
    std::vector<float> positions, normals, colours;  // colours empty: none
    std::vector<uint32_t> indices;
    bool same_geometry(const MeshArrays& o) const {
        return positions == o.positions && normals == o.normals && indices == o.indices;
    }
    bool operator==(const MeshArrays& o) const { return same_geometry(o) && colours == o.colours; }
};
inline MeshArrays arrays_of(const nfd_mesh* mesh) {
    nfd_mesh_data d{};
    const float* colours = nullptr;
    if (nfd_mesh_get_data(mesh, &d) != NFD_SUCCESS ||
        nfd_mesh_get_colours(mesh, &colours) != NFD_SUCCESS)
        throw std::runtime_error("mesh getters failed");
    MeshArrays m;
    m.positions.assign(d.positions, d.positions + 3 * d.vertex_count);
    m.normals.assign(d.normals, d.normals + 3 * d.vertex_count);
    m.indices.assign(d.indices, d.indices + 3 * d.triangle_count);
    if (colours) m.colours.assign(colours, colours + 3 * d.vertex_count);
    return m;
}

// nfd_asset_evaluate_colour at original-frame positions (xyz); throws if it fails.
inline std::vector<float> colours_at(nfd_context* ctx, const nfd_asset* asset,
                                     const std::vector<float>& positions) {
    std::vector<float> rgb(positions.size());
    if (nfd_asset_evaluate_colour(ctx, asset, positions.data(), positions.size() / 3, rgb.data()) !=
        NFD_SUCCESS)
        throw std::runtime_error("colour evaluation failed");
    return rgb;
}

// The colour network of a file that has one.
inline Network parse_colour(const Bytes& bytes) {
    ParsedFile f;
    if (parse_file(bytes.data(), bytes.size(), &f) != NFD_SUCCESS || !f.colour)
        throw std::runtime_error("no colour network");
    return *f.colour;
}

// <name>.colours.txt: "x y z r g b" per line, unit-frame points and the reference's colours.
struct ColourSamples {
    std::vector<float> unit, rgb;
};
inline ColourSamples read_colour_samples(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    ColourSamples s;
    float v[6];
    while (in >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5]) {
        s.unit.insert(s.unit.end(), v, v + 3);
        s.rgb.insert(s.rgb.end(), v + 3, v + 6);
    }
    if (s.unit.empty()) throw std::runtime_error("no samples in " + path);
    return s;
}

template <class A, class B>  // float vectors of any allocator
double max_difference(const A& a, const B& b) {
    if (a.size() != b.size()) return INFINITY;
    double d = 0;
    for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::fabs(double(a[i]) - double(b[i])));
    return d;
}

}  // namespace nfd::test
