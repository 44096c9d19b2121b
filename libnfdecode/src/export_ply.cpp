// Binary little-endian PLY. Values are serialised byte by byte, so the files are the same on
// big-endian hosts.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "export.h"

namespace nfd {
namespace {

class LittleEndianFile {
public:
    explicit LittleEndianFile(const char* path)
        : f_(std::fopen(path, "wb")), buffer_(f_ ? kBufferBytes : 0) {}
    ~LittleEndianFile() {
        if (f_) std::fclose(f_);
    }
    bool is_open() const { return f_ != nullptr; }

    void text(const std::string& s) { put(s.data(), s.size()); }
    void u8(uint8_t v) { put(&v, 1); }
    void u32(uint32_t v) {
        const uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
        put(b, 4);
    }
    void f32(float v) {
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        u32(bits);
    }
    void f64(double v) {
        uint64_t bits;
        std::memcpy(&bits, &v, 8);
        u32(uint32_t(bits));
        u32(uint32_t(bits >> 32));
    }
    // Writes what is buffered and closes; false if anything failed on the way.
    bool close() {
        flush();
        const bool ok = ok_ && std::fclose(f_) == 0;
        f_ = nullptr;
        return ok;
    }

private:
    // A fixed buffer filled by memcpy: a vector grown a byte at a time made the writer a tenth of
    // a decode at 256 (14 ms for the bunny's 6 MB).
    static constexpr size_t kBufferBytes = size_t(1) << 20;
    void put(const void* bytes, size_t n) {
        if (used_ + n > kBufferBytes) flush();
        if (n > kBufferBytes) {  // a header longer than the buffer: straight to the file
            ok_ = ok_ && std::fwrite(bytes, 1, n, f_) == n;
            return;
        }
        std::memcpy(buffer_.data() + used_, bytes, n);
        used_ += n;
    }
    void flush() {
        if (used_ > 0 && std::fwrite(buffer_.data(), 1, used_, f_) != used_) ok_ = false;
        used_ = 0;
    }
    std::FILE* f_;
    nfd::vector<uint8_t> buffer_;
    size_t used_ = 0;
    bool ok_ = true;
};

// Positions are f32 unless an offset places them (a geo-referenced frame): then f64 holds
// offset + position exactly where f32 would snap it to a coarse grid.
bool has_offset(const std::array<double, 3>& offset) {
    return offset[0] != 0.0 || offset[1] != 0.0 || offset[2] != 0.0;
}

std::string vertex_header(size_t count, bool doubles, bool normals, bool colours) {
    std::string h = "ply\nformat binary_little_endian 1.0\ncomment written by libnfdecode\n";
    h += "element vertex " + std::to_string(count) + "\n";
    h += doubles ? "property double x\nproperty double y\nproperty double z\n"
                 : "property float x\nproperty float y\nproperty float z\n";
    if (normals) h += "property float nx\nproperty float ny\nproperty float nz\n";
    if (colours) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    return h;
}

// One vertex record: position (offset by `offset` in f64 when it has one), then normal and colour
// where given.
void write_vertex(LittleEndianFile& out, size_t i, const float* positions,
                  const std::array<double, 3>* offset, const float* normals, const float* colours) {
    for (int a = 0; a < 3; ++a) {
        if (offset)
            out.f64((*offset)[a] + double(positions[3 * i + a]));
        else
            out.f32(positions[3 * i + a]);
    }
    if (normals)
        for (int a = 0; a < 3; ++a) out.f32(normals[3 * i + a]);
    if (colours)
        for (int a = 0; a < 3; ++a) out.u8(colour_byte(colours[3 * i + a]));
}

}  // namespace

uint8_t colour_byte(float c) {
    const float scaled = std::floor(255.0f * c + 0.5f);
    return uint8_t(std::min(255.0f, std::max(0.0f, scaled)));  // NaN reads as 0 (max(0, NaN))
}

nfd_result write_mesh_ply(const MeshData& mesh, const char* path) {
    LittleEndianFile out(path);
    if (!out.is_open()) return NFD_ERROR_IO;
    const float* colours = mesh.colours.empty() ? nullptr : mesh.colours.data();
    const std::array<double, 3>* offset = has_offset(mesh.offset) ? &mesh.offset : nullptr;
    out.text(vertex_header(mesh.vertex_count(), offset != nullptr, true, colours != nullptr));
    out.text("element face " + std::to_string(mesh.triangle_count()) + "\n");
    out.text("property list uchar uint vertex_indices\nend_header\n");
    for (size_t i = 0; i < mesh.vertex_count(); ++i)
        write_vertex(out, i, mesh.positions.data(), offset, mesh.normals.data(), colours);
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        out.u8(3);
        for (int k = 0; k < 3; ++k) out.u32(mesh.indices[3 * t + k]);
    }
    return out.close() ? NFD_SUCCESS : NFD_ERROR_IO;
}

nfd_result write_points_ply(const float* points, const float* normals, const float* colours,
                            size_t count, const std::array<double, 3>& offset, const char* path) {
    LittleEndianFile out(path);
    if (!out.is_open()) return NFD_ERROR_IO;
    const std::array<double, 3>* placed = has_offset(offset) ? &offset : nullptr;
    out.text(vertex_header(count, placed != nullptr, normals != nullptr, colours != nullptr) +
             "end_header\n");
    for (size_t i = 0; i < count; ++i) write_vertex(out, i, points, placed, normals, colours);
    return out.close() ? NFD_SUCCESS : NFD_ERROR_IO;
}

}  // namespace nfd
