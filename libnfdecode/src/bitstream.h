// The .nfc reader (FORMAT.md): the only code in libnfdecode that looks at file bytes.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "network.h"
#include "nfdecode/nfdecode.h"

#include "host_memory.h"

namespace nfd {

constexpr size_t kHeaderSize = 16;
constexpr size_t kChunkFrameSize = 8;  // tag, length
constexpr size_t kChunkCrcSize = 4;

constexpr uint32_t tag_of(const char (&s)[5]) {
    return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
           uint32_t(uint8_t(s[3])) << 24;
}
constexpr uint32_t kTagGeom = tag_of("GEOM");
constexpr uint32_t kTagColour = tag_of("colr");
constexpr uint32_t kTagFrame64 = tag_of("fram");

// CRC-32, ISO-HDLC / zlib: reflected polynomial 0xEDB88320, init and xorout 0xFFFFFFFF.
// `previous` continues a CRC over more bytes, as zlib's crc32(): crc32(b, m + n) ==
// crc32(b + m, n, crc32(b, m)).
uint32_t crc32(const uint8_t* data, size_t size, uint32_t previous = 0);
// The little-endian u32 at p (every integer of the format, and of pipeline_cache.h's envelope).
uint32_t load_u32(const uint8_t* p);

struct ParsedFile {
    uint32_t major = 0, minor = 0;  // minor may exceed NFD_FORMAT_MINOR (newer optional chunks)
    uint32_t file_size = 0;
    Geometry geometry;              // dequantized GEOM chunk
    std::optional<Network> colour;  // dequantized `colr` chunk (1.1): 3 sigmoid outputs
    bool has_colour() const { return colour.has_value(); }
};

// The header checks every major shares (FORMAT.md "Version policy"): magic, then header_crc.
// `header` holds kHeaderSize bytes. NFD_ERROR_CORRUPT, or the file's version, whatever it is.
nfd_result read_format_version(const uint8_t* header, uint32_t* major, uint32_t* minor);

// The geometry network's shape (frequencies, omega0, output activation, layer widths; no weights)
// from the first bytes of a GEOM payload, as soon as they hold it (about 40 bytes): for work that
// can start before the chunk is complete, such as the GPU pipelines of that shape. The rules of
// those fields are checked, the chunk's CRC cannot be yet: the shape is a hint, never a result.
// False while the bytes are too few, or when they break a rule.
bool peek_geometry_network(const uint8_t* payload, size_t size, Network* shape);

// "Each tag may appear at most once", checked in O(1) per chunk whatever the chunk count: a file
// may legally hold millions of empty optional chunks. A tag is four letters, so a bitmap over the
// 52^4 possible tags (0.9 MiB) is allocated only when a file has more chunks than the inline list.
class TagSet {
public:
    // Returns false if `tag` (four letters) was inserted before.
    bool insert(uint32_t tag);

private:
    std::array<uint32_t, 8> inline_{};
    size_t count_ = 0;
    nfd::vector<uint64_t> bitmap_;
};

// FORMAT.md's reader, one piece of the file at a time, in file order: the header, then for each
// chunk its frame (tag and length) and then its body (payload and CRC). The caller hands over each
// piece whole, so the checks run in exactly the order FORMAT.md gives, whether the file arrived at
// once (parse_file) or in pieces of any size (stream.h): that order is the one place both readers
// take their errors from. After a failure the parser must not be used again.
class FileParser {
public:
    static constexpr uint64_t kUnknownSize = UINT64_MAX;

    // `total_size`: how many bytes the caller has, when it knows before reading (the one-shot
    // reader). FORMAT.md compares it with file_size right after the header (fewer: truncated, more:
    // corrupt), before any chunk. A stream passes kUnknownSize and learns the total only at its end.
    explicit FileParser(uint64_t total_size) : total_size_(total_size) {}

    // Bytes the next piece has: 16 (header); min(8, bytes left in the file) (a frame: fewer than 8
    // fail as truncated, as the one-shot reader runs out there); length + 4 (a body, whose length
    // the frame checked against NFD_MAX_CHUNK_SIZE and file_size). 0 once the file is complete.
    size_t next_piece_size() const;

    // Verifies the next piece, exactly next_piece_size() bytes, and decodes what it completes.
    // Results as nfd_asset_create's. Allocates only for a GEOM body, within the caps.
    nfd_result read_piece(const uint8_t* piece);

    bool header_read() const { return next_ != Next::Header; }
    bool complete() const { return next_ == Next::End; }
    uint32_t chunks_read() const { return chunks_read_; }
    // GEOM and, when the file has one, `fram` (the second chunk) are read: the asset's outputs are
    // placed. Known when the chunk after GEOM shows its tag (or the file ends there).
    bool geometry_read() const {
        return chunks_read_ > 1 ||
               (chunks_read_ == 1 && (next_ == Next::End || (next_ == Next::Body && tag_ != kTagFrame64)));
    }
    // The next piece is the first chunk's body under a GEOM tag (not yet verified): its payload
    // starts with what peek_geometry_network reads.
    bool reading_geometry_body() const {
        return next_ == Next::Body && chunks_read_ == 0 && tag_ == kTagGeom;
    }
    uint64_t offset() const { return offset_; }              // bytes of the pieces read
    const ParsedFile& file() const { return file_; }
    ParsedFile& file() { return file_; }

private:
    enum class Next { Header, Frame, Body, End };
    nfd_result read_header(const uint8_t* header);
    nfd_result read_frame(const uint8_t* frame, size_t size);
    nfd_result read_body(const uint8_t* body);

    uint64_t total_size_;
    Next next_ = Next::Header;
    uint64_t offset_ = 0;
    uint8_t frame_[kChunkFrameSize] = {};  // the current chunk's, which its CRC covers
    uint32_t tag_ = 0, length_ = 0;
    uint32_t chunks_read_ = 0;
    TagSet seen_;
    ParsedFile file_;
};

}  // namespace nfd
