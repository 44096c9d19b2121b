#include "stream.h"

#include <algorithm>
#include <new>
#include <utility>

namespace nfd {

nfd_result StreamReader::feed(const uint8_t* bytes, size_t size) {
    while (error_ == NFD_SUCCESS && size > 0) {
        const size_t need = parser_.next_piece_size();
        if (need == 0) return error_ = NFD_ERROR_CORRUPT;  // past file_size: trailing data
        const uint8_t* piece = bytes;
        if (pending_.empty() && size >= need) {
            bytes += need, size -= need;
            consumed_ += need;
        } else {
            // `need` is the header or a chunk's frame or body, whose length the frame has checked
            // against NFD_MAX_CHUNK_SIZE and file_size: what is reserved here is bounded by both.
            if (pending_.empty()) pending_.reserve(need);
            const size_t take = std::min(size, need - pending_.size());
            pending_.insert(pending_.end(), bytes, bytes + take);
            bytes += take, size -= take;
            consumed_ += take;
            if (pending_.size() < need) {
                peek_network_shape();
                break;
            }
            piece = pending_.data();
        }
        error_ = parser_.read_piece(piece);
        nfd::vector<uint8_t>().swap(pending_);  // hold no chunk past its end
    }
    return error_;
}

void StreamReader::peek_network_shape() {
    if (early_shape_ || !parser_.reading_geometry_body()) return;
    try {
        Network shape;
        if (peek_geometry_network(pending_.data(), pending_.size(), &shape))
            early_shape_ = std::move(shape);
    } catch (const std::bad_alloc&) {
        // Only a hint (early_network_shape): the stream goes on without it.
    }
}

nfd_result StreamReader::finish() {
    if (error_ == NFD_SUCCESS && !parser_.complete()) error_ = NFD_ERROR_TRUNCATED;
    return error_;
}

nfd_result parse_file(const uint8_t* bytes, size_t size, ParsedFile* out) {
    StreamReader reader(size);
    reader.feed(bytes, size);
    const nfd_result r = reader.finish();
    if (r == NFD_SUCCESS) *out = std::move(reader.parser().file());
    return r;
}

}  // namespace nfd
