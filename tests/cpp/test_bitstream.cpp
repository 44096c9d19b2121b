// The parser against FORMAT.md: valid files, every rule and cap, and hostile bytes (every truncated
// prefix, every single-byte corruption under several bit patterns) of synthetic and golden files.
#include <gtest/gtest.h>

#include "alloc_tracking.h"
#include "test_util.h"

namespace nfd::test {
namespace {

nfd_result parse(const Bytes& b, ParsedFile* out = nullptr) {
    ParsedFile f;
    return parse_file(b.data(), b.size(), out ? out : &f);
}

// A survey's frame: 600 km east, 200 km north (UTM metres), not representable in f32.
constexpr double kFarCenter[3] = {600123.4567891, 200654.3219876, -12.25};

bool is_data_error(nfd_result r) {
    return r == NFD_ERROR_TRUNCATED || r == NFD_ERROR_CORRUPT ||
           r == NFD_ERROR_UNSUPPORTED_VERSION || r == NFD_ERROR_UNSUPPORTED_FEATURE;
}

// Valid files covering both level widths, both field types, optional chunks and a newer minor.
std::vector<std::pair<std::string, Bytes>> synthetic_files() {
    GeomSpec udf = random_siren(16, 8, 3, /*field_type=*/1);
    return {
        {"sdf_w16_b8", geom_file(random_siren(16, 8, 1))},
        {"sdf_w24_b12", geom_file(random_siren(24, 12, 2))},
        {"udf_w16_b8", geom_file(udf)},
        {"sdf_optional_chunks_minor3",
         file({chunk("GEOM", geom_payload(random_siren(8, 6, 4))),
               chunk("colr", colour_payload(random_colour_siren(8, 6, 5))),
               chunk("xtra", Bytes{}), chunk("zzZZ", Bytes(40, 7))},
              {1, 3, 0})},
        {"sdf_frame64", geo_file(random_siren(8, 8, 6), kFarCenter, 12.5)},
    };
}

std::vector<std::pair<std::string, Bytes>> all_files() {
    auto files = synthetic_files();
    for (const std::string& name : golden_names())
        files.emplace_back("golden " + name, read_bytes(golden_path(name, ".nfc")));
    return files;
}

TEST(Bitstream, Crc32MatchesZlibCheckValue) {
    const char* s = "123456789";
    EXPECT_EQ(crc32(reinterpret_cast<const uint8_t*>(s), 9), 0xCBF43926u);
    EXPECT_EQ(crc32(nullptr, 0), 0u);
}

TEST(Bitstream, ParsesSyntheticFileAndDequantizes) {
    const GeomSpec spec = random_siren(16, 8, 1);
    ParsedFile f;
    ASSERT_EQ(parse(geom_file(spec), &f), NFD_SUCCESS);
    EXPECT_EQ(f.major, 1u);
    EXPECT_EQ(f.minor, 0u);
    EXPECT_FALSE(f.has_colour());
    const Geometry& g = f.geometry;
    EXPECT_EQ(g.field, FieldType::Sdf);
    EXPECT_EQ(g.truncation, spec.truncation);
    EXPECT_EQ(g.scale, spec.scale);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(g.center[a], spec.center[a]);
    const Network& n = g.network;
    ASSERT_EQ(n.layers.size(), 3u);
    EXPECT_EQ(n.input_width(), 99u);
    EXPECT_EQ(n.output_width(), 1u);
    EXPECT_EQ(n.bits, 8u);
    EXPECT_EQ(n.omega0, 30.0f);
    // Dequantization is exactly f32(q) * step, in payload order (W row-major, then b, per layer).
    size_t k = 0;
    for (size_t l = 0; l < 3; ++l) {
        for (float w : n.layers[l].weights) ASSERT_EQ(w, float(spec.levels[k++]) * spec.steps[2 * l]);
        for (float b : n.layers[l].bias) ASSERT_EQ(b, float(spec.levels[k++]) * spec.steps[2 * l + 1]);
    }
    EXPECT_EQ(k, spec.levels.size());
    // Frequencies: pi * beta^k by repeated f64 multiplication, rounded to f32.
    ASSERT_EQ(n.frequencies.size(), 16u);
    double a = 3.141592653589793;
    for (float fk : n.frequencies) {
        EXPECT_EQ(fk, float(a));
        a *= double(1.4f);
    }
    EXPECT_NEAR(n.frequencies[15], 489.0, 1.0);
}

TEST(Bitstream, SixteenBitLevelsAndUdf) {
    ParsedFile f;
    const GeomSpec s12 = random_siren(24, 12, 2);
    ASSERT_EQ(parse(geom_file(s12), &f), NFD_SUCCESS);
    EXPECT_EQ(f.geometry.network.bits, 12u);
    EXPECT_EQ(f.geometry.network.layers[0].weights[5], float(s12.levels[5]) * s12.steps[0]);
    ASSERT_EQ(parse(geom_file(random_siren(16, 8, 3, 1)), &f), NFD_SUCCESS);
    EXPECT_EQ(f.geometry.field, FieldType::Udf);
    EXPECT_EQ(f.geometry.network.output, OutputActivation::Abs);
}

TEST(Bitstream, EveryTruncatedPrefixIsTruncated) {
    for (const auto& [name, bytes] : all_files()) {
        ASSERT_EQ(parse(bytes), NFD_SUCCESS) << name;
        for (size_t n = 0; n < bytes.size(); ++n) {
            const Bytes prefix(bytes.begin(), bytes.begin() + long(n));
            ASSERT_EQ(parse(prefix), NFD_ERROR_TRUNCATED) << name << " prefix " << n;
        }
    }
}

TEST(Bitstream, EverySingleByteCorruptionIsRejected) {
    // Several patterns: the lowest and highest bit, all bits, and a byte-dependent pattern.
    const uint8_t patterns[] = {0x01, 0x80, 0xFF, 0x5A};
    for (const auto& [name, bytes] : all_files()) {
        Bytes damaged = bytes;
        for (size_t i = 0; i < bytes.size(); ++i) {
            for (uint8_t p : patterns) {
                damaged[i] = uint8_t(bytes[i] ^ p);
                const nfd_result r = parse(damaged);
                ASSERT_TRUE(is_data_error(r))
                    << name << " byte " << i << " ^ " << int(p) << " gave " << nfd_result_string(r);
            }
            damaged[i] = bytes[i];
        }
    }
}

// Damage that the CRCs do not catch (the chunk CRC recomputed after the change) must still never
// crash or hang: each GEOM payload byte changed, under several patterns.
TEST(Bitstream, CrcConsistentGeomDamageNeverCrashes) {
    const GeomSpec spec = random_siren(8, 8, 5);
    const Bytes payload = geom_payload(spec);
    size_t accepted = 0;
    for (size_t i = 0; i < payload.size(); ++i) {
        for (uint8_t p : {uint8_t(0x01), uint8_t(0x80), uint8_t(0xFF)}) {
            Bytes damaged = payload;
            damaged[i] ^= p;
            const nfd_result r = parse(file({chunk("GEOM", damaged)}));
            ASSERT_TRUE(r == NFD_SUCCESS || is_data_error(r)) << i;
            accepted += r == NFD_SUCCESS;
        }
    }
    EXPECT_GT(accepted, 0u);  // e.g. a changed step or centre is still a valid file
}

// ---- header --------------------------------------------------------------------------------

TEST(Bitstream, HeaderRules) {
    const Bytes good = geom_file(random_siren(8, 8, 6));
    auto with = [&](size_t at, uint8_t v, bool fix_crc) {
        Bytes b = good;
        b[at] = v;
        if (fix_crc) set_u32(b, 12, crc32(b.data(), 12));
        return b;
    };
    EXPECT_EQ(parse(with(0, 0x88, true)), NFD_ERROR_CORRUPT);  // magic, even with a valid CRC
    EXPECT_EQ(parse(with(4, 2, false)), NFD_ERROR_CORRUPT);    // CRC before version
    EXPECT_EQ(parse(with(4, 2, true)), NFD_ERROR_UNSUPPORTED_VERSION);
    EXPECT_EQ(parse(with(4, 0, true)), NFD_ERROR_UNSUPPORTED_VERSION);
    EXPECT_EQ(parse(with(6, 1, true)), NFD_ERROR_CORRUPT);  // reserved flags
    EXPECT_EQ(parse(with(7, 0x80, true)), NFD_ERROR_CORRUPT);

    Bytes trailing = good;
    trailing.push_back(0);
    EXPECT_EQ(parse(trailing), NFD_ERROR_CORRUPT);

    auto with_size = [&](uint32_t size) {
        Bytes b = good;
        set_u32(b, 8, size);
        set_u32(b, 12, crc32(b.data(), 12));
        return b;
    };
    EXPECT_EQ(parse(with_size(27)), NFD_ERROR_CORRUPT);  // below header + one empty chunk
    EXPECT_EQ(parse(with_size(NFD_MAX_FILE_SIZE + 1)), NFD_ERROR_CORRUPT);
    EXPECT_EQ(parse(with_size(uint32_t(good.size()) + 1)), NFD_ERROR_TRUNCATED);
    EXPECT_EQ(parse(with_size(uint32_t(good.size()) - 1)), NFD_ERROR_CORRUPT);  // trailing byte
}

TEST(Bitstream, WrongMajorEvenWithValidContent) {
    for (uint8_t major : {0, 2, 255})
        EXPECT_EQ(parse(geom_file(random_siren(8, 8, 7), {major, 0, 0})),
                  NFD_ERROR_UNSUPPORTED_VERSION);
}

// ---- chunks --------------------------------------------------------------------------------

TEST(Bitstream, NewerMinorWithUnknownOptionalChunkIsAccepted) {
    const Bytes geom = chunk("GEOM", geom_payload(random_siren(8, 8, 8)));
    ParsedFile f;
    ASSERT_EQ(parse(file({geom, chunk("nwer", Bytes(100, 0xAB))}, {1, 7, 0}), &f), NFD_SUCCESS);
    EXPECT_EQ(f.minor, 7u);
    EXPECT_FALSE(f.has_colour());
}

// ---- the colour chunk (1.1) -----------------------------------------------------------------

TEST(Bitstream, ColourChunkIsDecoded) {
    const GeomSpec colour = random_colour_siren(12, 8, 11);
    ParsedFile f;
    ASSERT_EQ(parse(coloured_file(random_siren(8, 8, 10), colour), &f), NFD_SUCCESS);
    EXPECT_EQ(f.minor, 1u);
    ASSERT_TRUE(f.has_colour());
    const Network& n = *f.colour;
    EXPECT_EQ(n.output, OutputActivation::Sigmoid);
    EXPECT_EQ(n.output_width(), 3u);
    EXPECT_EQ(n.frequencies.size(), 8u);
    ASSERT_EQ(n.layers.size(), 3u);
    EXPECT_EQ(n.layers[0].in, 3u + 6u * 8u);
    EXPECT_EQ(n.layers[0].weights[5], float(colour.levels[5]) * colour.steps[0]);
}

// Each colour rule, checked as GEOM's are: the chunk is verified (CRC valid), its payload is not.
TEST(Bitstream, ColourChunkRules) {
    const Bytes geom = chunk("GEOM", geom_payload(random_siren(8, 8, 12)));
    auto with_colour = [&](const Bytes& payload) { return parse(file({geom, chunk("colr", payload)})); };
    const GeomSpec good = random_colour_siren(8, 8, 13);
    EXPECT_EQ(with_colour(colour_payload(good)), NFD_SUCCESS);
    EXPECT_EQ(with_colour(colour_payload(good, /*colour_space=*/1)), NFD_ERROR_CORRUPT);
    EXPECT_EQ(with_colour(Bytes{}), NFD_ERROR_TRUNCATED);
    EXPECT_EQ(with_colour(Bytes{9}), NFD_ERROR_CORRUPT);  // colour space 9
    for (uint8_t output : {0, 1, 3}) {  // identity, abs, unknown: a colour is sigmoid
        GeomSpec s = good;
        s.output = output;
        EXPECT_EQ(with_colour(colour_payload(s)), NFD_ERROR_CORRUPT) << int(output);
    }
    // One output (a geometry network in the colour chunk) or four.
    for (uint16_t outputs : {1, 4}) {
        GeomSpec s = random_siren(8, 8, 14, 0, outputs, 8);
        s.output = 2;
        EXPECT_EQ(with_colour(colour_payload(s)), NFD_ERROR_CORRUPT) << outputs;
    }
    Bytes cut = colour_payload(good);
    cut.resize(cut.size() / 2);  // inside the brotli stream
    EXPECT_EQ(with_colour(cut), NFD_ERROR_CORRUPT);
    cut.resize(10);  // inside the block's fields
    EXPECT_EQ(with_colour(cut), NFD_ERROR_TRUNCATED);
}

// ---- the 64-bit frame (1.2) ----------------------------------------------------------------

TEST(Bitstream, Frame64IsDecodedAndPlacesTheOutputs) {
    ParsedFile f;
    ASSERT_EQ(parse(geo_file(random_siren(8, 8, 20), kFarCenter, 12.5), &f), NFD_SUCCESS);
    EXPECT_EQ(f.minor, 2u);
    const Geometry& g = f.geometry;
    ASSERT_TRUE(g.frame64.has_value());
    for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(g.frame64->center[a], kFarCenter[a]);
        EXPECT_EQ(g.center[a], float(kFarCenter[a]));  // GEOM: the nearest f32
        EXPECT_EQ(g.emit_center(a), 0.0f);              // positions local ...
        EXPECT_EQ(g.offset(a), kFarCenter[a]);          // ... to the exact center
    }
    EXPECT_EQ(g.frame64->scale, 12.5);

    ParsedFile plain;
    ASSERT_EQ(parse(geom_file(random_siren(8, 8, 20)), &plain), NFD_SUCCESS);
    EXPECT_FALSE(plain.geometry.frame64.has_value());
    for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(plain.geometry.emit_center(a), plain.geometry.center[a]);  // as in 1.0
        EXPECT_EQ(plain.geometry.offset(a), 0.0);
    }
}

// Each `fram` rule: GEOM must hold its values rounded to f32, they are finite (scale > 0), the
// payload is exactly 32 bytes, and the chunk comes directly after GEOM.
TEST(Bitstream, Frame64Rules) {
    const GeomSpec spec = random_siren(8, 8, 21);
    auto with_frame = [&](const double center[3], double scale) {
        return parse(geo_file(spec, center, scale));
    };
    const double* c = kFarCenter;
    EXPECT_EQ(with_frame(c, 12.5), NFD_SUCCESS);
    // GEOM's center or scale not the f32 rounding of fram's (one ulp off either way).
    GeomSpec off = spec;
    for (int a = 0; a < 3; ++a) off.center[a] = float(c[a]);
    off.center[1] = std::nextafter(off.center[1], 0.0f);
    off.scale = 12.5f;
    const Bytes frame = frame64_payload(c, 12.5);
    EXPECT_EQ(parse(file({chunk("GEOM", geom_payload(off)), chunk("fram", frame)})),
              NFD_ERROR_CORRUPT);
    off.center[1] = float(c[1]);
    off.scale = std::nextafter(12.5f, 13.0f);
    EXPECT_EQ(parse(file({chunk("GEOM", geom_payload(off)), chunk("fram", frame)})),
              NFD_ERROR_CORRUPT);
    off.scale = 12.5f;
    const Bytes geom = chunk("GEOM", geom_payload(off));
    ASSERT_EQ(parse(file({geom, chunk("fram", frame)})), NFD_SUCCESS);
    // Non-finite or non-positive values (GEOM cannot match them either, which is checked first
    // for the center: both are corrupt).
    for (double bad : {double(NAN), double(INFINITY), 0.0, -12.5}) {
        const double center[3] = {c[0], c[1], c[2]};
        EXPECT_EQ(parse(file({geom, chunk("fram", frame64_payload(center, bad))})),
                  NFD_ERROR_CORRUPT) << bad;
        const double bad_center[3] = {c[0], bad, c[2]};
        EXPECT_EQ(parse(file({geom, chunk("fram", frame64_payload(bad_center, 12.5))})),
                  NFD_ERROR_CORRUPT) << bad;
    }
    // Payload size: short is truncated, long is corrupt.
    Bytes cut = frame;
    cut.resize(31);
    EXPECT_EQ(parse(file({geom, chunk("fram", cut)})), NFD_ERROR_TRUNCATED);
    Bytes longer = frame;
    longer.push_back(0);
    EXPECT_EQ(parse(file({geom, chunk("fram", longer)})), NFD_ERROR_CORRUPT);
    // Position: only directly after GEOM; and once.
    const Bytes colr = chunk("colr", colour_payload(random_colour_siren(8, 8, 22)));
    EXPECT_EQ(parse(file({geom, chunk("fram", frame), colr})), NFD_SUCCESS);
    EXPECT_EQ(parse(file({geom, colr, chunk("fram", frame)})), NFD_ERROR_CORRUPT);
    EXPECT_EQ(parse(file({geom, chunk("fram", frame), chunk("fram", frame)})), NFD_ERROR_CORRUPT);
}

TEST(Bitstream, ChunkRules) {
    const Bytes geom = chunk("GEOM", geom_payload(random_siren(8, 8, 9)));
    EXPECT_EQ(parse(file({geom, chunk("NWER", Bytes{1})})), NFD_ERROR_UNSUPPORTED_FEATURE);
    EXPECT_EQ(parse(file({geom, geom})), NFD_ERROR_CORRUPT);                        // duplicate
    EXPECT_EQ(parse(file({chunk("abcd", {}), geom})), NFD_ERROR_CORRUPT);           // GEOM not first
    EXPECT_EQ(parse(file({geom, chunk("ab1d", {})})), NFD_ERROR_CORRUPT);           // not letters
    EXPECT_EQ(parse(file({geom, chunk("abcd", {}), chunk("abcd", {})})), NFD_ERROR_CORRUPT);
    EXPECT_EQ(parse(file({chunk("abcd", {})})), NFD_ERROR_CORRUPT);                 // no GEOM

    Bytes bad_crc = geom;
    bad_crc.back() ^= 1;
    EXPECT_EQ(parse(file({bad_crc})), NFD_ERROR_CORRUPT);

    Bytes huge = geom;  // length beyond MAX_CHUNK_SIZE: corrupt before any bounds reasoning
    set_u32(huge, 4, NFD_MAX_CHUNK_SIZE + 1);
    EXPECT_EQ(parse(file({huge})), NFD_ERROR_CORRUPT);
    Bytes overrun = geom;  // length past the end of the file
    set_u32(overrun, 4, uint32_t(geom.size()));
    EXPECT_EQ(parse(file({overrun})), NFD_ERROR_TRUNCATED);
    Bytes stub = {'a', 'b', 'c', 'd', 0, 0};  // a chunk header cut short by file_size
    EXPECT_EQ(parse(file({geom, stub})), NFD_ERROR_TRUNCATED);
}

// Millions of empty optional chunks are legal up to the caps: linear time, bounded memory.
TEST(Bitstream, ManyChunksStayLinear) {
    std::vector<Bytes> chunks = {chunk("GEOM", geom_payload(random_siren(8, 8, 10)))};
    char tag[5] = "aaaa";
    for (int i = 0; i < 17000; ++i) {  // distinct tags "a???" with ??? in a..z
        tag[1] = char('a' + i % 26);
        tag[2] = char('a' + i / 26 % 26);
        tag[3] = char('a' + i / 676 % 26);
        chunks.push_back(chunk(tag, {}));
    }
    EXPECT_EQ(parse(file(chunks)), NFD_SUCCESS);
    tag[1] = tag[2] = tag[3] = 'a';
    chunks.push_back(chunk(tag, {}));  // a late duplicate is still caught
    EXPECT_EQ(parse(file(chunks)), NFD_ERROR_CORRUPT);
}

// ---- GEOM and network fields ---------------------------------------------------------------

nfd_result parse_spec(const GeomSpec& s) { return parse(geom_file(s)); }

TEST(Bitstream, GeometryFieldRules) {
    const GeomSpec base = random_siren(8, 8, 11);
    ASSERT_EQ(parse_spec(base), NFD_SUCCESS);
    auto expect_corrupt = [&](auto mutate, const char* what) {
        GeomSpec s = base;
        mutate(s);
        EXPECT_EQ(parse_spec(s), NFD_ERROR_CORRUPT) << what;
    };
    expect_corrupt([](GeomSpec& s) { s.field_type = 2; }, "field type");
    expect_corrupt([](GeomSpec& s) { s.truncation = 0; }, "truncation 0");
    expect_corrupt([](GeomSpec& s) { s.truncation = 1.5f; }, "truncation > 1");
    expect_corrupt([](GeomSpec& s) { s.truncation = NAN; }, "truncation NaN");
    expect_corrupt([](GeomSpec& s) { s.center[1] = INFINITY; }, "center inf");
    expect_corrupt([](GeomSpec& s) { s.center[2] = NAN; }, "center NaN");
    expect_corrupt([](GeomSpec& s) { s.scale = 0; }, "scale 0");
    // Frames whose positions would overflow f32 (a valid 1.1 file could make infinite vertices).
    expect_corrupt([](GeomSpec& s) { s.center[0] = 3e38f, s.scale = 3e38f; }, "extent > 2^126");
    expect_corrupt([](GeomSpec& s) { s.center[2] = -0x1p126f, s.scale = 0x1p100f; }, "extent over 2^126");
    {
        GeomSpec s = base;
        s.center[0] = s.center[1] = s.center[2] = 0;
        s.scale = 0x1p126f;  // exactly at the cap: positions stay below 1.1 * 2^126
        EXPECT_EQ(parse_spec(s), NFD_SUCCESS);
    }
    expect_corrupt([](GeomSpec& s) { s.scale = -1; }, "scale < 0");
    expect_corrupt([](GeomSpec& s) { s.beta = 0.99f; }, "beta < 1");
    expect_corrupt([](GeomSpec& s) { s.beta = 2.01f; }, "beta > 2");
    expect_corrupt([](GeomSpec& s) { s.beta = NAN; }, "beta NaN");
    expect_corrupt([](GeomSpec& s) { s.omega0 = 0; }, "omega0 0");
    expect_corrupt([](GeomSpec& s) { s.omega0 = 1000.5f; }, "omega0 > 1000");
    expect_corrupt([](GeomSpec& s) { s.omega0 = INFINITY; }, "omega0 inf");
    expect_corrupt([](GeomSpec& s) { s.output = 1; }, "SDF with abs output");
    expect_corrupt([](GeomSpec& s) { s.output = 2; }, "GEOM with sigmoid");
    expect_corrupt([](GeomSpec& s) { s.output = 3; }, "unknown activation");
    expect_corrupt([](GeomSpec& s) { s.field_type = 1; }, "UDF with identity output");
    expect_corrupt([](GeomSpec& s) { s.bits = 1; }, "bits 1");
    expect_corrupt([](GeomSpec& s) { s.bits = 17; }, "bits 17");
    expect_corrupt([](GeomSpec& s) { s.steps[3] = 0; }, "step 0");
    expect_corrupt([](GeomSpec& s) { s.steps[0] = -0.1f; }, "step < 0");
    expect_corrupt([](GeomSpec& s) { s.steps[5] = NAN; }, "step NaN");
    expect_corrupt([](GeomSpec& s) { s.steps[4] = INFINITY; }, "step inf");
    expect_corrupt([](GeomSpec& s) { s.widths.back() = 2; }, "two outputs");

    // Boundary values that are valid.
    GeomSpec edge = base;
    edge.beta = 2.0f;
    edge.omega0 = 1000.0f;
    edge.truncation = 1.0f;
    EXPECT_EQ(parse_spec(edge), NFD_SUCCESS);
}

TEST(Bitstream, Caps) {
    GeomSpec s = random_siren(8, 8, 12);
    s.num_frequencies = NFD_MAX_FREQUENCIES + 1;
    EXPECT_EQ(parse_spec(s), NFD_ERROR_CORRUPT);

    GeomSpec layers = random_siren(8, 8, 12);
    layers.widths.assign(NFD_MAX_LAYERS + 1, 1);
    layers.steps.assign(2 * layers.widths.size(), 0.01f);
    EXPECT_EQ(parse_spec(layers), NFD_ERROR_CORRUPT);
    layers.widths.assign(1, 1);
    layers.steps.assign(2, 0.01f);
    EXPECT_EQ(parse_spec(layers), NFD_ERROR_CORRUPT);  // fewer than 2 layers

    GeomSpec wide = random_siren(8, 8, 12);
    wide.widths[0] = NFD_MAX_WIDTH + 1;
    EXPECT_EQ(parse_spec(wide), NFD_ERROR_CORRUPT);
    wide.widths[0] = 0;
    EXPECT_EQ(parse_spec(wide), NFD_ERROR_CORRUPT);

    // Widths within caps but too many parameters in total (5 layers of 512: ~1.1M > 1M).
    GeomSpec params = random_siren(8, 8, 12);
    params.widths = {512, 512, 512, 512, 512, 1};
    params.steps.assign(12, 0.01f);
    params.levels.clear();
    ASSERT_GT(params.parameter_count(), NFD_MAX_PARAMETERS);
    EXPECT_EQ(parse(geom_file_with_payload(params, Bytes{0})), NFD_ERROR_CORRUPT);
}

TEST(Bitstream, LevelRange) {
    GeomSpec s = random_siren(8, 8, 13);
    s.levels[17] = -128;  // fits int8 but not the symmetric 8-bit grid
    EXPECT_EQ(parse_spec(s), NFD_ERROR_CORRUPT);
    s.levels[17] = 127;
    EXPECT_EQ(parse_spec(s), NFD_SUCCESS);

    GeomSpec narrow = random_siren(8, 4, 13);  // 4 bits: |q| <= 7, stored as int8
    narrow.levels.back() = 8;
    EXPECT_EQ(parse_spec(narrow), NFD_ERROR_CORRUPT);
    narrow.levels.back() = -7;
    EXPECT_EQ(parse_spec(narrow), NFD_SUCCESS);

    GeomSpec wide = random_siren(8, 16, 13);
    wide.levels[3] = -32768;
    EXPECT_EQ(parse_spec(wide), NFD_ERROR_CORRUPT);
    wide.levels[3] = -32767;
    EXPECT_EQ(parse_spec(wide), NFD_SUCCESS);
}

TEST(Bitstream, BrotliPayloadMustDecodeToExactSize) {
    const GeomSpec s = random_siren(8, 8, 14);
    const Bytes raw = s.raw_levels();
    auto with_payload = [&](const Bytes& p) { return parse(geom_file_with_payload(s, p)); };

    EXPECT_EQ(with_payload(brotli(raw)), NFD_SUCCESS);
    Bytes longer = raw;
    longer.push_back(0);
    EXPECT_EQ(with_payload(brotli(longer)), NFD_ERROR_CORRUPT);
    const Bytes shorter(raw.begin(), raw.end() - 1);
    EXPECT_EQ(with_payload(brotli(shorter)), NFD_ERROR_CORRUPT);
    Bytes trailing = brotli(raw);
    trailing.push_back(0);
    EXPECT_EQ(with_payload(trailing), NFD_ERROR_CORRUPT);
    const Bytes whole = brotli(raw), cut(whole.begin(), whole.end() - 1);
    EXPECT_EQ(with_payload(cut), NFD_ERROR_CORRUPT);
    EXPECT_EQ(with_payload(Bytes(64, 0xFF)), NFD_ERROR_CORRUPT);
    EXPECT_EQ(with_payload(Bytes{}), NFD_ERROR_TRUNCATED);  // the stream is at least one byte
    // A stream that would expand far beyond the announced size is stopped at that size.
    EXPECT_EQ(with_payload(brotli(Bytes(8u << 20, 0))), NFD_ERROR_CORRUPT);
}

// Whatever a file announces, the parser's own allocations stay within what the caps allow:
// at most P_max 16-bit levels (2 MiB) and P_max f32 weights (4 MiB) at once.
TEST(Bitstream, AllocationsAreBoundedByCaps) {
    GeomSpec big = random_siren(8, 16, 15);
    big.num_frequencies = 24;
    big.widths = {512, 512, 512, 1};  // ~0.6M parameters, the largest shape near the cap
    big.steps.assign(8, 0.01f);
    ASSERT_LE(big.parameter_count(), NFD_MAX_PARAMETERS);
    const Bytes hostile[] = {
        geom_file_with_payload(big, Bytes(100, 0x00)),  // valid header, garbage stream
        [] {  // announces the maximum file size but holds 28 bytes
            Bytes b = file({chunk("abcd", {})});
            set_u32(b, 8, NFD_MAX_FILE_SIZE);
            set_u32(b, 12, crc32(b.data(), 12));
            return b;
        }(),
    };
    g_largest_allocation = 0;
    g_track_allocations = true;
    for (const Bytes& b : hostile) EXPECT_NE(parse(b), NFD_SUCCESS);
    g_track_allocations = false;
    EXPECT_LE(g_largest_allocation.load(), size_t(4) * NFD_MAX_PARAMETERS);
}

}  // namespace
}  // namespace nfd::test
