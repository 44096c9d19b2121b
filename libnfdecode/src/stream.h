// Bytes as they arrive, gathered into the pieces FileParser reads (bitstream.h): incremental input
// for nfd_stream, and the one-shot parse_file as the same machine given the whole file at once.
#pragma once
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "bitstream.h"

#include "host_memory.h"

namespace nfd {

class StreamReader {
public:
    explicit StreamReader(uint64_t total_size = FileParser::kUnknownSize) : parser_(total_size) {}

    // Takes `size` bytes: every piece they complete is verified at once, so the first failure in
    // byte order is reported by the call whose bytes complete the failing piece; a byte past
    // file_size is NFD_ERROR_CORRUPT (trailing data). Sticky: after a failure every call returns it.
    // Pieces that lie whole inside `bytes` are read in place; only a piece split across calls is
    // copied, into a buffer of exactly its size, so memory is the header or one chunk at most.
    nfd_result feed(const uint8_t* bytes, size_t size);

    // No more bytes: NFD_ERROR_TRUNCATED unless the file is complete (sticky as feed's failures).
    nfd_result finish();

    // Makes a failure that feed could not record itself sticky: an exception (std::bad_alloc,
    // mapped by api.cpp) may leave a piece half read. Keeps an earlier failure.
    void record_failure(nfd_result r) {
        if (error_ == NFD_SUCCESS) error_ = r;
    }

    nfd_result error() const { return error_; }
    // The GEOM network's shape (peek_geometry_network) once a feed has gathered enough of a GEOM
    // body split across feeds, before the body is complete; nullptr before, and when the body
    // arrived whole in one feed (then the asset itself is ready). Set at most once.
    const Network* early_network_shape() const { return early_shape_ ? &*early_shape_ : nullptr; }
    // Bytes taken from feed: after a failure, up to the end of the piece that failed.
    uint64_t bytes_consumed() const { return consumed_; }
    const FileParser& parser() const { return parser_; }
    FileParser& parser() { return parser_; }

private:
    void peek_network_shape();

    FileParser parser_;
    nfd::vector<uint8_t> pending_;  // the start of a piece split across feed calls
    uint64_t consumed_ = 0;
    nfd_result error_ = NFD_SUCCESS;
    std::optional<Network> early_shape_;
};

// The one-shot reader: `size` bytes, all of them the file. Errors exactly as FORMAT.md orders them
// (the size rule right after the header, since the size is known); see nfd_asset_create. Reads in
// place: only an input shorter than the header is copied. May throw std::bad_alloc; api.cpp maps it.
nfd_result parse_file(const uint8_t* bytes, size_t size, ParsedFile* out);

}  // namespace nfd
