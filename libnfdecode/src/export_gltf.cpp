// Binary glTF 2.0 (glTF 2.0 specification, 4.4 "GLB File Format"), written straight from the
// mesh's arrays: a 12-byte header, the JSON chunk, then the BIN chunk as the positions, normals,
// colours and indices one after another. Through tinygltf, which copies the binary data twice
// before writing it, the writer was a sixth of a decode at 256 and held three copies of the mesh;
// tinygltf still reads every file back in the tests (Api.GlbLoadsInTinyGltf), and the Khronos
// validator checks them (CTest gltf_validator).
#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "export.h"

namespace nfd {
namespace {

using nlohmann::json;

constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr uint32_t kBinChunk = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126, kUnsignedInt = 5125;           // accessor componentType
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;  // bufferView target

// Writes n 4-byte words (floats or uint32) little-endian, as glTF stores them: as they are on a
// little-endian host, a chunk at a time byte-swapped on others.
bool write_words(std::FILE* f, const void* words, size_t n) {
    if (n == 0) return true;  // an empty array's data() may be null, which fwrite must not get
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    const uint8_t* in = static_cast<const uint8_t*>(words);
    uint8_t chunk[4096];
    for (size_t done = 0; done < n;) {
        const size_t count = std::min(n - done, sizeof chunk / 4);
        for (size_t k = 0; k < 4 * count; ++k) chunk[k] = in[4 * done + (k & ~size_t(3)) + 3 - (k & 3)];
        if (std::fwrite(chunk, 4, count, f) != count) return false;
        done += count;
    }
    return true;
#else
    return std::fwrite(words, 4, n, f) == n;
#endif
}

bool write_u32(std::FILE* f, uint32_t v) { return write_words(f, &v, 1); }

// The JSON of a mesh whose binary chunk holds its arrays back to back from byte 0.
json gltf_json(const MeshData& mesh, uint64_t* bin_bytes) {
    json j = {{"asset", {{"version", "2.0"}, {"generator", "libnfdecode"}}},
              {"scene", 0},
              // An unnamed empty scene would serialise as null, which is invalid.
              {"scenes", json::array({{{"name", "nfc"}}})}};
    *bin_bytes = 0;
    // glTF has no empty accessors or buffers, so an empty mesh is an asset with an empty scene.
    if (mesh.triangle_count() == 0) return j;

    json views = json::array(), accessors = json::array(), attributes;
    // A bufferView of `bytes` after the previous ones, and an accessor of `count` elements on it.
    auto add = [&](uint64_t bytes, int target, int component, const char* type, size_t count) {
        views.push_back({{"buffer", 0}, {"byteOffset", *bin_bytes}, {"byteLength", bytes},
                         {"target", target}});
        *bin_bytes += bytes;
        accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", component},
                             {"count", count}, {"type", type}});
        return accessors.size() - 1;
    };
    // POSITION must carry min/max (glTF 2.0, 3.6.2.4); f32 values are exact as JSON doubles.
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::numeric_limits<double>::infinity();
        hi[a] = -std::numeric_limits<double>::infinity();
    }
    for (size_t i = 0; i < mesh.vertex_count(); ++i)
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], double(mesh.positions[3 * i + a]));
            hi[a] = std::max(hi[a], double(mesh.positions[3 * i + a]));
        }
    const uint64_t vertex_bytes = uint64_t(mesh.positions.size()) * 4;
    attributes["POSITION"] = add(vertex_bytes, kArrayBuffer, kFloat, "VEC3", mesh.vertex_count());
    accessors.back()["min"] = {lo[0], lo[1], lo[2]};
    accessors.back()["max"] = {hi[0], hi[1], hi[2]};
    attributes["NORMAL"] = add(vertex_bytes, kArrayBuffer, kFloat, "VEC3", mesh.vertex_count());
    if (!mesh.colours.empty())  // float RGB in [0, 1], as glTF's COLOR_0 allows
        attributes["COLOR_0"] = add(vertex_bytes, kArrayBuffer, kFloat, "VEC3", mesh.vertex_count());
    const size_t indices = add(uint64_t(mesh.indices.size()) * 4, kElementArrayBuffer,
                               kUnsignedInt, "SCALAR", mesh.indices.size());

    json node = {{"mesh", 0}};
    // A geo-referenced frame: positions stay f32 and local, the far translation is the node's,
    // a JSON number written with round-trip precision.
    if (mesh.offset != std::array<double, 3>{})
        node["translation"] = {mesh.offset[0], mesh.offset[1], mesh.offset[2]};
    j["nodes"] = json::array({node});
    j["scenes"][0]["nodes"] = {0};
    j["meshes"] = json::array({{{"name", "nfc"},
                                {"primitives", json::array({{{"attributes", attributes},
                                                             {"indices", indices},
                                                             {"mode", 4}}})}}});  // triangles
    j["accessors"] = std::move(accessors);
    j["bufferViews"] = std::move(views);
    j["buffers"] = json::array({{{"byteLength", *bin_bytes}}});
    return j;
}

}  // namespace

nfd_result write_glb(const MeshData& mesh, const char* path) {
    uint64_t bin_bytes = 0;
    std::string text = gltf_json(mesh, &bin_bytes).dump();
    text.append((4 - text.size() % 4) % 4, ' ');  // chunks are 4-byte aligned; JSON pads with spaces
    // Every part of the binary chunk is whole 4-byte words: no padding.
    const uint64_t total = 12 + 8 + text.size() + (bin_bytes ? 8 + bin_bytes : 0);
    if (total > std::numeric_limits<uint32_t>::max()) return NFD_ERROR_LIMIT_EXCEEDED;

    std::FILE* f = std::fopen(path, "wb");
    if (!f) return NFD_ERROR_IO;
    bool ok = write_u32(f, kGlbMagic) && write_u32(f, 2) && write_u32(f, uint32_t(total)) &&
              write_u32(f, uint32_t(text.size())) && write_u32(f, kJsonChunk) &&
              std::fwrite(text.data(), 1, text.size(), f) == text.size();
    if (ok && bin_bytes) {
        ok = write_u32(f, uint32_t(bin_bytes)) && write_u32(f, kBinChunk) &&
             write_words(f, mesh.positions.data(), mesh.positions.size()) &&
             write_words(f, mesh.normals.data(), mesh.normals.size()) &&
             write_words(f, mesh.colours.data(), mesh.colours.size()) &&
             write_words(f, mesh.indices.data(), mesh.indices.size());
    }
    ok = std::fclose(f) == 0 && ok;
    return ok ? NFD_SUCCESS : NFD_ERROR_IO;
}

}  // namespace nfd
