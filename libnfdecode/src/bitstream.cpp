// The .nfc reader. Every read goes through the bounded Reader, every value is checked where
// FORMAT.md defines it, and nothing is allocated before the caps have bounded its size.
#include "bitstream.h"

#include <brotli/decode.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

namespace nfd {

uint32_t load_u32(const uint8_t* p) {
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

namespace {

#define NFD_TRY(expr)                                  \
    do {                                               \
        const nfd_result nfd_try_result_ = (expr);     \
        if (nfd_try_result_ != NFD_SUCCESS) return nfd_try_result_; \
    } while (0)
#define NFD_CHECK(cond) \
    do {                \
        if (!(cond)) return NFD_ERROR_CORRUPT; \
    } while (0)

constexpr uint8_t kMagic[4] = {0x89, 'N', 'F', 'C'};


// Bounds-checked little-endian reads; running past the end is "truncated" by definition.
class Reader {
public:
    Reader(const uint8_t* data, size_t size) : p_(data), end_(data + size) {}
    size_t remaining() const { return size_t(end_ - p_); }
    const uint8_t* position() const { return p_; }

    nfd_result u8(uint8_t* v) { return read(v, 1); }
    nfd_result u16(uint16_t* v) { return read(v, 2); }
    nfd_result u32(uint32_t* v) { return read(v, 4); }
    nfd_result f32(float* v) {
        uint32_t bits = 0;
        NFD_TRY(u32(&bits));
        std::memcpy(v, &bits, 4);
        return NFD_SUCCESS;
    }
    nfd_result f64(double* v) {
        uint64_t bits = 0;
        NFD_TRY(read(&bits, 8));
        std::memcpy(v, &bits, 8);
        return NFD_SUCCESS;
    }

private:
    template <class T>
    nfd_result read(T* v, size_t n) {
        if (remaining() < n) return NFD_ERROR_TRUNCATED;
        uint64_t x = 0;
        for (size_t i = 0; i < n; ++i) x |= uint64_t(p_[i]) << (8 * i);
        *v = T(x);
        p_ += n;
        return NFD_SUCCESS;
    }
    const uint8_t* p_;
    const uint8_t* end_;
};

bool is_letter(uint8_t c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }

// TagSet's bitmap index of a tag of four letters.
constexpr uint32_t kTagSpace = 52u * 52u * 52u * 52u;
uint32_t letter_index(uint32_t c) { return c >= 'a' ? c - 'a' + 26 : c - 'A'; }
uint32_t tag_index(uint32_t tag) {
    uint32_t i = 0;
    for (int k = 3; k >= 0; --k) i = i * 52 + letter_index((tag >> (8 * k)) & 0xFF);
    return i;
}
void set_bit(nfd::vector<uint64_t>& bitmap, uint32_t i) { bitmap[i / 64] |= uint64_t(1) << (i % 64); }

// Decompresses into exactly `out_size` bytes: the stream must produce exactly that much output,
// end there, and use all of `in`. Anything else (invalid, shorter, longer, trailing input) is
// corrupt. The output buffer is never grown: at most one probe byte past its end is requested.
// The brotli decoder's state through the host's hooks (nfd_set_allocator); NULL tells brotli that
// the allocation failed.
void* brotli_allocate(void*, size_t bytes) { return host_allocate_or_null(bytes); }
void brotli_free(void*, void* address) { host_deallocate(address); }

nfd_result brotli_decompress_exact(const uint8_t* in, size_t in_size, uint8_t* out,
                                   size_t out_size) {
    struct Free {
        void operator()(BrotliDecoderState* s) const { BrotliDecoderDestroyInstance(s); }
    };
    std::unique_ptr<BrotliDecoderState, Free> state(
        BrotliDecoderCreateInstance(brotli_allocate, brotli_free, nullptr));
    if (!state) return NFD_ERROR_OUT_OF_MEMORY;

    size_t avail_in = in_size, avail_out = out_size;
    const uint8_t* next_in = in;
    uint8_t* next_out = out;
    BrotliDecoderResult result = BrotliDecoderDecompressStream(state.get(), &avail_in, &next_in,
                                                               &avail_out, &next_out, nullptr);
    if (result == BROTLI_DECODER_RESULT_NEEDS_MORE_OUTPUT && avail_out == 0) {
        // The buffer is full; brotli may still have to read the end of the stream. A stream that
        // yields even one more byte is longer than announced.
        uint8_t probe = 0;
        size_t probe_avail = 1;
        uint8_t* probe_next = &probe;
        result = BrotliDecoderDecompressStream(state.get(), &avail_in, &next_in, &probe_avail,
                                               &probe_next, nullptr);
        if (probe_avail == 0) return NFD_ERROR_CORRUPT;
    }
    if (result == BROTLI_DECODER_RESULT_ERROR) {
        const BrotliDecoderErrorCode code = BrotliDecoderGetErrorCode(state.get());
        if (code <= BROTLI_DECODER_ERROR_ALLOC_CONTEXT_MODES &&
            code >= BROTLI_DECODER_ERROR_ALLOC_BLOCK_TYPE_TREES)
            return NFD_ERROR_OUT_OF_MEMORY;  // brotli's ALLOC_* range: our fault, not the file's
    }
    NFD_CHECK(result == BROTLI_DECODER_RESULT_SUCCESS);  // invalid, or shorter (needs more input)
    NFD_CHECK(avail_out == 0);                           // ended early
    NFD_CHECK(avail_in == 0);                            // bytes after the end of the stream
    return NFD_SUCCESS;
}

bool finite(float v) { return std::isfinite(v); }

// Whether a stored CRC matches. Fuzzing builds (NFD_FUZZ_NO_CRC, set by NFD_BUILD_FUZZERS only)
// accept any, so that mutated inputs reach the checks and the decoding behind the framing.
bool crc_matches(uint32_t computed, uint32_t stored) {
#if NFD_FUZZ_NO_CRC
    (void)computed, (void)stored;
    return true;
#else
    return computed == stored;
#endif
}

// FORMAT.md "Network block" up to the steps: what fixes the network's shape.
struct NetworkShape {
    uint8_t num_frequencies = 0, output = 0, bits = 0, num_layers = 0;
    float beta = 0, omega0 = 0;
    uint16_t widths[NFD_MAX_LAYERS] = {};
    uint32_t input_width() const { return 3u + 6u * num_frequencies; }
};

// `required_output` and `outputs` are the chunk's own rules (GEOM: the activation matching the
// field type, and one output).
nfd_result read_network_shape(Reader& r, OutputActivation required_output, uint32_t outputs,
                              NetworkShape* s) {
    NFD_TRY(r.u8(&s->num_frequencies));
    NFD_CHECK(s->num_frequencies <= NFD_MAX_FREQUENCIES);
    NFD_TRY(r.f32(&s->beta));
    NFD_CHECK(finite(s->beta) && s->beta >= 1.0f && s->beta <= 2.0f);
    NFD_TRY(r.f32(&s->omega0));
    NFD_CHECK(finite(s->omega0) && s->omega0 > 0.0f && s->omega0 <= 1000.0f);
    NFD_TRY(r.u8(&s->output));
    NFD_CHECK(s->output == uint8_t(required_output));
    NFD_TRY(r.u8(&s->bits));
    NFD_CHECK(s->bits >= 2 && s->bits <= 16);
    NFD_TRY(r.u8(&s->num_layers));
    NFD_CHECK(s->num_layers >= 2 && s->num_layers <= NFD_MAX_LAYERS);
    for (uint32_t i = 0; i < s->num_layers; ++i) {
        NFD_TRY(r.u16(&s->widths[i]));
        NFD_CHECK(s->widths[i] >= 1 && s->widths[i] <= NFD_MAX_WIDTH);
    }
    NFD_CHECK(s->widths[s->num_layers - 1] == outputs);
    return NFD_SUCCESS;
}

// The shape's fields of a Network (weights and biases empty), frequencies in f64 by repeated
// multiplication, each rounded to f32 (FORMAT.md step 1).
void set_network_shape(const NetworkShape& s, Network* net) {
    net->layers.assign(s.num_layers, Layer{});
    for (uint32_t i = 0, in = s.input_width(); i < s.num_layers; in = s.widths[i++]) {
        net->layers[i].in = in;
        net->layers[i].out = s.widths[i];
    }
    const uint64_t pi_bits = 0x400921FB54442D18ull;
    double a = 0;
    std::memcpy(&a, &pi_bits, sizeof a);
    net->frequencies.resize(s.num_frequencies);
    for (float& f : net->frequencies) {
        f = float(a);
        a *= double(s.beta);
    }
    net->omega0 = s.omega0;
    net->output = OutputActivation(s.output);
    net->bits = s.bits;
}

// FORMAT.md "Network block".
nfd_result read_network(Reader& r, OutputActivation required_output, uint32_t outputs,
                        Network* net) {
    NetworkShape shape;
    NFD_TRY(read_network_shape(r, required_output, outputs, &shape));
    const uint32_t num_layers = shape.num_layers, bits = shape.bits;
    const uint16_t* widths = shape.widths;
    float steps[2 * NFD_MAX_LAYERS] = {};
    for (uint32_t i = 0; i < 2u * num_layers; ++i) {
        NFD_TRY(r.f32(&steps[i]));
        NFD_CHECK(finite(steps[i]) && steps[i] > 0.0f);
    }

    const uint32_t input_width = shape.input_width();
    uint64_t parameters = 0;
    for (uint32_t i = 0, in = input_width; i < num_layers; in = widths[i++])
        parameters += uint64_t(in) * widths[i] + widths[i];
    NFD_CHECK(parameters <= NFD_MAX_PARAMETERS);

    // The caps now bound every size: allocate and decompress.
    if (r.remaining() < 1) return NFD_ERROR_TRUNCATED;
    const size_t bytes_per_level = bits <= 8 ? 1 : 2;
    nfd::vector<uint8_t> levels(size_t(parameters) * bytes_per_level);
    NFD_TRY(brotli_decompress_exact(r.position(), r.remaining(), levels.data(), levels.size()));

    const int32_t max_level = (int32_t(1) << (bits - 1)) - 1;
    size_t next = 0;
    bool levels_ok = true;
    auto dequantize = [&](nfd::vector<float>& dst, size_t count, float step) {
        dst.resize(count);
        for (size_t k = 0; k < count; ++k, ++next) {
            const int32_t q = bytes_per_level == 1
                                  ? int32_t(int8_t(levels[next]))
                                  : int32_t(int16_t(uint16_t(levels[2 * next] |
                                                             levels[2 * next + 1] << 8)));
            levels_ok &= q >= -max_level && q <= max_level;
            dst[k] = float(q) * step;  // FORMAT.md: one f32 multiplication
        }
    };
    set_network_shape(shape, net);
    for (uint32_t i = 0; i < num_layers; ++i) {
        Layer& layer = net->layers[i];
        dequantize(layer.weights, size_t(layer.in) * layer.out, steps[2 * i]);
        dequantize(layer.bias, layer.out, steps[2 * i + 1]);
    }
    NFD_CHECK(levels_ok);
    return NFD_SUCCESS;
}

// GEOM's fields before its network block.
nfd_result read_geometry_frame(Reader& r, Geometry* g) {
    uint8_t field = 0;
    NFD_TRY(r.u8(&field));
    NFD_CHECK(field <= uint8_t(FieldType::Udf));
    g->field = FieldType(field);
    NFD_TRY(r.f32(&g->truncation));
    NFD_CHECK(finite(g->truncation) && g->truncation > 0.0f && g->truncation <= 1.0f);
    for (float& c : g->center) {
        NFD_TRY(r.f32(&c));
        NFD_CHECK(finite(c));
    }
    NFD_TRY(r.f32(&g->scale));
    NFD_CHECK(finite(g->scale) && g->scale > 0.0f);
    // Positions u * scale + center (|u| <= 1.1 with a rounded-up level's last cells) stay finite.
    double extent = 0;
    for (float c : g->center) extent = std::max(extent, std::fabs(double(c)));
    NFD_CHECK(extent + double(g->scale) <= NFD_MAX_FRAME_EXTENT);
    return NFD_SUCCESS;
}

OutputActivation geometry_activation(FieldType field) {
    return field == FieldType::Sdf ? OutputActivation::Identity : OutputActivation::Abs;
}

nfd_result read_geometry(Reader& r, Geometry* g) {
    NFD_TRY(read_geometry_frame(r, g));
    NFD_TRY(read_network(r, geometry_activation(g->field), 1, &g->network));
    g->network.ball = ShapeBall::of_truncation(g->truncation);
    return NFD_SUCCESS;
}

// FORMAT.md "`fram` payload": the exact frame, of which GEOM holds the nearest f32 values (so
// that a 1.0 reader, which skips this chunk, places the shape where the f32 frame can).
nfd_result read_frame64(Reader& r, Geometry* g) {
    Frame64 frame;
    for (int a = 0; a < 3; ++a) {
        NFD_TRY(r.f64(&frame.center[a]));
        NFD_CHECK(std::isfinite(frame.center[a]) && float(frame.center[a]) == g->center[a]);
    }
    NFD_TRY(r.f64(&frame.scale));
    NFD_CHECK(std::isfinite(frame.scale) && frame.scale > 0.0 && float(frame.scale) == g->scale);
    NFD_CHECK(r.remaining() == 0);
    g->frame64 = frame;
    return NFD_SUCCESS;
}

// FORMAT.md "`colr` payload": the colour space (0 only), then an RGB network.
nfd_result read_colour(Reader& r, Network* net) {
    uint8_t colour_space = 0;
    NFD_TRY(r.u8(&colour_space));
    NFD_CHECK(colour_space == 0);
    return read_network(r, OutputActivation::Sigmoid, 3, net);
}

}  // namespace

uint32_t crc32(const uint8_t* data, size_t size, uint32_t previous) {
    static const std::array<uint32_t, 256> table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[i] = c;
        }
        return t;
    }();
    uint32_t crc = previous ^ 0xFFFFFFFFu;
    for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xFF] ^ (crc >> 8);
    return crc ^ 0xFFFFFFFFu;
}

bool TagSet::insert(uint32_t tag) {
    if (bitmap_.empty()) {
        for (size_t i = 0; i < count_; ++i)
            if (inline_[i] == tag) return false;
        if (count_ < inline_.size()) {
            inline_[count_++] = tag;
            return true;
        }
        bitmap_.assign(kTagSpace / 64 + 1, 0);
        for (size_t i = 0; i < count_; ++i) set_bit(bitmap_, tag_index(inline_[i]));
    }
    const uint32_t i = tag_index(tag);
    if (bitmap_[i / 64] >> (i % 64) & 1) return false;
    set_bit(bitmap_, i);
    return true;
}

bool peek_geometry_network(const uint8_t* payload, size_t size, Network* shape) {
    Reader r(payload, size);
    Geometry g;
    NetworkShape s;
    if (read_geometry_frame(r, &g) != NFD_SUCCESS ||
        read_network_shape(r, geometry_activation(g.field), 1, &s) != NFD_SUCCESS)
        return false;
    set_network_shape(s, shape);
    return true;
}

nfd_result read_format_version(const uint8_t* header, uint32_t* major, uint32_t* minor) {
    NFD_CHECK(std::memcmp(header, kMagic, 4) == 0);
    NFD_CHECK(crc_matches(crc32(header, 12), load_u32(header + 12)));
    *major = header[4];
    *minor = header[5];
    return NFD_SUCCESS;
}

size_t FileParser::next_piece_size() const {
    switch (next_) {
        case Next::Header: return kHeaderSize;
        case Next::Frame: return size_t(std::min<uint64_t>(kChunkFrameSize, file_.file_size - offset_));
        case Next::Body: return size_t(length_) + kChunkCrcSize;
        case Next::End: break;
    }
    return 0;
}

nfd_result FileParser::read_piece(const uint8_t* piece) {
    const size_t size = next_piece_size();
    switch (next_) {
        case Next::Header: NFD_TRY(read_header(piece)); break;
        case Next::Frame: NFD_TRY(read_frame(piece, size)); break;
        case Next::Body: NFD_TRY(read_body(piece)); break;
        case Next::End: return NFD_ERROR_INTERNAL;  // the caller reads past the end
    }
    offset_ += size;
    return NFD_SUCCESS;
}

// In the documented order: magic, CRC, major, flags, file_size. The CRC comes before the version so
// that a damaged header reads as corrupt, not as a misleading version.
nfd_result FileParser::read_header(const uint8_t* header) {
    NFD_TRY(read_format_version(header, &file_.major, &file_.minor));
    if (file_.major != NFD_FORMAT_MAJOR) return NFD_ERROR_UNSUPPORTED_VERSION;
    NFD_CHECK((header[6] | header[7]) == 0);
    file_.file_size = load_u32(header + 8);
    NFD_CHECK(file_.file_size >= kHeaderSize + kChunkFrameSize + kChunkCrcSize &&
              file_.file_size <= NFD_MAX_FILE_SIZE);
    if (total_size_ != kUnknownSize) {
        if (total_size_ < file_.file_size) return NFD_ERROR_TRUNCATED;
        NFD_CHECK(total_size_ == file_.file_size);  // trailing bytes
    }
    next_ = Next::Frame;
    return NFD_SUCCESS;
}

// Chunk framing: the 8 bytes of tag and length within the file, the length cap, then payload and
// CRC within the file. Nothing about the tag yet: that comes after the CRC.
nfd_result FileParser::read_frame(const uint8_t* frame, size_t size) {
    if (size < kChunkFrameSize) return NFD_ERROR_TRUNCATED;
    std::memcpy(frame_, frame, kChunkFrameSize);
    tag_ = load_u32(frame);
    length_ = load_u32(frame + 4);
    NFD_CHECK(length_ <= NFD_MAX_CHUNK_SIZE);
    const uint64_t left = file_.file_size - offset_ - kChunkFrameSize;
    if (left < uint64_t(length_) + kChunkCrcSize) return NFD_ERROR_TRUNCATED;
    next_ = Next::Body;
    return NFD_SUCCESS;
}

// Then CRC, tag (letters, duplicate, GEOM first, unknown critical) and payload.
nfd_result FileParser::read_body(const uint8_t* body) {
    NFD_CHECK(crc_matches(crc32(body, length_, crc32(frame_, kChunkFrameSize)),
                          load_u32(body + length_)));
    for (int k = 0; k < 4; ++k) NFD_CHECK(is_letter(uint8_t(tag_ >> (8 * k))));
    NFD_CHECK(seen_.insert(tag_));
    NFD_CHECK(chunks_read_ > 0 || tag_ == kTagGeom);  // GEOM must come first

    if (tag_ == kTagGeom) {
        Reader payload(body, length_);
        NFD_TRY(read_geometry(payload, &file_.geometry));
    } else if (tag_ == kTagFrame64) {
        NFD_CHECK(chunks_read_ == 1);  // directly after GEOM, before anything is placed
        Reader payload(body, length_);
        NFD_TRY(read_frame64(payload, &file_.geometry));
    } else if (tag_ == kTagColour) {
        Reader payload(body, length_);
        Network colour;
        NFD_TRY(read_colour(payload, &colour));
        file_.colour = std::move(colour);
    } else if (uint8_t(tag_) >= 'A' && uint8_t(tag_) <= 'Z') {
        return NFD_ERROR_UNSUPPORTED_FEATURE;  // unknown critical chunk
    }  // unknown optional chunk: verified, skipped
    ++chunks_read_;
    const uint64_t end = offset_ + length_ + kChunkCrcSize;
    next_ = end == file_.file_size ? Next::End : Next::Frame;
    return NFD_SUCCESS;
}

}  // namespace nfd
