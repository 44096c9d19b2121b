// libFuzzer target: nfd_stream fed in pieces whose sizes the input draws. Layout of an input: a
// count byte n, then n bytes of piece sizes (1..256 each, repeated cyclically), then the file. The
// stream's result must equal nfd_asset_create's where nfdecode.h says it does; an asset taken
// when the geometry is ready and the complete asset must be the one-shot's (same info, and the
// same colours at a few points, bit for bit).
#include <nfdecode/nfdecode.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "fuzz_util.h"

namespace {

// Two assets of the same file agree: info, frame, and the field and colour at fixed points.
void require_same(const nfd_asset* a, const nfd_asset* b, bool compare_colour) {
    nfd_asset_info x{}, y{};
    require(nfd_asset_get_info(a, &x) == NFD_SUCCESS && nfd_asset_get_info(b, &y) == NFD_SUCCESS);
    x.has_colour = y.has_colour = 0;  // an early asset may predate the colour chunk
    require(std::memcmp(&x, &y, sizeof x) == 0);
    nfd_asset_frame fa{}, fb{};  // the early asset is placed as the complete one (`fram`)
    require(nfd_asset_get_frame(a, &fa) == NFD_SUCCESS && nfd_asset_get_frame(b, &fb) == NFD_SUCCESS);
    require(std::memcmp(&fa, &fb, sizeof fa) == 0);
    const float points[6] = {0.1f, -0.2f, 0.3f, 1.5f, 2.0f, -0.5f};
    float va[2], vb[2], ca[6], cb[6];
    require(nfd_asset_evaluate(cpu_context(), a, points, 2, va) == NFD_SUCCESS);
    require(nfd_asset_evaluate(cpu_context(), b, points, 2, vb) == NFD_SUCCESS);
    require(std::memcmp(va, vb, sizeof va) == 0);
    if (!compare_colour) return;
    const nfd_result ra = nfd_asset_evaluate_colour(cpu_context(), a, points, 2, ca);
    const nfd_result rb = nfd_asset_evaluate_colour(cpu_context(), b, points, 2, cb);
    require(ra == rb && (ra != NFD_SUCCESS || std::memcmp(ca, cb, sizeof ca) == 0));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 2 || !cpu_context()) return 0;
    const size_t n = std::min<size_t>(data[0], size - 1);
    const uint8_t* sizes = data + 1;
    const uint8_t* file = data + 1 + n;
    const size_t file_size = size - 1 - n;

    nfd_asset* one_shot = nullptr;
    const nfd_result expected = file_size ? nfd_asset_create(file, file_size, &one_shot)
                                          : NFD_ERROR_TRUNCATED;
    nfd_stream* stream = nullptr;
    if (nfd_stream_create(nullptr, &stream) != NFD_SUCCESS) std::abort();
    nfd_asset* early = nullptr;
    nfd_result r = NFD_SUCCESS;
    for (size_t at = 0, k = 0; r == NFD_SUCCESS && at < file_size; ++k) {
        const size_t piece = std::min<size_t>(file_size - at, n ? 1 + sizes[k % n] : file_size);
        nfd_stream_progress p{};
        r = nfd_stream_feed(stream, file + at, piece, &p);
        at += piece;
        require(p.bytes_consumed <= at);
        if (r == NFD_SUCCESS && !early && (p.flags & NFD_STREAM_GEOMETRY_READY))
            require(nfd_stream_take_asset(stream, &early) == NFD_SUCCESS);
    }
    if (r == NFD_SUCCESS) r = nfd_stream_finish(stream);
    // nfdecode.h "Which result a stream gives": equal for an input of exactly file_size bytes and
    // for one whose header is short or damaged; a valid one-shot file streams valid.
    uint32_t major, minor;
    const bool announced = file_size >= 16 && (file[8] | file[9] << 8 | file[10] << 16 |
                                               uint32_t(file[11]) << 24) == file_size;
    if (announced || file_size < 16 ||
        nfd_peek_format_version(file, file_size, &major, &minor) != NFD_SUCCESS)
        require(r == expected);
    if (expected == NFD_SUCCESS) require(r == NFD_SUCCESS);
    if (r == NFD_SUCCESS) {
        nfd_asset* complete = nullptr;
        require(nfd_stream_take_complete_asset(stream, &complete) == NFD_SUCCESS);
        require(one_shot != nullptr);
        require_same(complete, one_shot, true);
        if (early) require_same(early, one_shot, false);
        nfd_asset_destroy(complete);
    }
    nfd_asset_destroy(early);
    nfd_stream_destroy(stream);
    nfd_asset_destroy(one_shot);
    return 0;
}
