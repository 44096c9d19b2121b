// libFuzzer target over the parser (the only code that reads untrusted bytes), one-shot and
// incremental (tests/fuzz/README.md; scripts/fuzz.sh builds and runs it).
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

namespace {

// The input through nfd_stream in pieces of 1..64 bytes, sizes drawn from the input's length.
nfd_result streamed(const uint8_t* data, size_t size) {
    nfd_stream* stream = nullptr;
    nfd_result r = nfd_stream_create(nullptr, &stream);
    uint32_t state = uint32_t(size) * 2654435761u;
    for (size_t at = 0; r == NFD_SUCCESS && at < size;) {
        state = state * 1103515245u + 12345u;
        const size_t n = std::min<size_t>(size - at, 1 + (state >> 16) % 64);
        r = nfd_stream_feed(stream, data + at, n, nullptr);
        at += n;
    }
    if (r == NFD_SUCCESS) r = nfd_stream_finish(stream);
    nfd_stream_destroy(stream);
    return r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    nfd_asset* asset = nullptr;
    const nfd_result one_shot = nfd_asset_create(data, size, &asset);
    if (one_shot == NFD_SUCCESS) {
        nfd_asset_info info;
        nfd_asset_get_info(asset, &info);
        nfd_asset_destroy(asset);
        if (streamed(data, size / 2) != NFD_ERROR_TRUNCATED) std::abort();  // a valid prefix
    }
    // nfdecode.h "Which result a stream gives": equal on a short or damaged header and on an
    // input of exactly the announced file_size.
    uint32_t major, minor;
    const bool announced_size =
        size >= 16 && (data[8] | data[9] << 8 | data[10] << 16 | uint32_t(data[11]) << 24) == size;
    if ((size < 16 || nfd_peek_format_version(data, size, &major, &minor) != NFD_SUCCESS ||
         announced_size) &&
        streamed(data, size) != one_shot)
        std::abort();
    return 0;
}
