// libFuzzer target: a progressive extraction (nfd_extraction) of any file the parser accepts, on the
// C++ path, against what nfdecode.h promises of it ("Progressive extraction"): each step reports
// its ladder level, meshes the levels asked and only those, with finite values and indices in
// range; the final level's mesh (positions, normals, indices, colours) is byte-identical to
// nfd_mesh_extract's at that resolution; the steps' new points add up to that decode's; a level
// whose resolution divides the final one is that decode's own, to the byte, but for the two
// exceptions nfdecode.h states, checked by count: an SDF following its surface (a level above
// the finest may hold a sliver's cells too: a superset), and the coarsest level of a ladder of
// several levels, sampled through a probe where a decode at its resolution evaluates every
// vertex (a field steeper than the keep rule's margin may hide surface from it: a subset).
// Anything else aborts.
#include <nfdecode/nfdecode.h>

#include <cstdint>
#include <cstring>

#include "fuzz_util.h"

namespace {

struct Mesh {
    nfd_mesh* handle = nullptr;
    nfd_mesh_data data{};
    const float* colours = nullptr;
    nfd_decode_stats stats{};
    ~Mesh() { nfd_mesh_destroy(handle); }
    void read() {
        read_valid_mesh(handle, &data, &colours);
        require(nfd_mesh_get_stats(handle, &stats) == NFD_SUCCESS);
    }
};

bool same_bytes(const void* a, const void* b, size_t n) { return n == 0 || std::memcmp(a, b, n) == 0; }

void require_same(const Mesh& a, const Mesh& b) {
    require(a.data.vertex_count == b.data.vertex_count && a.data.triangle_count == b.data.triangle_count);
    const size_t v = 3 * a.data.vertex_count * sizeof(float);
    require(same_bytes(a.data.positions, b.data.positions, v));
    require(same_bytes(a.data.normals, b.data.normals, v));
    require(same_bytes(a.data.indices, b.data.indices, 3 * a.data.triangle_count * sizeof(uint32_t)));
    require((a.colours != nullptr) == (b.colours != nullptr));
    if (a.colours) require(same_bytes(a.colours, b.colours, v));
    require(a.stats.active_cells == b.stats.active_cells);
}

// nfd_mesh_extract at `resolution`; false when it ran out of memory (the input is then dropped).
bool one_shot(const nfd_asset* asset, uint32_t resolution, bool sample_band, Mesh* out) {
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = resolution;
    mo.sample_band = sample_band;
    const nfd_result r = nfd_mesh_extract(cpu_context(), asset, &mo, &out->handle);
    if (r == NFD_ERROR_OUT_OF_MEMORY) return false;
    require(r == NFD_SUCCESS);
    out->read();
    return true;
}

void extract(const nfd_asset* asset, uint32_t resolution, bool sample_band, bool every_level) {
    uint32_t rungs[NFD_MAX_LADDER_LEVELS], count = 0;
    require(nfd_extraction_ladder(resolution, rungs, NFD_MAX_LADDER_LEVELS, &count) == NFD_SUCCESS);
    require(count >= 1 && rungs[count - 1] == resolution);
    nfd_asset_info info{};
    require(nfd_asset_get_info(asset, &info) == NFD_SUCCESS);
    const bool follows_sdf = info.field_type == NFD_FIELD_SDF && !sample_band;

    nfd_extraction_options eo{};
    eo.struct_size = sizeof eo;
    eo.resolution = resolution;
    // Every level, or the coarsest and the final ones (a level skipped between meshed ones).
    eo.mesh_levels = every_level ? 0 : 1u | 1u << (count - 1);
    eo.sample_band = sample_band;
    nfd_extraction* extraction = nullptr;
    const nfd_result created = nfd_extraction_create(cpu_context(), asset, &eo, &extraction);
    if (created == NFD_ERROR_OUT_OF_MEMORY) return;
    require(created == NFD_SUCCESS);
    uint64_t values = 0;
    for (uint32_t i = 0; i < count; ++i) {
        nfd_extraction_level level{};
        level.struct_size = sizeof level;
        Mesh mesh;
        const nfd_result stepped = nfd_extraction_step(extraction, &mesh.handle, &level);
        if (stepped == NFD_ERROR_OUT_OF_MEMORY) break;
        require(stepped == NFD_SUCCESS);
        require(level.index == i && level.resolution == rungs[i] && (level.done != 0) == (i + 1 == count));
        values += level.points_evaluated;
        const bool meshed = every_level || i == 0 || i + 1 == count;
        require((mesh.handle != nullptr) == meshed);
        if (!meshed) continue;
        mesh.read();
        require(mesh.stats.points_evaluated == values);  // all steps so far, none twice
        if (resolution % rungs[i] != 0) continue;        // a rounded-up level: no decode's own
        Mesh reference;
        if (!one_shot(asset, rungs[i], sample_band, &reference)) break;
        if (i + 1 == count) {
            require_same(mesh, reference);
            require(reference.stats.points_evaluated == values);
        } else if (i == 0) {  // probed, where that decode evaluates every vertex: a subset
            require(mesh.data.triangle_count <= reference.data.triangle_count);
            require(mesh.stats.active_cells <= reference.stats.active_cells);
        } else if (follows_sdf) {  // may hold a sliver's cells too: a superset
            require(mesh.data.triangle_count >= reference.data.triangle_count);
            require(mesh.stats.active_cells >= reference.stats.active_cells);
        } else {
            require_same(mesh, reference);
        }
    }
    nfd_extraction_destroy(extraction);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0 || !cpu_context()) return 0;
    // The last byte picks the extraction and is not part of the file: the final resolution
    // 128..143 when bit 0x20 is set (three levels), else 64..79 when bit 0x10 is (two), else
    // 32..47 (one: the ladder of a resolution under 64), from its low four bits (odd ones round
    // the coarser levels up); the band sampled when bit 0x40 is set; every level meshed unless
    // bit 0x80 is set.
    const uint8_t pick = data[size - 1];
    const uint32_t base = pick & 0x20 ? 128 : (pick & 0x10 ? 64 : 32);
    nfd_asset* asset = nullptr;
    if (nfd_asset_create(data, size - 1, &asset) != NFD_SUCCESS) return 0;
    extract(asset, base + (pick & 15), pick & 0x40, !(pick & 0x80));
    nfd_asset_destroy(asset);
    return 0;
}
