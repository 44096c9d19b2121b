// nfd_stream against the one-shot reader: the same asset and mesh whatever the piece sizes, the
// same result code on every complete file, every prefix, every byte flip (nfdecode.h, "Which
// result a stream gives"), progress at the right byte counts, the asset before a later chunk, and
// memory bounded by the chunk in progress.
#include <gtest/gtest.h>
#include <nfdecode/nfdecode.h>

#include <memory>

#include "alloc_tracking.h"
#include "colour_util.h"
#include "stream.h"
#include "test_util.h"

namespace nfd::test {
namespace {

struct StreamFree {
    void operator()(nfd_stream* s) const { nfd_stream_destroy(s); }
};
using StreamPtr = std::unique_ptr<nfd_stream, StreamFree>;
struct AssetFree {
    void operator()(nfd_asset* a) const { nfd_asset_destroy(a); }
};
using AssetPtr = std::unique_ptr<nfd_asset, AssetFree>;

StreamPtr new_stream() {
    nfd_stream* s = nullptr;
    EXPECT_EQ(nfd_stream_create(nullptr, &s), NFD_SUCCESS);
    return StreamPtr(s);
}

// Piece sizes that cover `size` bytes: 1 each (seed 0), else random sizes of 1..2*mean.
std::vector<size_t> split(size_t size, uint32_t seed, size_t mean = 40) {
    std::vector<size_t> pieces;
    std::mt19937 rng(seed);
    std::uniform_int_distribution<size_t> length(1, 2 * mean);
    for (size_t done = 0; done < size;) {
        const size_t n = std::min(size - done, seed == 0 ? size_t(1) : length(rng));
        pieces.push_back(n);
        done += n;
    }
    return pieces;
}

// Feeds `bytes` in `pieces` and finishes: the stream's result (the first failing feed's, else
// finish's), and its asset when it succeeds.
struct Streamed {
    nfd_result result;
    AssetPtr asset;
};
Streamed stream_in_pieces(const Bytes& bytes, const std::vector<size_t>& pieces) {
    StreamPtr s = new_stream();
    size_t at = 0;
    for (size_t n : pieces) {
        const nfd_result r = nfd_stream_feed(s.get(), bytes.data() + at, n, nullptr);
        at += n;
        if (r != NFD_SUCCESS) return {r, nullptr};
    }
    Streamed out{nfd_stream_finish(s.get()), nullptr};
    if (out.result == NFD_SUCCESS) {
        nfd_asset* a = nullptr;
        EXPECT_EQ(nfd_stream_take_complete_asset(s.get(), &a), NFD_SUCCESS);
        out.asset.reset(a);
    }
    return out;
}

nfd_result one_shot(const Bytes& bytes) {
    nfd_asset* a = nullptr;
    const nfd_result r = nfd_asset_create(bytes.data(), bytes.size(), &a);
    nfd_asset_destroy(a);
    return r;
}

// The mesh at resolution 64 on the CPU, as raw arrays (colour_util.h).
MeshArrays mesh_of(const nfd_asset* asset) {
    struct ContextFree {
        void operator()(nfd_context* c) const { nfd_context_destroy(c); }
    };
    // A CPU context per call (cheap): none outlives the test (HostMemory.* replace the allocator
    // only while nothing is alive, in the single-process sanitizer runs too).
    const std::unique_ptr<nfd_context, ContextFree> ctx = [] {
        nfd_context_options co{};
        co.struct_size = sizeof co;
        co.device = NFD_DEVICE_CPU;
        nfd_context* c = nullptr;
        EXPECT_EQ(nfd_context_create(&co, &c), NFD_SUCCESS);
        return std::unique_ptr<nfd_context, ContextFree>(c);
    }();
    nfd_mesh_options mo{};
    mo.struct_size = sizeof mo;
    mo.resolution = 64;
    nfd_mesh* mesh = nullptr;
    EXPECT_EQ(nfd_mesh_extract(ctx.get(), asset, &mo, &mesh), NFD_SUCCESS);
    MeshArrays m = arrays_of(mesh);
    nfd_mesh_destroy(mesh);
    return m;
}

// GEOM then optional chunks: a colour chunk, an unknown one, an empty one; newer minor.
Bytes optional_colour() { return colour_payload(random_colour_siren(8, 8, 21)); }

Bytes file_with_optional_chunks() {
    return file({chunk("GEOM", geom_payload(closed_blob())), chunk("colr", optional_colour()),
                 chunk("xtra", Bytes{}), chunk("zzZZ", Bytes(40, 7))},
                {1, 3, 0});
}

std::vector<std::pair<std::string, Bytes>> all_files() {
    std::vector<std::pair<std::string, Bytes>> files = {
        {"blob", geom_file(closed_blob())},
        {"siren_udf_b12", geom_file(random_siren(16, 12, 3, /*field_type=*/1))},
        {"blob_optional_chunks", file_with_optional_chunks()},
    };
    for (const std::string& name : golden_names())
        files.emplace_back("golden " + name, read_bytes(golden_path(name, ".nfc")));
    return files;
}

// Acceptance: byte-at-a-time, random splits and the whole file give the one-shot's mesh, byte
// for byte, and the same asset info.
TEST(Stream, AnySplitGivesTheOneShotMesh) {
    for (const auto& [name, bytes] : all_files()) {
        nfd_asset* reference = nullptr;
        ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &reference), NFD_SUCCESS) << name;
        const AssetPtr owned(reference);
        const MeshArrays expected = mesh_of(reference);
        ASSERT_FALSE(expected.indices.empty()) << name;
        nfd_asset_info expected_info{};
        ASSERT_EQ(nfd_asset_get_info(reference, &expected_info), NFD_SUCCESS);
        const std::vector<std::vector<size_t>> splits = {
            split(bytes.size(), 0), split(bytes.size(), 1), split(bytes.size(), 2, 7),
            split(bytes.size(), 3, 500), {bytes.size()}};
        for (size_t k = 0; k < splits.size(); ++k) {
            const Streamed s = stream_in_pieces(bytes, splits[k]);
            ASSERT_EQ(s.result, NFD_SUCCESS) << name << " split " << k;
            EXPECT_TRUE(mesh_of(s.asset.get()) == expected) << name << " split " << k;
            nfd_asset_info info{};
            ASSERT_EQ(nfd_asset_get_info(s.asset.get(), &info), NFD_SUCCESS);
            EXPECT_EQ(std::memcmp(&info, &expected_info, sizeof info), 0) << name << " split " << k;
        }
    }
}

TEST(Stream, EveryPrefixIsTruncatedAtFinishAsOneShot) {
    for (const auto& [name, bytes] : all_files()) {
        for (size_t n = 0; n < bytes.size(); ++n) {
            const Bytes prefix(bytes.begin(), bytes.begin() + long(n));
            if (n > 0)  // (no bytes at all: nfd_asset_create sees a NULL pointer)
                ASSERT_EQ(one_shot(prefix), NFD_ERROR_TRUNCATED) << name << " prefix " << n;
            ASSERT_EQ(stream_in_pieces(prefix, split(n, uint32_t(n) + 1, 16)).result,
                      NFD_ERROR_TRUNCATED)
                << name << " prefix " << n;
        }
    }
}

// Every position of the small files, every 7th of the golden ones, under two patterns, fed in
// random pieces: the one-shot's code on the same damaged bytes.
TEST(Stream, ByteFlipsGiveTheOneShotResult) {
    size_t compared = 0, accepted = 0;
    for (const auto& [name, bytes] : all_files()) {
        const size_t stride = name.rfind("golden", 0) == 0 ? 7 : 1;
        Bytes damaged = bytes;
        for (size_t i = 0; i < bytes.size(); i += stride) {
            for (uint8_t p : {uint8_t(0x01), uint8_t(0xA5)}) {
                damaged[i] = uint8_t(bytes[i] ^ p);
                const nfd_result expected = one_shot(damaged);
                const nfd_result got =
                    stream_in_pieces(damaged, split(damaged.size(), uint32_t(i * 2 + p), 24)).result;
                ASSERT_EQ(got, expected) << name << " byte " << i << " ^ " << int(p);
                ++compared;
                accepted += got == NFD_SUCCESS;
            }
            damaged[i] = bytes[i];
        }
    }
    EXPECT_GT(compared, 5000u);
    EXPECT_LT(accepted, compared);
}

// Damage that CRCs do not catch (recomputed after the change) reaches every later rule: the
// header's version and flags, the chunk tag rules, the GEOM fields.
TEST(Stream, CrcConsistentDamageGivesTheOneShotResult) {
    const Bytes geom = chunk("GEOM", geom_payload(random_siren(8, 8, 9)));
    std::vector<Bytes> files = {
        file({geom, chunk("NWER", Bytes{1})}),              // unknown critical
        file({geom, geom}),                                 // duplicate
        file({chunk("abcd", {}), geom}),                    // GEOM not first
        file({geom, chunk("ab1d", {})}),                    // not letters
        file({geom}, {2, 0, 0}),                            // other major
        file({geom}, {1, 0, 1}),                            // flags
        file({geom, Bytes{'a', 'b', 'c', 'd', 0, 0}}),      // frame cut short by file_size
    };
    Bytes overrun = geom;
    set_u32(overrun, 4, uint32_t(geom.size()));  // length past the end of the file
    files.push_back(file({overrun}));
    Bytes huge = geom;
    set_u32(huge, 4, NFD_MAX_CHUNK_SIZE + 1);
    files.push_back(file({huge}));
    const Bytes payload = geom_payload(random_siren(8, 8, 9));
    for (size_t i = 0; i < payload.size(); i += 3) {
        Bytes damaged = payload;
        damaged[i] ^= 0x81;
        files.push_back(file({chunk("GEOM", damaged)}));
    }
    for (size_t k = 0; k < files.size(); ++k) {
        const nfd_result expected = one_shot(files[k]);
        if (k < 9) EXPECT_NE(expected, NFD_SUCCESS) << k;
        for (uint32_t seed : {0u, 5u})
            EXPECT_EQ(stream_in_pieces(files[k], split(files[k].size(), seed, 9)).result, expected)
                << "file " << k << " seed " << seed;
    }
}

TEST(Stream, TrailingBytesAreCorrupt) {
    const Bytes good = geom_file(closed_blob());
    Bytes longer = good;
    longer.push_back(0);
    ASSERT_EQ(one_shot(longer), NFD_ERROR_CORRUPT);
    EXPECT_EQ(stream_in_pieces(longer, {longer.size()}).result, NFD_ERROR_CORRUPT);
    EXPECT_EQ(stream_in_pieces(longer, split(longer.size(), 0)).result, NFD_ERROR_CORRUPT);

    // After a successful finish, more bytes are trailing too; the extra byte is not consumed.
    StreamPtr s = new_stream();
    nfd_stream_progress p{};
    ASSERT_EQ(nfd_stream_feed(s.get(), good.data(), good.size(), &p), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_finish(s.get()), NFD_SUCCESS);
    const uint8_t extra = 0;
    EXPECT_EQ(nfd_stream_feed(s.get(), &extra, 1, &p), NFD_ERROR_CORRUPT);
    EXPECT_EQ(p.bytes_consumed, good.size());
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_CORRUPT);
}

// Fed one byte at a time, each bit of progress appears on the byte that completes it.
TEST(Stream, ProgressAtTheRightByteCounts) {
    const Bytes bytes = file_with_optional_chunks();
    const size_t geom_end = 16 + 12 + geom_payload(closed_blob()).size();
    const size_t colr_end = geom_end + 12 + optional_colour().size();
    StreamPtr s = new_stream();
    nfd_stream_progress p{};
    ASSERT_EQ(nfd_stream_feed(s.get(), nullptr, 0, &p), NFD_SUCCESS);
    EXPECT_EQ(p.flags, 0u);
    EXPECT_EQ(p.file_size, 0u);
    uint32_t chunks = 0;
    for (size_t n = 1; n <= bytes.size(); ++n) {
        ASSERT_EQ(nfd_stream_feed(s.get(), &bytes[n - 1], 1, &p), NFD_SUCCESS) << n;
        ASSERT_EQ(p.bytes_consumed, n);
        ASSERT_EQ((p.flags & NFD_STREAM_HEADER_READ) != 0, n >= 16) << n;
        // Ready when the chunk after GEOM shows it is not the 64-bit frame (FORMAT.md).
        ASSERT_EQ((p.flags & NFD_STREAM_GEOMETRY_READY) != 0, n >= geom_end + 8) << n;
        ASSERT_EQ((p.flags & NFD_STREAM_COLOUR_SEEN) != 0, n >= colr_end) << n;
        ASSERT_EQ((p.flags & NFD_STREAM_COMPLETE) != 0, n == bytes.size()) << n;
        if (n >= 16) {
            ASSERT_EQ(p.file_size, bytes.size());
            ASSERT_EQ(p.format_major, 1u);
            ASSERT_EQ(p.format_minor, 3u);
        }
        if (p.chunks_complete != chunks) {
            const size_t chunk_ends[] = {geom_end, colr_end, colr_end + 12, bytes.size()};
            ASSERT_EQ(p.chunks_complete, chunks + 1) << n;
            EXPECT_EQ(n, chunk_ends[chunks]);
            chunks = p.chunks_complete;
        }
    }
    EXPECT_EQ(chunks, 4u);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_SUCCESS);
}

// The asset is there once GEOM's CRC and the next chunk's tag (not a 64-bit frame) have arrived,
// before the colour chunk; it is the one-shot's, survives the stream, and is handed out once.
TEST(Stream, AssetBeforeTheLaterChunks) {
    const Bytes bytes = file_with_optional_chunks();
    const size_t geom_end = 16 + 12 + geom_payload(closed_blob()).size();
    const size_t ready = geom_end + 8;
    nfd_asset* reference = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &reference), NFD_SUCCESS);
    const AssetPtr owned_reference(reference);

    StreamPtr s = new_stream();
    nfd_stream_progress p{};
    nfd_asset* a = reinterpret_cast<nfd_asset*>(0x1);
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), ready - 1, &p), NFD_SUCCESS);
    EXPECT_EQ(p.flags & NFD_STREAM_GEOMETRY_READY, 0u);
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);  // not yet
    EXPECT_EQ(a, nullptr);
    ASSERT_EQ(nfd_stream_feed(s.get(), &bytes[ready - 1], 1, &p), NFD_SUCCESS);
    EXPECT_NE(p.flags & NFD_STREAM_GEOMETRY_READY, 0u);
    EXPECT_EQ(p.flags & NFD_STREAM_COLOUR_SEEN, 0u);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr asset(a);
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);  // once
    EXPECT_EQ(a, nullptr);
    nfd_asset_info info{};
    ASSERT_EQ(nfd_asset_get_info(asset.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.has_colour, 0);  // as of the take: colr has not arrived
    EXPECT_EQ(info.format_minor, 3u);
    EXPECT_EQ(info.file_size, bytes.size());

    // The rest arrives; the stream reports it; the asset taken does not change.
    ASSERT_EQ(nfd_stream_feed(s.get(), &bytes[ready], bytes.size() - ready, &p), NFD_SUCCESS);
    EXPECT_NE(p.flags & NFD_STREAM_COLOUR_SEEN, 0u);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_SUCCESS);
    s.reset();
    ASSERT_EQ(nfd_asset_get_info(asset.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.has_colour, 0);
    EXPECT_TRUE(mesh_of(asset.get()).same_geometry(mesh_of(reference)));
    EXPECT_TRUE(mesh_of(asset.get()).colours.empty());
}

// A geo-referenced file (GEOM, then its 64-bit frame, then colour): the asset waits for the frame,
// which places every output, and carries it.
TEST(Stream, AssetWaitsForTheFrameAfterGeom) {
    const double center[3] = {600123.4567891, 200654.3219876, -12.25};
    GeomSpec blob = closed_blob();
    for (int a = 0; a < 3; ++a) blob.center[a] = float(center[a]);
    blob.scale = 2.0f;
    const Bytes bytes = file({chunk("GEOM", geom_payload(blob)),
                              chunk("fram", frame64_payload(center, 2.0)),
                              chunk("colr", optional_colour())},
                             {1, 2, 0});
    const size_t frame_end = 16 + 12 + geom_payload(blob).size() + 12 + 32;
    StreamPtr s = new_stream();
    nfd_stream_progress p{};
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), frame_end - 1, &p), NFD_SUCCESS);
    EXPECT_EQ(p.chunks_complete, 1u);  // GEOM is verified ...
    EXPECT_EQ(p.flags & NFD_STREAM_GEOMETRY_READY, 0u);  // ... but not yet placed
    nfd_asset* a = nullptr;
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);
    ASSERT_EQ(nfd_stream_feed(s.get(), &bytes[frame_end - 1], 1, &p), NFD_SUCCESS);
    EXPECT_NE(p.flags & NFD_STREAM_GEOMETRY_READY, 0u);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr early(a);
    nfd_asset_frame frame{};
    ASSERT_EQ(nfd_asset_get_frame(early.get(), &frame), NFD_SUCCESS);
    EXPECT_EQ(frame.exact64, 1);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(frame.offset[k], center[k]);
    nfd_asset* reference = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &reference), NFD_SUCCESS);
    const AssetPtr owned_reference(reference);
    EXPECT_TRUE(mesh_of(early.get()).same_geometry(mesh_of(reference)));
}

// The complete asset: only once every byte is verified, once, with the colour; the geometry's
// asset taken before stays geometry only, and colouring its mesh afterwards gives the one-shot's.
TEST(Stream, CompleteAssetBringsTheColour) {
    const Bytes bytes = file_with_optional_chunks();
    nfd_asset* reference = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &reference), NFD_SUCCESS);
    const AssetPtr owned_reference(reference);
    const MeshArrays expected = mesh_of(reference);
    ASSERT_FALSE(expected.colours.empty());

    StreamPtr s = new_stream();
    nfd_asset* a = nullptr;
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), bytes.size() - 1, nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr early(a);
    EXPECT_EQ(nfd_stream_take_complete_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);  // not yet
    EXPECT_EQ(a, nullptr);
    ASSERT_EQ(nfd_stream_feed(s.get(), &bytes.back(), 1, nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_complete_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr complete(a);
    EXPECT_EQ(nfd_stream_take_complete_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);  // once
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_SUCCESS);
    s.reset();

    nfd_asset_info info{};
    ASSERT_EQ(nfd_asset_get_info(early.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.has_colour, 1);  // taken after colr arrived (one byte before the end)
    ASSERT_EQ(nfd_asset_get_info(complete.get(), &info), NFD_SUCCESS);
    EXPECT_EQ(info.has_colour, 1);
    EXPECT_TRUE(mesh_of(complete.get()) == expected);
}

// A mesh decoded before the colour arrived is coloured afterwards, as the one-shot's.
TEST(Stream, MeshBeforeTheColourIsColouredLater) {
    const Bytes bytes = file_with_optional_chunks();
    const size_t geom_end = 16 + 12 + geom_payload(closed_blob()).size();
    nfd_asset* reference = nullptr;
    ASSERT_EQ(nfd_asset_create(bytes.data(), bytes.size(), &reference), NFD_SUCCESS);
    const AssetPtr owned_reference(reference);
    nfd_context_options co{};
    co.struct_size = sizeof co;
    co.device = NFD_DEVICE_CPU;
    nfd_context* c = nullptr;
    ASSERT_EQ(nfd_context_create(&co, &c), NFD_SUCCESS);
    const std::unique_ptr<nfd_context, void (*)(nfd_context*)> ctx(c, &nfd_context_destroy);

    StreamPtr s = new_stream();
    nfd_asset* a = nullptr;
    const size_t ready = geom_end + 8;  // GEOM and the next chunk's frame
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), ready, nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr early(a);
    nfd_mesh* m = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx.get(), early.get(), nullptr, &m), NFD_SUCCESS);
    const std::unique_ptr<nfd_mesh, void (*)(nfd_mesh*)> mesh(m, &nfd_mesh_destroy);
    const float* colours = reinterpret_cast<const float*>(0x1);
    ASSERT_EQ(nfd_mesh_get_colours(mesh.get(), &colours), NFD_SUCCESS);
    EXPECT_EQ(colours, nullptr);
    EXPECT_EQ(nfd_mesh_evaluate_colours(ctx.get(), early.get(), mesh.get()), NFD_ERROR_NO_COLOUR);

    ASSERT_EQ(nfd_stream_feed(s.get(), &bytes[ready], bytes.size() - ready, nullptr),
              NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_complete_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr complete(a);
    ASSERT_EQ(nfd_mesh_evaluate_colours(ctx.get(), complete.get(), mesh.get()), NFD_SUCCESS);
    ASSERT_EQ(nfd_mesh_get_colours(mesh.get(), &colours), NFD_SUCCESS);
    ASSERT_NE(colours, nullptr);
    nfd_mesh* one_shot_mesh = nullptr;
    ASSERT_EQ(nfd_mesh_extract(ctx.get(), reference, nullptr, &one_shot_mesh), NFD_SUCCESS);
    const std::unique_ptr<nfd_mesh, void (*)(nfd_mesh*)> expected(one_shot_mesh, &nfd_mesh_destroy);
    nfd_mesh_data d{};
    ASSERT_EQ(nfd_mesh_get_data(expected.get(), &d), NFD_SUCCESS);
    const float* expected_colours = nullptr;
    ASSERT_EQ(nfd_mesh_get_colours(expected.get(), &expected_colours), NFD_SUCCESS);
    ASSERT_NE(expected_colours, nullptr);
    EXPECT_EQ(std::memcmp(colours, expected_colours, 12 * d.vertex_count), 0);
}

// A failure after GEOM: the asset taken before it stays valid; take_asset afterwards reports it.
TEST(Stream, FailureAfterTheAssetWasTaken) {
    Bytes bytes = file_with_optional_chunks();
    const size_t geom_end = 16 + 12 + geom_payload(closed_blob()).size();
    bytes[geom_end + 20] ^= 0x10;  // inside colr's payload: its CRC fails
    ASSERT_EQ(one_shot(bytes), NFD_ERROR_CORRUPT);

    StreamPtr s = new_stream();
    nfd_asset* a = nullptr;
    const size_t ready = geom_end + 8;  // GEOM and the next chunk's frame
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), ready, nullptr), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    const AssetPtr asset(a);
    EXPECT_EQ(nfd_stream_feed(s.get(), &bytes[ready], bytes.size() - ready, nullptr),
              NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_CORRUPT);
    s.reset();
    EXPECT_FALSE(mesh_of(asset.get()).indices.empty());

    // Fed at once, the failure comes with the same call that completed GEOM: no asset.
    s = new_stream();
    EXPECT_EQ(nfd_stream_feed(s.get(), bytes.data(), bytes.size(), nullptr), NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_CORRUPT);
    EXPECT_EQ(a, nullptr);
}

// The first failure in byte order, reported by the feed that completes the failing structure,
// and then by every call. On a prefix of a damaged file this is where the stream and the
// one-shot reader may differ (documented): the one-shot reader applies the size rule first.
TEST(Stream, ErrorsAreEarlyAndSticky) {
    Bytes bytes = file_with_optional_chunks();
    const size_t geom_end = 16 + 12 + geom_payload(closed_blob()).size();
    bytes[geom_end - 1] ^= 0x01;  // GEOM's CRC
    StreamPtr s = new_stream();
    nfd_stream_progress p{};
    ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), geom_end - 1, &p), NFD_SUCCESS);
    EXPECT_EQ(nfd_stream_feed(s.get(), &bytes[geom_end - 1], 10, &p), NFD_ERROR_CORRUPT);
    EXPECT_EQ(p.bytes_consumed, geom_end);  // up to the end of the failing chunk
    EXPECT_EQ(p.chunks_complete, 0u);
    EXPECT_EQ(p.flags, NFD_STREAM_HEADER_READ);
    EXPECT_EQ(nfd_stream_feed(s.get(), &bytes[geom_end + 9], 5, &p), NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_stream_feed(s.get(), nullptr, 0, &p), NFD_ERROR_CORRUPT);
    EXPECT_EQ(p.bytes_consumed, geom_end);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_CORRUPT);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_CORRUPT);
    const Bytes prefix(bytes.begin(), bytes.begin() + long(geom_end));
    EXPECT_EQ(one_shot(prefix), NFD_ERROR_TRUNCATED);  // the documented difference

    // The header: as soon as its 16th byte arrives, whatever follows. Truncation only at finish.
    const Bytes v2 = geom_file(closed_blob(), {2, 0, 0});
    s = new_stream();
    ASSERT_EQ(nfd_stream_feed(s.get(), v2.data(), 15, &p), NFD_SUCCESS);
    EXPECT_EQ(nfd_stream_feed(s.get(), &v2[15], 1, &p), NFD_ERROR_UNSUPPORTED_VERSION);
    EXPECT_EQ(p.flags, 0u);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_UNSUPPORTED_VERSION);
}

TEST(Stream, NullAndInvalidArguments) {
    nfd_stream* raw = reinterpret_cast<nfd_stream*>(0x1);
    EXPECT_EQ(nfd_stream_create(nullptr, nullptr), NFD_ERROR_INVALID_ARGUMENT);
    nfd_stream_options tiny{};
    tiny.struct_size = 2;  // smaller than the first layout
    EXPECT_EQ(nfd_stream_create(&tiny, &raw), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(raw, nullptr);
    struct {
        nfd_stream_options known;
        uint32_t unknown;
    } newer{};
    newer.known.struct_size = sizeof newer;
    ASSERT_EQ(nfd_stream_create(&newer.known, &raw), NFD_SUCCESS);  // unknown fields zero
    nfd_stream_destroy(raw);
    newer.unknown = 1;
    EXPECT_EQ(nfd_stream_create(&newer.known, &raw), NFD_ERROR_INVALID_ARGUMENT);

    const Bytes good = geom_file(closed_blob());
    nfd_stream_progress p{};
    nfd_asset* a = nullptr;
    EXPECT_EQ(nfd_stream_feed(nullptr, good.data(), good.size(), &p), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_stream_finish(nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_stream_take_asset(nullptr, &a), NFD_ERROR_INVALID_ARGUMENT);
    nfd_stream_destroy(nullptr);

    // NULL bytes with a size is the caller's mistake, not the stream's: it goes on working.
    StreamPtr s = new_stream();
    EXPECT_EQ(nfd_stream_feed(s.get(), nullptr, 4, &p), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(p.bytes_consumed, 0u);
    EXPECT_EQ(nfd_stream_feed(s.get(), good.data(), good.size(), nullptr), NFD_SUCCESS);
    EXPECT_EQ(nfd_stream_take_asset(s.get(), nullptr), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_stream_finish(s.get()), NFD_SUCCESS);
    ASSERT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_SUCCESS);
    nfd_asset_destroy(a);
}

TEST(Stream, PeekFormatVersion) {
    const Bytes good = geom_file(closed_blob(), {1, 4, 0});
    uint32_t major = 77, minor = 77;
    ASSERT_EQ(nfd_peek_format_version(good.data(), 16, &major, &minor), NFD_SUCCESS);
    EXPECT_EQ(major, 1u);
    EXPECT_EQ(minor, 4u);
    EXPECT_EQ(nfd_peek_format_version(good.data(), good.size(), &major, &minor), NFD_SUCCESS);

    // Another major, or 1.x rules broken after the CRC: peeking succeeds, decoding does not.
    const Bytes v3 = geom_file(closed_blob(), {3, 1, 0});
    ASSERT_EQ(nfd_peek_format_version(v3.data(), v3.size(), &major, &minor), NFD_SUCCESS);
    EXPECT_EQ(major, 3u);
    EXPECT_EQ(minor, 1u);
    EXPECT_EQ(one_shot(v3), NFD_ERROR_UNSUPPORTED_VERSION);
    const Bytes flagged = geom_file(closed_blob(), {1, 0, 4});
    EXPECT_EQ(nfd_peek_format_version(flagged.data(), 16, &major, &minor), NFD_SUCCESS);
    EXPECT_EQ(one_shot(flagged), NFD_ERROR_CORRUPT);

    major = minor = 77;
    EXPECT_EQ(nfd_peek_format_version(good.data(), 15, &major, &minor), NFD_ERROR_TRUNCATED);
    Bytes bad = good;
    bad[0] = 0x88;  // magic, even with its CRC fixed
    set_u32(bad, 12, crc32(bad.data(), 12));
    EXPECT_EQ(nfd_peek_format_version(bad.data(), 16, &major, &minor), NFD_ERROR_CORRUPT);
    bad = good;
    bad[5] ^= 1;  // the minor, under the CRC
    EXPECT_EQ(nfd_peek_format_version(bad.data(), 16, &major, &minor), NFD_ERROR_CORRUPT);
    EXPECT_EQ(major, 77u);  // untouched on failure
    EXPECT_EQ(minor, 77u);
    EXPECT_EQ(nfd_peek_format_version(nullptr, 16, &major, &minor), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_peek_format_version(good.data(), 16, nullptr, &minor), NFD_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(nfd_peek_format_version(good.data(), 16, &major, nullptr), NFD_ERROR_INVALID_ARGUMENT);
}

// A header announcing the largest file and a chunk of 1000 bytes, arriving a byte at a time: the
// stream reserves that chunk and nothing near the file's size. A length beyond the cap is
// rejected before anything is reserved.
TEST(Stream, MemoryIsBoundedByTheChunkInProgress) {
    auto announcing = [](uint32_t length) {
        Bytes b = file({chunk("abcd", Bytes(1000, 1))});
        set_u32(b, 8, NFD_MAX_FILE_SIZE);
        set_u32(b, 12, crc32(b.data(), 12));
        set_u32(b, 20, length);
        return b;
    };
    for (uint32_t length : {1000u, NFD_MAX_CHUNK_SIZE + 1}) {
        const Bytes b = announcing(length);
        StreamPtr s = new_stream();
        nfd_result r = NFD_SUCCESS;
        g_largest_allocation = 0;
        g_track_allocations = true;
        for (size_t n = 0; n < 16 + 8 + 500 && r == NFD_SUCCESS; ++n)
            r = nfd_stream_feed(s.get(), &b[n], 1, nullptr);
        g_track_allocations = false;
        if (length == 1000) {
            EXPECT_EQ(r, NFD_SUCCESS);
            EXPECT_EQ(g_largest_allocation.load(), size_t(1000) + 4);  // payload and CRC
        } else {
            EXPECT_EQ(r, NFD_ERROR_CORRUPT);
            EXPECT_LE(g_largest_allocation.load(), size_t(16));
        }
    }
}

// An allocation failure inside a feed is sticky like a file's failure: a piece may be half read.
TEST(Stream, OutOfMemoryIsSticky) {
    const Bytes bytes = geom_file(random_siren(16, 8, 4));
    // One byte of the body: reserving its buffer fails. The whole body: decoding it in place does.
    for (size_t body_bytes : {size_t(1), bytes.size() - 24}) {
        StreamPtr s = new_stream();
        ASSERT_EQ(nfd_stream_feed(s.get(), bytes.data(), 24, nullptr), NFD_SUCCESS);  // to the body
        g_fail_allocations_over = 64;
        const nfd_result r = nfd_stream_feed(s.get(), &bytes[24], body_bytes, nullptr);
        g_fail_allocations_over = SIZE_MAX;
        EXPECT_EQ(r, NFD_ERROR_OUT_OF_MEMORY) << body_bytes;
        EXPECT_EQ(nfd_stream_feed(s.get(), &bytes[25], 1, nullptr), NFD_ERROR_OUT_OF_MEMORY);
        EXPECT_EQ(nfd_stream_finish(s.get()), NFD_ERROR_OUT_OF_MEMORY);
        nfd_asset* a = nullptr;
        EXPECT_EQ(nfd_stream_take_asset(s.get(), &a), NFD_ERROR_OUT_OF_MEMORY);
    }
}

// The network's shape is known from GEOM's first bytes, long before the chunk is complete
// (nfd_stream_options.prepare_context compiles its pipelines then): fed a byte at a time, every
// file shows the shape of the network it decodes to while its geometry is still incomplete, from
// the same byte whatever the piece sizes; a GEOM that arrives whole in one feed shows none.
TEST(Stream, NetworkShapeIsReadBeforeTheGeometryChunkIsComplete) {
    for (const auto& [name, bytes] : all_files()) {
        SCOPED_TRACE(name);
        const Geometry parsed = parse_or_throw(bytes);
        // Header, GEOM's frame, its 21 bytes of frame fields, the network's 12 bytes, the widths.
        const size_t shape_end = 16 + 8 + 21 + 12 + 2 * parsed.network.layers.size();
        for (uint32_t seed : {0u, 1u, 2u}) {
            StreamReader reader;
            size_t at = 0;
            for (size_t n : split(bytes.size(), seed, 8)) {
                ASSERT_EQ(reader.feed(bytes.data() + at, n), NFD_SUCCESS);
                at += n;
                if (reader.early_network_shape()) break;
            }
            const Network* shape = reader.early_network_shape();
            ASSERT_NE(shape, nullptr);
            EXPECT_FALSE(reader.parser().geometry_read());
            if (seed == 0) EXPECT_EQ(at, shape_end);
            EXPECT_GE(at, shape_end);
            EXPECT_LT(at, shape_end + 16);  // within the piece that completes it
            EXPECT_EQ(shape->frequencies, parsed.network.frequencies);
            EXPECT_EQ(shape->omega0, parsed.network.omega0);
            EXPECT_EQ(shape->output, parsed.network.output);
            ASSERT_EQ(shape->layers.size(), parsed.network.layers.size());
            for (size_t l = 0; l < shape->layers.size(); ++l) {
                EXPECT_EQ(shape->layers[l].in, parsed.network.layers[l].in);
                EXPECT_EQ(shape->layers[l].out, parsed.network.layers[l].out);
                EXPECT_TRUE(shape->layers[l].weights.empty());
            }
        }
        StreamReader whole;
        ASSERT_EQ(whole.feed(bytes.data(), bytes.size()), NFD_SUCCESS);
        EXPECT_EQ(whole.early_network_shape(), nullptr);
    }
}

// The shape is read before the CRC can vouch for it, so it is checked as the parser checks those
// fields: a prefix that breaks a rule (field type, widths, activation) gives no shape, and every
// byte flip of the shape's bytes gives either none or one that passes the rules, never a crash.
TEST(Stream, NetworkShapeReadAheadFollowsTheRules) {
    const Bytes bytes = geom_file(random_siren(16, 8, 5, /*field_type=*/1));
    const size_t payload = 16 + 8;
    for (size_t k = payload; k < payload + 60; ++k)
        for (uint8_t flip : {0x01, 0x80, 0xFF}) {
            Bytes damaged = bytes;
            damaged[k] ^= flip;
            Network shape;
            if (peek_geometry_network(&damaged[payload], 60, &shape)) {
                EXPECT_LE(shape.frequencies.size(), size_t(NFD_MAX_FREQUENCIES));
                EXPECT_GE(shape.layers.size(), 2u);
                EXPECT_LE(shape.layers.size(), size_t(NFD_MAX_LAYERS));
                EXPECT_EQ(shape.layers.back().out, 1u);
            }
        }
    Network shape;
    EXPECT_TRUE(peek_geometry_network(&bytes[payload], bytes.size() - payload - 4, &shape));
    EXPECT_EQ(shape.output, OutputActivation::Abs);
    for (size_t n = 0; n < 21 + 12 + 2 * 3; ++n)
        EXPECT_FALSE(peek_geometry_network(&bytes[payload], n, &shape)) << n;  // too few bytes
    Bytes wrong_activation = bytes;
    wrong_activation[payload + 21 + 9] = 0;  // identity on a UDF
    EXPECT_FALSE(peek_geometry_network(&wrong_activation[payload], 60, &shape));
}

}  // namespace
}  // namespace nfd::test
