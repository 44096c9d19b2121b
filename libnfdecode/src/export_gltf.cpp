// Binary glTF 2.0 via tinygltf. This file holds tinygltf's implementation (exactly once in the
// library); image support is compiled out since the decoder writes geometry and vertex colours
// only.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>

#include "export.h"

namespace nfd {
namespace {

template <class T, class Allocator>
size_t append(std::vector<unsigned char>& bytes, const std::vector<T, Allocator>& values) {
    const size_t offset = bytes.size();  // all parts are 4-byte types: alignment holds
    bytes.resize(offset + values.size() * sizeof(T));
    if (!values.empty()) std::memcpy(bytes.data() + offset, values.data(), values.size() * sizeof(T));
    return offset;
}

int add_view(tinygltf::Model& m, size_t offset, size_t length, int target) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = offset;
    view.byteLength = length;
    view.target = target;
    m.bufferViews.push_back(view);
    return int(m.bufferViews.size() - 1);
}

int add_accessor(tinygltf::Model& m, int view, int component, int type, size_t count) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.componentType = component;
    a.type = type;
    a.count = count;
    m.accessors.push_back(a);
    return int(m.accessors.size() - 1);
}

}  // namespace

nfd_result write_glb(const MeshData& mesh, const char* path) {
    tinygltf::Model m;
    m.asset.version = "2.0";
    m.asset.generator = "libnfdecode";
    m.scenes.emplace_back();
    m.scenes[0].name = "nfc";  // an unnamed empty scene would serialise as null, which is invalid
    m.defaultScene = 0;

    // glTF has no empty accessors or buffers, so an empty mesh is an asset with an empty scene.
    if (mesh.triangle_count() > 0) {
        tinygltf::Buffer buffer;
        const size_t pos = append(buffer.data, mesh.positions);
        const size_t nrm = append(buffer.data, mesh.normals);
        const size_t rgb = append(buffer.data, mesh.colours);  // empty: no colours
        const size_t idx = append(buffer.data, mesh.indices);
        m.buffers.push_back(std::move(buffer));

        const size_t vertex_bytes = mesh.positions.size() * sizeof(float);
        const int position = add_accessor(
            m, add_view(m, pos, vertex_bytes, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, mesh.vertex_count());
        const int normal = add_accessor(
            m, add_view(m, nrm, vertex_bytes, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, mesh.vertex_count());
        const int indices = add_accessor(
            m,
            add_view(m, idx, mesh.indices.size() * sizeof(uint32_t),
                     TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, mesh.indices.size());

        // POSITION must carry min/max (glTF 2.0, 3.6.2.4).
        std::vector<double>& lo = m.accessors[size_t(position)].minValues;
        std::vector<double>& hi = m.accessors[size_t(position)].maxValues;
        lo.assign(3, std::numeric_limits<double>::infinity());
        hi.assign(3, -std::numeric_limits<double>::infinity());
        for (size_t i = 0; i < mesh.vertex_count(); ++i)
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], double(mesh.positions[3 * i + a]));
                hi[a] = std::max(hi[a], double(mesh.positions[3 * i + a]));
            }

        tinygltf::Primitive primitive;
        primitive.attributes["POSITION"] = position;
        primitive.attributes["NORMAL"] = normal;
        if (!mesh.colours.empty())  // float RGB in [0, 1], as glTF's COLOR_0 allows
            primitive.attributes["COLOR_0"] = add_accessor(
                m, add_view(m, rgb, vertex_bytes, TINYGLTF_TARGET_ARRAY_BUFFER),
                TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, mesh.vertex_count());
        primitive.indices = indices;
        primitive.mode = TINYGLTF_MODE_TRIANGLES;
        tinygltf::Mesh gltf_mesh;
        gltf_mesh.name = "nfc";
        gltf_mesh.primitives.push_back(primitive);
        m.meshes.push_back(gltf_mesh);
        tinygltf::Node node;
        node.mesh = 0;
        // A geo-referenced frame: positions stay f32 and local, the far translation is the node's,
        // which glTF stores as a JSON number (written with round-trip precision).
        if (mesh.offset != std::array<double, 3>{})
            node.translation.assign(mesh.offset.begin(), mesh.offset.end());
        m.nodes.push_back(node);
        m.scenes[0].nodes.push_back(0);
    }

    // tinygltf's file writer ignores I/O errors; its stream writer lets us check them.
    std::ofstream file(path, std::ios::binary);
    if (!file) return NFD_ERROR_IO;
    tinygltf::TinyGLTF writer;
    const bool ok = writer.WriteGltfSceneToStream(&m, file, /*prettyPrint=*/false,
                                                  /*writeBinary=*/true);
    file.close();
    return ok && file ? NFD_SUCCESS : NFD_ERROR_IO;
}

}  // namespace nfd
