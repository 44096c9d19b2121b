// Test helpers: an independent .nfc writer (so tests can build any valid or hostile file), a few
// synthetic networks, an f64 reference evaluator, a PLY reader, mesh checks and golden-vector paths.
#pragma once
#include <brotli/encode.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "bitstream.h"
#include "mesh.h"
#include "network.h"
#include "stream.h"

namespace nfd::test {

// A library vector (nfd::vector, the host's allocator) as a std::vector, to compare with one.
template <class T, class Allocator>
std::vector<T> std_vector(const std::vector<T, Allocator>& v) {
    return std::vector<T>(v.begin(), v.end());
}

using Bytes = std::vector<uint8_t>;

// ---- writer -------------------------------------------------------------------------------------

inline void put_u8(Bytes& b, uint32_t v) { b.push_back(uint8_t(v)); }
inline void put_u16(Bytes& b, uint32_t v) {
    for (int k = 0; k < 2; ++k) b.push_back(uint8_t(v >> (8 * k)));
}
inline void put_u32(Bytes& b, uint32_t v) {
    for (int k = 0; k < 4; ++k) b.push_back(uint8_t(v >> (8 * k)));
}
inline void put_f32(Bytes& b, float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    put_u32(b, bits);
}
inline void put_f64(Bytes& b, double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    put_u32(b, uint32_t(bits));
    put_u32(b, uint32_t(bits >> 32));
}
inline void set_u32(Bytes& b, size_t at, uint32_t v) {
    if (at + 4 > b.size()) throw std::out_of_range("set_u32");
    uint8_t* p = b.data() + at;
    for (int k = 0; k < 4; ++k) p[k] = uint8_t(v >> (8 * k));
}

inline Bytes brotli(const Bytes& raw) {
    Bytes out(BrotliEncoderMaxCompressedSize(raw.size()) + 16);
    size_t size = out.size();
    if (!BrotliEncoderCompress(BROTLI_DEFAULT_QUALITY, BROTLI_DEFAULT_WINDOW, BROTLI_MODE_GENERIC,
                               raw.size(), raw.data(), &size, out.data()))
        throw std::runtime_error("brotli encode failed");
    out.resize(size);
    return out;
}

// Everything a GEOM chunk says, in FORMAT.md order. `levels` holds the P integer levels.
struct GeomSpec {
    uint8_t field_type = 0;
    float truncation = 0.1f;
    float center[3] = {0, 0, 0};
    float scale = 1.0f;
    uint8_t num_frequencies = 16;
    float beta = 1.4f;
    float omega0 = 30.0f;
    uint8_t output = 0;
    uint8_t bits = 8;
    std::vector<uint16_t> widths;
    std::vector<float> steps;     // 2 per layer: weight step, bias step
    std::vector<int32_t> levels;  // all layers: W row-major, then b

    uint32_t input_width() const { return 3u + 6u * num_frequencies; }
    size_t parameter_count() const {
        size_t p = 0, in = input_width();
        for (uint16_t w : widths) p += in * w + w, in = w;
        return p;
    }
    Bytes raw_levels() const {
        Bytes raw;
        for (int32_t q : levels) bits <= 8 ? put_u8(raw, uint32_t(q)) : put_u16(raw, uint32_t(q));
        return raw;
    }
};

// The network block (FORMAT.md) of a spec, appended to b; `payload` replaces the brotli stream
// when given (for hostile streams).
inline void put_network_block(Bytes& b, const GeomSpec& s, const Bytes* payload) {
    put_u8(b, s.num_frequencies);
    put_f32(b, s.beta);
    put_f32(b, s.omega0);
    put_u8(b, s.output);
    put_u8(b, s.bits);
    put_u8(b, uint32_t(s.widths.size()));
    for (uint16_t w : s.widths) put_u16(b, w);
    for (float st : s.steps) put_f32(b, st);
    const Bytes stream = payload ? *payload : brotli(s.raw_levels());
    b.insert(b.end(), stream.begin(), stream.end());
}

// The GEOM payload; `payload` replaces the brotli stream when given (for hostile streams).
inline Bytes geom_payload(const GeomSpec& s, const Bytes* payload = nullptr) {
    Bytes b;
    put_u8(b, s.field_type);
    put_f32(b, s.truncation);
    for (float c : s.center) put_f32(b, c);
    put_f32(b, s.scale);
    put_network_block(b, s, payload);
    return b;
}

// The `colr` payload (FORMAT.md 1.1): colour space, then the network block of `s` (whose frame
// fields are not written: colour uses GEOM's).
inline Bytes colour_payload(const GeomSpec& s, uint8_t colour_space = 0) {
    Bytes b;
    put_u8(b, colour_space);
    put_network_block(b, s, nullptr);
    return b;
}

inline Bytes chunk(const char* tag, const Bytes& payload) {
    Bytes c(tag, tag + 4);
    put_u32(c, uint32_t(payload.size()));
    c.insert(c.end(), payload.begin(), payload.end());
    put_u32(c, crc32(c.data(), c.size()));
    return c;
}

struct HeaderSpec {
    uint8_t major = 1, minor = 0;
    uint16_t flags = 0;
};

inline Bytes file(const std::vector<Bytes>& chunks, HeaderSpec h = {}) {
    Bytes f = {0x89, 'N', 'F', 'C', h.major, h.minor};
    put_u16(f, h.flags);
    put_u32(f, 0);  // file_size, below
    put_u32(f, 0);  // header_crc, below
    for (const Bytes& c : chunks) f.insert(f.end(), c.begin(), c.end());
    set_u32(f, 8, uint32_t(f.size()));
    set_u32(f, 12, crc32(f.data(), 12));
    return f;
}

inline Bytes geom_file(const GeomSpec& s, HeaderSpec h = {}) {
    return file({chunk("GEOM", geom_payload(s))}, h);
}

// A geometry with a colour chunk: the format 1.1 file an encoder writes.
inline Bytes coloured_file(const GeomSpec& geometry, const GeomSpec& colour) {
    return file({chunk("GEOM", geom_payload(geometry)), chunk("colr", colour_payload(colour))},
                {1, 1, 0});
}

// The `fram` payload (FORMAT.md 1.2): the frame in f64.
inline Bytes frame64_payload(const double center[3], double scale) {
    Bytes b;
    for (int a = 0; a < 3; ++a) put_f64(b, center[a]);
    put_f64(b, scale);
    return b;
}

// A geometry placed by a 64-bit frame, as the encoder writes one for a shape far from its origin:
// GEOM holds the frame rounded to f32, `fram` the exact values (format 1.2).
inline Bytes geo_file(GeomSpec s, const double center[3], double scale) {
    for (int a = 0; a < 3; ++a) s.center[a] = float(center[a]);
    s.scale = float(scale);
    return file({chunk("GEOM", geom_payload(s)), chunk("fram", frame64_payload(center, scale))},
                {1, 2, 0});
}

inline Bytes geom_file_with_payload(const GeomSpec& s, const Bytes& brotli_stream) {
    return file({chunk("GEOM", geom_payload(s, &brotli_stream))});
}

// ---- synthetic networks ----------------------------------------------------------------------------

// A SIREN as the encoder initialises it (first layer U(-1/in, 1/in), later U(+-sqrt(6/in)/w0)),
// quantized to `bits`: realistic magnitudes for the evaluator and the parser. `outputs` 3 with
// sigmoid output: a colour network (random_colour_siren).
inline GeomSpec random_siren(uint32_t width, uint8_t bits, uint32_t seed, uint8_t field_type = 0,
                             uint16_t outputs = 1, uint8_t frequencies = 16) {
    GeomSpec s;
    s.field_type = field_type;
    s.output = field_type;  // SDF: identity, UDF: abs
    s.num_frequencies = frequencies;
    s.bits = bits;
    s.widths = {uint16_t(width), uint16_t(width), outputs};
    s.center[0] = 0.25f, s.center[1] = -1.5f, s.center[2] = 3.0f;
    s.scale = 2.5f;
    std::mt19937 rng(seed);
    const int32_t max_level = (1 << (bits - 1)) - 1;
    std::uniform_int_distribution<int32_t> level(-max_level, max_level);
    uint32_t in = s.input_width();
    for (size_t l = 0; l < s.widths.size(); ++l) {
        const float bound = l == 0 ? 1.0f / float(in) : std::sqrt(6.0f / float(in)) / s.omega0;
        s.steps.push_back(bound / float(max_level));
        s.steps.push_back(0.05f / float(max_level));
        for (uint32_t k = 0; k < in * s.widths[l] + s.widths[l]; ++k) s.levels.push_back(level(rng));
        in = s.widths[l];
    }
    return s;
}

// A colour network as the encoder writes it: 8 frequencies, 3 sigmoid outputs.
inline GeomSpec random_colour_siren(uint32_t width, uint8_t bits, uint32_t seed) {
    GeomSpec s = random_siren(width, bits, seed, 0, 3, 8);
    s.output = 2;
    return s;
}

// A closed SDF-like field with a known zero set: f = s * sin(w0 * (a * sum_j cos(2 u_j) + c)),
// built from exact SIREN layers (sin(x + pi/2) = cos x). Inside (f < 0) is the rounded-cube blob
// sum_j cos(2 u_j) > T with T = cos(1.2) + 2 (it crosses the axes at |u| = 0.6); the gradient
// norm stays below 1.8. Positional-encoding inputs
// are present (L = 2) but weighted zero, so the full input path is exercised.
inline GeomSpec closed_blob(float scale = 1.0f, const float* center = nullptr) {
    GeomSpec s;
    s.num_frequencies = 2;
    s.bits = 16;
    s.omega0 = 30.0f;
    s.scale = scale;
    if (center) std::copy(center, center + 3, s.center);
    s.widths = {3, 1, 1};
    const int32_t M = 32767;
    const double w0 = s.omega0, a = -0.01, T = std::cos(1.2) + 2.0, slope = 1.0 / 0.6;
    const uint32_t in = s.input_width();
    // Layer 0: h_j = sin(w0 * ((2 / w0) u_j + pi / (2 w0))) = cos(2 u_j).
    s.steps.push_back(float((2.0 / w0) / M));
    s.steps.push_back(float((M_PI / (2.0 * w0)) / M));
    for (uint32_t o = 0; o < 3; ++o)
        for (uint32_t i = 0; i < in; ++i) s.levels.push_back(i == o ? M : 0);
    for (int o = 0; o < 3; ++o) s.levels.push_back(M);
    // Layer 1: g = sin(w0 * (a * sum_j h_j - a * T)), negative where sum > T.
    s.steps.push_back(float(std::fabs(a) / M));
    s.steps.push_back(float(std::fabs(a * T) / M));
    for (int i = 0; i < 3; ++i) s.levels.push_back(-M);
    s.levels.push_back(M);
    // Layer 2: f = slope * g (sin's slope at 0 is w0 * |a| = 0.3; slope 1/0.6 halves the gradient
    // of sum_j cos(2 u_j) so it stays Lipschitz-2 everywhere).
    s.steps.push_back(float(slope / M));
    s.steps.push_back(1.0f);
    s.levels.push_back(M);
    s.levels.push_back(0);
    return s;
}

// closed_blob centred at (o, o, o) of the unit frame instead of the origin: h_j = cos(2 (u_j - o)).
// At o = 1.2 it fills a corner of [-1, 1]^3 and lies 1.5 and more from the origin: beyond the
// shape's ball (network.h, ShapeBall; 1.2 at the truncation 0.1), where no shape an encoder writes
// has a surface.
inline GeomSpec offset_blob(float o) {
    GeomSpec s = closed_blob();
    const double bias = (M_PI / 2.0 - 2.0 * o) / s.omega0;
    s.steps[1] = float(std::fabs(bias) / 32767);
    const uint32_t in = s.input_width();
    for (uint32_t j = 0; j < 3; ++j) s.levels[3 * in + j] = bias < 0 ? -32767 : 32767;
    return s;
}

inline Geometry parse_or_throw(const Bytes& bytes) {
    ParsedFile f;
    if (parse_file(bytes.data(), bytes.size(), &f) != NFD_SUCCESS)
        throw std::runtime_error("synthetic file does not parse");
    return f.geometry;
}

// ---- f64 reference evaluator (the numpy reference's arithmetic: f32 encoding products, f64 rest)

// Every output of the network at u, activated.
inline std::vector<double> evaluate_f64_outputs(const Network& net, const float* u) {
    std::vector<double> h(u, u + 3);
    for (float f : net.frequencies) {
        double s[3], c[3];
        for (int j = 0; j < 3; ++j) {
            const float arg = f * u[j];
            s[j] = std::sin(double(arg));
            c[j] = std::cos(double(arg));
        }
        h.insert(h.end(), s, s + 3);
        h.insert(h.end(), c, c + 3);
    }
    for (size_t l = 0; l < net.layers.size(); ++l) {
        const Layer& layer = net.layers[l];
        std::vector<double> next(layer.out);
        for (uint32_t o = 0; o < layer.out; ++o) {
            double z = layer.bias[o];
            for (uint32_t i = 0; i < layer.in; ++i) z += double(layer.weights[o * layer.in + i]) * h[i];
            next[o] = l + 1 < net.layers.size() ? std::sin(double(net.omega0) * z) : z;
        }
        h.swap(next);
    }
    for (double& y : h) {
        if (net.output == OutputActivation::Abs) y = std::fabs(y);
        if (net.output == OutputActivation::Sigmoid) y = 1.0 / (1.0 + std::exp(-y));
    }
    return h;
}

inline double evaluate_f64(const Network& net, const float* u) { return evaluate_f64_outputs(net, u)[0]; }

// ---- meshes ----------------------------------------------------------------------------------------

// Reads PLY (ascii or binary_little_endian) vertices x y z (float or double), normals, colours
// (red green blue: uchar read as v / 255, floats as they are) and triangle faces; the positions
// unrounded in `positions64` when given (double coordinates of geo-referenced output).
inline MeshData read_ply(const std::string& path, std::vector<double>* positions64 = nullptr) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot open " + path);
    std::string line, format;
    struct Element {
        std::string name;
        size_t count;
        std::vector<std::pair<std::string, std::string>> props;  // type, name ("list:..." lists)
    };
    std::vector<Element> elements;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream ls(line);
        std::string word;
        ls >> word;
        if (word == "format") ls >> format;
        else if (word == "element") {
            Element e;
            ls >> e.name >> e.count;
            elements.push_back(e);
        } else if (word == "property") {
            std::string type, name;
            ls >> type;
            if (type == "list") {
                std::string count_type, item_type;
                ls >> count_type >> item_type >> name;
                type = "list:" + count_type + ":" + item_type;
            } else {
                ls >> name;
            }
            elements.back().props.emplace_back(type, name);
        } else if (word == "end_header") break;
    }
    const bool ascii = format == "ascii";
    if (!ascii && format != "binary_little_endian") throw std::runtime_error("PLY format " + format);
    auto size_of = [](const std::string& t) -> size_t {
        if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
        if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
        if (t == "double" || t == "float64") return 8;
        return 4;
    };
    auto read_value = [&](const std::string& t) -> double {
        if (ascii) {
            double v;
            in >> v;
            return v;
        }
        unsigned char b[8] = {};
        in.read(reinterpret_cast<char*>(b), std::streamsize(size_of(t)));
        if (t == "float" || t == "float32") { float f; std::memcpy(&f, b, 4); return f; }
        if (t == "double" || t == "float64") { double d; std::memcpy(&d, b, 8); return d; }
        if (t == "char" || t == "int8") return int8_t(b[0]);
        if (t == "uchar" || t == "uint8") return b[0];
        if (t == "short" || t == "int16") { int16_t v; std::memcpy(&v, b, 2); return v; }
        if (t == "ushort" || t == "uint16") { uint16_t v; std::memcpy(&v, b, 2); return v; }
        if (t == "int" || t == "int32") { int32_t v; std::memcpy(&v, b, 4); return v; }
        uint32_t v; std::memcpy(&v, b, 4); return v;
    };
    MeshData m;
    for (const Element& e : elements) {
        for (size_t k = 0; k < e.count; ++k) {
            for (const auto& [type, name] : e.props) {
                if (type.rfind("list:", 0) == 0) {
                    const size_t colon = type.find(':', 5);
                    const std::string count_type = type.substr(5, colon - 5), item = type.substr(colon + 1);
                    const size_t n = size_t(read_value(count_type));
                    std::vector<uint32_t> ids(n);
                    for (auto& id : ids) id = uint32_t(read_value(item));
                    if (e.name == "face")
                        for (size_t t = 1; t + 1 < n; ++t)  // fan: polygons become triangles
                            m.indices.insert(m.indices.end(), {ids[0], ids[t], ids[t + 1]});
                    continue;
                }
                const double v = read_value(type);
                if (e.name == "vertex" && (name == "x" || name == "y" || name == "z")) {
                    m.positions.push_back(float(v));
                    if (positions64) positions64->push_back(v);
                }
                if (e.name == "vertex" && (name == "nx" || name == "ny" || name == "nz"))
                    m.normals.push_back(float(v));
                if (e.name == "vertex" && (name == "red" || name == "green" || name == "blue"))
                    m.colours.push_back(type == "uchar" || type == "uint8" ? float(v) / 255.0f
                                                                           : float(v));
            }
        }
    }
    if (!in) throw std::runtime_error("short PLY " + path);
    return m;
}

// Maps every vertex of `a` to the nearest vertex of `b` (grid hash, cells of `cell`), or -1 when
// none lies within `tolerance`.
inline std::vector<int64_t> match_vertices(const MeshData& a, const MeshData& b, float cell,
                                           float tolerance) {
    auto key = [cell](const float* p, int dx, int dy, int dz) {
        const int64_t x = int64_t(std::floor(p[0] / cell)) + dx, y = int64_t(std::floor(p[1] / cell)) + dy,
                      z = int64_t(std::floor(p[2] / cell)) + dz;
        return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791);
    };
    std::unordered_multimap<int64_t, size_t> grid;
    for (size_t i = 0; i < b.vertex_count(); ++i) grid.emplace(key(&b.positions[3 * i], 0, 0, 0), i);
    std::vector<int64_t> match(a.vertex_count(), -1);
    for (size_t i = 0; i < a.vertex_count(); ++i) {
        const float* p = &a.positions[3 * i];
        float best = tolerance;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    auto range = grid.equal_range(key(p, dx, dy, dz));
                    for (auto it = range.first; it != range.second; ++it) {
                        const float* q = &b.positions[3 * it->second];
                        const float d = std::sqrt((p[0] - q[0]) * (p[0] - q[0]) +
                                                  (p[1] - q[1]) * (p[1] - q[1]) +
                                                  (p[2] - q[2]) * (p[2] - q[2]));
                        if (d <= best) best = d, match[i] = int64_t(it->second);
                    }
                }
    }
    return match;
}

// Triangles as sorted index triples after mapping a's vertices onto b's: equal multisets mean the
// same triangles; the rotation that puts the smallest index first also keeps the winding.
inline std::multiset<std::array<int64_t, 3>> triangles(const MeshData& m,
                                                      const std::vector<int64_t>* map) {
    std::multiset<std::array<int64_t, 3>> out;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
        std::array<int64_t, 3> v;
        for (int k = 0; k < 3; ++k) {
            const uint32_t i = m.indices[3 * t + k];
            v[k] = map ? (*map)[i] : int64_t(i);
        }
        std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
        out.insert(v);
    }
    return out;
}

// Every undirected edge used by exactly two triangles, once in each direction: closed, manifold
// along edges, and consistently oriented.
inline bool is_watertight_and_consistent(const MeshData& m, std::string* why) {
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    for (size_t t = 0; t < m.triangle_count(); ++t)
        for (int k = 0; k < 3; ++k) {
            const uint32_t a = m.indices[3 * t + k], b = m.indices[3 * t + (k + 1) % 3];
            if (a == b) { *why = "degenerate triangle " + std::to_string(t); return false; }
            if (++directed[{a, b}] > 1) { *why = "directed edge used twice"; return false; }
        }
    for (const auto& [edge, count] : directed)
        if (!directed.count({edge.second, edge.first})) {
            *why = "boundary or flipped edge " + std::to_string(edge.first) + "-" +
                   std::to_string(edge.second);
            return false;
        }
    return true;
}

inline double signed_volume(const MeshData& m) {
    double v = 0;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
        const float* p[3];
        for (int k = 0; k < 3; ++k) p[k] = &m.positions[3 * size_t(m.indices[3 * t + k])];
        v += (double(p[0][0]) * (double(p[1][1]) * p[2][2] - double(p[1][2]) * p[2][1]) -
              double(p[0][1]) * (double(p[1][0]) * p[2][2] - double(p[1][2]) * p[2][0]) +
              double(p[0][2]) * (double(p[1][0]) * p[2][1] - double(p[1][1]) * p[2][0])) / 6.0;
    }
    return v;
}

// Symmetric Chamfer distance (metrics.md: sum of the two one-sided mean Euclidean distances)
// between point sets, with a uniform grid for the nearest-neighbour queries.
template <class A, class B>  // float vectors of any allocator
double chamfer(const A& a, const B& b) {
    auto one_sided = [](const auto& from, const auto& to) {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = 0; i < to.size(); ++i) {
            lo[i % 3] = std::min(lo[i % 3], to[i]);
            hi[i % 3] = std::max(hi[i % 3], to[i]);
        }
        const int n = 32;
        float cell = 0;
        for (int a = 0; a < 3; ++a) cell = std::max(cell, (hi[a] - lo[a]) / n);
        cell = std::max(cell, 1e-6f);
        auto key = [&](const float* p, int* c) {
            for (int a = 0; a < 3; ++a) c[a] = std::clamp(int((p[a] - lo[a]) / cell), 0, n);
        };
        std::vector<std::vector<size_t>> grid(size_t(n + 1) * (n + 1) * (n + 1));
        for (size_t i = 0; i < to.size() / 3; ++i) {
            int c[3];
            key(&to[3 * i], c);
            grid[size_t((c[2] * (n + 1) + c[1]) * (n + 1) + c[0])].push_back(i);
        }
        double sum = 0;
        for (size_t i = 0; i < from.size() / 3; ++i) {
            const float* p = &from[3 * i];
            int c[3];
            key(p, c);
            double best = INFINITY;
            for (int r = 0; r <= n; ++r) {  // grow the shell until it cannot hold anything closer
                for (int z = c[2] - r; z <= c[2] + r; ++z)
                    for (int y = c[1] - r; y <= c[1] + r; ++y)
                        for (int x = c[0] - r; x <= c[0] + r; ++x) {
                            if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r)
                                continue;
                            if (std::min({x, y, z}) < 0 || std::max({x, y, z}) > n) continue;
                            for (size_t j : grid[size_t((z * (n + 1) + y) * (n + 1) + x)]) {
                                double d = 0;
                                for (int a = 0; a < 3; ++a) d += std::pow(double(p[a]) - to[3 * j + a], 2);
                                best = std::min(best, d);
                            }
                        }
                if (std::sqrt(best) <= double(r) * cell) break;
            }
            sum += std::sqrt(best);
        }
        return sum / double(from.size() / 3);
    };
    return one_sided(a, b) + one_sided(b, a);
}

// ---- golden vectors (tests/vectors, produced by the Python encoder) ------------------------------

// tests/vectors, or $NFD_TEST_VECTORS_DIR to run the same checks on another vector set.
// Every CRC-consistent variant of a GEOM payload with byte i ^ pattern (i = 0, stride,
// 2 stride, ...) that the parser accepts: fn(i, file bytes, geometry). Hostile values (steps,
// frame, levels) that no CRC catches, for the decoding stages behind the parser.
template <class Fn>
void for_each_accepted_damaged_file(const Bytes& payload, size_t stride,
                                    std::initializer_list<uint8_t> patterns, Fn&& fn) {
    for (size_t i = 0; i < payload.size(); i += stride) {
        for (uint8_t p : patterns) {
            Bytes damaged = payload;
            damaged[i] ^= p;
            const Bytes bytes = file({chunk("GEOM", damaged)});
            ParsedFile parsed;
            if (parse_file(bytes.data(), bytes.size(), &parsed) == NFD_SUCCESS)
                fn(i, bytes, parsed.geometry);
        }
    }
}
// The same, the geometry only: fn(i, geometry).
template <class Fn>
void for_each_accepted_damage(const Bytes& payload, size_t stride,
                              std::initializer_list<uint8_t> patterns, Fn&& fn) {
    for_each_accepted_damaged_file(payload, stride, patterns,
                                   [&](size_t i, const Bytes&, const Geometry& g) { fn(i, g); });
}

// Finite positions and normals, indices in range.
inline ::testing::AssertionResult is_finite_mesh(const MeshData& m) {
    for (float v : m.positions)
        if (!std::isfinite(v)) return ::testing::AssertionFailure() << "position " << v;
    for (float v : m.normals)
        if (!std::isfinite(v)) return ::testing::AssertionFailure() << "normal " << v;
    for (uint32_t k : m.indices)
        if (k >= m.vertex_count()) return ::testing::AssertionFailure() << "index " << k;
    return ::testing::AssertionSuccess();
}

inline std::string vectors_dir() {
    const char* env = std::getenv("NFD_TEST_VECTORS_DIR");
    return env && *env ? env : NFD_TEST_VECTORS_DIR;
}

// The format-version prefix of a vector file name, "v1_<minor>_", or "" if `file` has none.
inline std::string golden_prefix(const std::string& file) {
    if (file.size() < 6 || file.rfind("v1_", 0) != 0) return "";
    const size_t underscore = file.find('_', 3);
    if (underscore == std::string::npos || underscore == 3) return "";
    for (size_t i = 3; i < underscore; ++i)
        if (!std::isdigit(static_cast<unsigned char>(file[i]))) return "";
    return file.substr(0, underscore + 1);
}

// Names <name> of every tests/vectors/v1_<minor>_<name>.nfc (all 1.x vectors: 1.0 geometry, 1.1
// with colour), sorted.
inline std::vector<std::string> golden_names() {
    namespace fs = std::filesystem;
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(vectors_dir(), ec)) {
        const std::string file = entry.path().filename().string();
        const std::string prefix = golden_prefix(file);
        if (!prefix.empty() && entry.path().extension() == ".nfc")
            names.push_back(file.substr(prefix.size(), file.size() - prefix.size() - 4));
    }
    std::sort(names.begin(), names.end());
    return names;
}

// Names of the vectors with colour (format 1.1 and later).
inline std::vector<std::string> golden_colour_names() {
    std::vector<std::string> names;
    for (const std::string& name : golden_names())
        if (std::filesystem::exists(vectors_dir() + "/v1_1_" + name + ".colours.txt"))
            names.push_back(name);
    return names;
}

// A fixture's SetUp with a host Vulkan device (host_vulkan.h): `why` is what HostVulkan::create
// returned; non-empty skips the test, or fails it when NFD_REQUIRE_VULKAN is set.
inline void skip_without_vulkan(const std::string& why) {
    if (why.empty()) return;
    const char* required = std::getenv("NFD_REQUIRE_VULKAN");
    if (required && *required && *required != '0') FAIL() << why;
    GTEST_SKIP() << why;
}

// tests/vectors/v1_<minor>_<name><suffix>, the minor being the one its .nfc has.
inline std::string golden_path(const std::string& name, const std::string& suffix) {
    for (const char* prefix : {"/v1_0_", "/v1_1_", "/v1_2_"}) {
        const std::string stem = vectors_dir() + prefix + name;
        if (std::filesystem::exists(stem + ".nfc")) return stem + suffix;
    }
    return vectors_dir() + "/v1_0_" + name + suffix;  // missing: the error names the 1.0 path
}

inline Bytes read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot open " + path);
    return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace nfd::test
