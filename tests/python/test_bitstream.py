"""The .nfc writer and reader against libnfdecode/FORMAT.md: round trips, hostile bytes, versions, caps."""

from __future__ import annotations

import dataclasses
import math
import struct

from pathlib import Path

import brotli
import numpy as np
import pytest
from conftest import random_color_file, random_file, random_network

from nfencode.bitstream import (
    COLOR_SPACE_RGB,
    FIELD_SDF,
    FIELD_UDF,
    HEADER_SIZE,
    MAX_FREQUENCIES,
    MAX_LAYERS,
    MAX_PARAMETERS,
    MAX_WIDTH,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    OUTPUT_SIGMOID,
    TAG_COLOR,
    TAG_FRAME64,
    TAG_GEOM,
    Frame64,
    GeometryChunk,
    NfcFile,
    assemble,
    color_payload,
    crc32,
    encode_chunk,
    geometry_payload,
    parameter_count,
    positional_frequencies,
    read_nfc,
    write_nfc,
)
from nfencode.errors import FormatError


def f32(x: float) -> float:
    return float(np.float32(x))


def file_with(chunks: list[bytes], major: int = 1, minor: int = 0) -> bytes:
    return assemble(chunks, major, minor)


def geom_chunk(f: NfcFile, check: bool = True) -> bytes:
    return encode_chunk(TAG_GEOM, geometry_payload(f.geometry, check=check))


def reject(data: bytes, kind: str | None = None) -> FormatError:
    with pytest.raises(FormatError) as info:
        read_nfc(data)
    if kind is not None:
        assert info.value.kind == kind, info.value
    return info.value


def patch_header(data: bytes, **fields: int) -> bytes:
    """Rewrite header fields (FORMAT.md offsets) and re-seal the header CRC."""
    head = bytearray(data[:12])
    offsets = {"major": ("<B", 4), "minor": ("<B", 5), "flags": ("<H", 6), "file_size": ("<I", 8)}
    for name, value in fields.items():
        fmt, at = offsets[name]
        struct.pack_into(fmt, head, at, value)
    return bytes(head) + struct.pack("<I", crc32(bytes(head))) + data[16:]


# ---------------------------------------------------------------------------------------------
# Round trips


@pytest.mark.parametrize(
    "field_type,bits,frequencies,widths",
    [(FIELD_SDF, 8, 16, (32, 32, 1)), (FIELD_UDF, 8, 2, (8, 8, 1)), (FIELD_SDF, 12, 3, (5, 1)),
     (FIELD_SDF, 16, 0, (4, 3, 2, 1)), (FIELD_UDF, 2, 1, (6, 6, 1))],
)
def test_round_trip(field_type: int, bits: int, frequencies: int, widths: tuple[int, ...]) -> None:
    original = random_file(field_type, num_frequencies=frequencies, widths=widths, bits=bits, seed=bits)
    decoded = read_nfc(write_nfc(original))
    g, d = original.geometry, decoded.geometry
    assert (decoded.major, decoded.minor, decoded.skipped_chunks) == (1, 0, [])
    assert d.field_type == g.field_type
    assert d.truncation == f32(g.truncation) and d.scale == f32(g.scale)
    assert d.center == tuple(f32(c) for c in g.center)
    n, m = g.network, d.network
    assert (m.num_frequencies, m.output, m.bits, m.out_features) == (
        n.num_frequencies, n.output, n.bits, n.out_features)
    assert m.frequency_base == f32(n.frequency_base) and m.omega0 == f32(n.omega0)
    assert m.steps == [(f32(a), f32(b)) for a, b in n.steps]
    for (w0, b0), (w1, b1) in zip(n.levels, m.levels):
        np.testing.assert_array_equal(w0, w1)
        np.testing.assert_array_equal(b0, b1)
    assert write_nfc(decoded) == write_nfc(original)


def test_file_size_is_what_the_header_says(sdf_bytes: bytes) -> None:
    assert sdf_bytes[:4] == b"\x89NFC"
    assert struct.unpack_from("<I", sdf_bytes, 8)[0] == len(sdf_bytes)


def test_positional_frequencies_follow_the_spec() -> None:
    f = positional_frequencies(16, 1.4)
    assert f.dtype == np.float32 and len(f) == 16
    a = math.pi
    for k in range(16):
        assert f[k] == np.float32(a)
        a *= f32(1.4)
    assert f[0] == np.float32(math.pi) and abs(float(f[15]) - math.pi * 1.4**15) < 1e-3
    np.testing.assert_array_equal(f, positional_frequencies(16, f32(1.4)))
    assert len(positional_frequencies(0, 1.4)) == 0


# ---------------------------------------------------------------------------------------------
# Hostile bytes


def test_every_truncated_prefix_is_rejected(sdf_bytes: bytes) -> None:
    for n in range(len(sdf_bytes)):
        reject(sdf_bytes[:n], "truncated")


def test_trailing_bytes_are_corrupt(sdf_bytes: bytes) -> None:
    reject(sdf_bytes + b"\x00", "corrupt")


@pytest.mark.parametrize("flip", [0x01, 0x80, 0xFF])
def test_every_single_byte_corruption_is_rejected(sdf_bytes: bytes, flip: int) -> None:
    for i in range(len(sdf_bytes)):
        damaged = bytearray(sdf_bytes)
        damaged[i] ^= flip
        reject(bytes(damaged))


def test_header_damage_reports_corrupt_not_version(sdf_bytes: bytes) -> None:
    damaged = bytearray(sdf_bytes)
    damaged[4] = 2  # major, without re-sealing the CRC
    reject(bytes(damaged), "corrupt")
    reject(b"PK\x03\x04" + sdf_bytes[4:], "corrupt")  # not an .nfc file at all


def test_other_major_is_unsupported_version(sdf_bytes: bytes) -> None:
    for major in (0, 2, 255):
        reject(patch_header(sdf_bytes, major=major), "unsupported_version")


def test_reserved_flags_and_bad_file_sizes_are_corrupt(sdf_bytes: bytes) -> None:
    reject(patch_header(sdf_bytes, flags=1), "corrupt")
    reject(patch_header(sdf_bytes, file_size=20)[:20], "corrupt")  # below header + one chunk
    reject(patch_header(sdf_bytes, file_size=64 * 1024 * 1024 + 1), "corrupt")
    reject(patch_header(sdf_bytes, file_size=len(sdf_bytes) + 1), "truncated")


def test_newer_minor_with_unknown_optional_chunk_decodes(sdf_bytes: bytes) -> None:
    f = random_file()
    data = file_with([geom_chunk(f), encode_chunk("futr", b"future feature"), encode_chunk("zzzz", b"")],
                     minor=3)
    decoded = read_nfc(data)
    assert decoded.minor == 3 and decoded.skipped_chunks == ["futr", "zzzz"]
    assert decoded.geometry.network.out_features == f.geometry.network.out_features


def test_damaged_optional_chunk_is_still_verified() -> None:
    data = bytearray(file_with([geom_chunk(random_file()), encode_chunk("futr", b"abc")]))
    data[-5] ^= 0x10  # inside the optional payload
    reject(bytes(data), "corrupt")


def test_unknown_critical_chunk_is_unsupported_feature() -> None:
    reject(file_with([geom_chunk(random_file()), encode_chunk("COLR", b"x")], minor=1), "unsupported_feature")


@pytest.mark.parametrize(
    "chunks",
    [
        ["futr", "GEOM"],  # GEOM not first
        ["GEOM", "GEOM"],  # duplicate
        ["GEOM", "futr", "futr"],  # duplicate optional chunk
        ["GEOM", "c0lr"],  # not four letters
    ],
)
def test_chunk_order_and_tags(chunks: list[str]) -> None:
    geom = geom_chunk(random_file())
    reject(file_with([geom if t == TAG_GEOM else encode_chunk(t, b"") for t in chunks]), "corrupt")


def test_chunk_length_beyond_the_file() -> None:
    geom = bytearray(geom_chunk(random_file()))
    struct.pack_into("<I", geom, 4, len(geom))  # claims more payload than the file holds
    reject(file_with([bytes(geom)]), "truncated")
    struct.pack_into("<I", geom, 4, 16 * 1024 * 1024 + 1)
    reject(file_with([bytes(geom)]), "corrupt")


def _bad(field: str, value, target: str = "network") -> NfcFile:
    f = random_file()
    if target == "network":
        net = dataclasses.replace(f.geometry.network, **{field: value})
        return dataclasses.replace(f, geometry=dataclasses.replace(f.geometry, network=net))
    return dataclasses.replace(f, geometry=dataclasses.replace(f.geometry, **{field: value}))


INVALID_VALUES = [
    ("field_type", 2, "geometry"),
    ("truncation", 0.0, "geometry"),
    ("truncation", 1.5, "geometry"),
    ("truncation", math.nan, "geometry"),
    ("center", (0.0, math.inf, 0.0), "geometry"),
    ("scale", 0.0, "geometry"),
    ("scale", -1.0, "geometry"),
    ("scale", math.nan, "geometry"),
    ("frequency_base", 0.5, "network"),
    ("frequency_base", 2.5, "network"),
    ("frequency_base", math.nan, "network"),
    ("omega0", 0.0, "network"),
    ("omega0", 1001.0, "network"),
    ("omega0", math.inf, "network"),
    ("output", OUTPUT_ABS, "network"),  # abs output on an SDF
    ("output", OUTPUT_SIGMOID, "network"),
    ("output", 3, "network"),
    ("bits", 1, "network"),
    ("bits", 17, "network"),
    ("steps", [(0.0, 0.01)] * 3, "network"),
    ("steps", [(0.01, -0.01)] * 3, "network"),
    ("steps", [(0.01, math.nan)] * 3, "network"),
]


@pytest.mark.parametrize("field,value,target", INVALID_VALUES)
def test_invalid_values_are_corrupt_and_unwritable(field: str, value, target: str) -> None:
    f = _bad(field, value, target)
    reject(file_with([geom_chunk(f, check=False)]), "corrupt")
    with pytest.raises(ValueError):
        write_nfc(f)


@pytest.mark.parametrize(
    "frequencies,widths",
    [
        (MAX_FREQUENCIES + 1, (4, 1)),
        (2, (MAX_WIDTH + 1, 1)),
        (2, (0, 1)),
        (2, (4,) * MAX_LAYERS + (1,)),  # MAX_LAYERS + 1 layers
        (2, (1,)),  # a single layer
        (2, (4, 2)),  # geometry must have one output
        (2, (MAX_WIDTH,) * 5 + (1,)),  # more than MAX_PARAMETERS
    ],
)
def test_caps_are_enforced(frequencies: int, widths: tuple[int, ...]) -> None:
    net = random_network(num_frequencies=0, widths=(4, 1))
    net.num_frequencies, net.out_features = frequencies, list(widths)
    net.steps = [(0.01, 0.01)] * len(widths)
    net.levels = [(np.zeros((1, 1), dtype=np.int64), np.zeros(1, dtype=np.int64))]  # never decompressed
    f = NfcFile(GeometryChunk(FIELD_SDF, 0.1, (0.0, 0.0, 0.0), 1.0, net))
    reject(file_with([geom_chunk(f, check=False)]), "corrupt")
    with pytest.raises(ValueError):
        write_nfc(f)


def test_parameter_cap_value() -> None:
    assert parameter_count(2, [MAX_WIDTH] * 5 + [1]) > MAX_PARAMETERS


@pytest.mark.parametrize("bits,level", [(8, 128), (8, -128), (4, 8), (16, -32768), (12, 2048)])
def test_levels_outside_the_grid(bits: int, level: int) -> None:
    f = random_file(bits=bits)
    f.geometry.network.levels[1][0][0, 0] = level
    reject(file_with([geom_chunk(f, check=False)]), "corrupt")
    with pytest.raises(ValueError):
        write_nfc(f)


def test_payload_of_the_wrong_size_is_corrupt() -> None:
    for delta in (-1, 1):
        f = random_file()
        w, b = f.geometry.network.levels[-1]
        f.geometry.network.levels[-1] = (w, np.zeros(len(b) + delta, dtype=np.int64))
        reject(file_with([geom_chunk(f, check=False)]), "corrupt")
        with pytest.raises(ValueError):
            write_nfc(f)


def _levels_stream(f: NfcFile) -> bytes:
    flat = np.concatenate([np.concatenate([w.ravel(), b]) for w, b in f.geometry.network.levels])
    return brotli.compress(flat.astype(np.int8).tobytes(), quality=11)


def test_invalid_brotli_and_decompression_bomb_are_corrupt() -> None:
    f = random_file()
    payload = geometry_payload(f.geometry)
    stream = _levels_stream(f)
    assert payload.endswith(stream)  # FORMAT.md: the brotli stream runs to the end of the chunk
    head = payload[: -len(stream)]
    for tail in (b"\xff" * len(stream), stream[:-1], stream + b"\x00", brotli.compress(bytes(20_000_000), quality=1)):
        reject(file_with([encode_chunk(TAG_GEOM, head + tail)]), "corrupt")
    reject(file_with([encode_chunk(TAG_GEOM, head)]), "truncated")  # no payload at all


def test_writer_refuses_other_major() -> None:
    with pytest.raises(ValueError):
        write_nfc(dataclasses.replace(random_file(), major=2))


def test_format_error_has_a_kind_and_one_line() -> None:
    err = reject(b"", "truncated")
    assert "\n" not in str(err) and str(err).startswith("truncated .nfc file")
    with pytest.raises(ValueError):
        FormatError("broken", "x")
    assert HEADER_SIZE == 16


# ---------------------------------------------------------------------------------------------
# The colour chunk (FORMAT.md 1.1, `colr`)

VECTORS = Path(__file__).resolve().parents[1] / "vectors"


def color_chunk(f: NfcFile, check: bool = True) -> bytes:
    assert f.color is not None
    return encode_chunk(TAG_COLOR, color_payload(f.color, check=check))


def test_color_round_trip_is_version_1_1() -> None:
    original = random_color_file()
    data = write_nfc(original)
    assert (data[4], data[5]) == (1, 1)
    geometry_only = write_nfc(dataclasses.replace(original, color=None))
    assert data[16:].startswith(geometry_only[16:])  # GEOM first, then colr
    assert data[len(geometry_only):len(geometry_only) + 4] == b"colr"
    decoded = read_nfc(data)
    assert (decoded.major, decoded.minor, decoded.skipped_chunks) == (1, 1, [])
    assert decoded.color is not None and original.color is not None
    assert decoded.color.color_space == COLOR_SPACE_RGB
    n, m = original.color.network, decoded.color.network
    assert (m.num_frequencies, m.output, m.bits, m.out_features) == (3, OUTPUT_SIGMOID, 8, [8, 8, 3])
    assert m.steps == [(f32(a), f32(b)) for a, b in n.steps]
    for (w0, b0), (w1, b1) in zip(n.levels, m.levels):
        np.testing.assert_array_equal(w0, w1)
        np.testing.assert_array_equal(b0, b1)
    assert write_nfc(decoded) == data


def test_minor_follows_the_content_not_the_field() -> None:
    f = random_color_file()
    assert write_nfc(dataclasses.replace(f, minor=0))[5] == 1
    assert write_nfc(dataclasses.replace(f, color=None, minor=3))[5] == 0


def test_golden_1_0_file_reads_unchanged_and_rewrites_byte_identically() -> None:
    for path in sorted(VECTORS.glob("v1_0_*.nfc")):
        data = path.read_bytes()
        decoded = read_nfc(data)
        assert (decoded.minor, decoded.color, decoded.skipped_chunks) == (0, None, []), path.name
        assert write_nfc(decoded) == data, path.name


def _bad_color(field: str, value) -> NfcFile:
    f = random_color_file()
    assert f.color is not None
    if field == "color_space":
        return dataclasses.replace(f, color=dataclasses.replace(f.color, color_space=value))
    return dataclasses.replace(f, color=dataclasses.replace(f.color, network=dataclasses.replace(f.color.network,
                                                                                              **{field: value})))


@pytest.mark.parametrize(
    "field,value",
    [("color_space", 1), ("color_space", 255), ("output", OUTPUT_IDENTITY), ("output", OUTPUT_ABS), ("output", 3),
     ("bits", 1), ("omega0", 0.0), ("steps", [(0.01, 0.0)] * 3)],
)
def test_invalid_color_values_are_corrupt_and_unwritable(field: str, value) -> None:
    f = _bad_color(field, value)
    reject(file_with([geom_chunk(f), color_chunk(f, check=False)], minor=1), "corrupt")
    with pytest.raises(ValueError):
        write_nfc(f)


@pytest.mark.parametrize("widths", [(8, 8, 1), (8, 8, 4), (8, 2)])
def test_color_network_must_have_three_outputs(widths: tuple[int, ...]) -> None:
    f = random_color_file(widths=widths)
    err = reject(file_with([geom_chunk(f), color_chunk(f, check=False)], minor=1), "corrupt")
    assert "colour network" in err.detail and "must be 3" in err.detail
    with pytest.raises(ValueError):
        write_nfc(f)


def test_color_caps_are_enforced() -> None:
    f = random_color_file()
    assert f.color is not None
    f.color.network.out_features = [MAX_WIDTH + 1, 8, 3]
    reject(file_with([geom_chunk(f), color_chunk(f, check=False)], minor=1), "corrupt")


def test_truncation_inside_the_color_chunk() -> None:
    f = random_color_file()
    payload = color_payload(f.color)  # type: ignore[arg-type]
    head = 1 + 12 + 2 * 3 + 8 * 3  # colour space, network scalars, 3 widths, 3 step pairs
    geom = geom_chunk(f)
    for cut in (0, 1, 5, 12, 20, head):  # CRC-consistent chunks whose structure ends early
        reject(file_with([geom, encode_chunk(TAG_COLOR, payload[:cut])], minor=1), "truncated")
    data = write_nfc(f)
    for n in range(len(write_nfc(dataclasses.replace(f, color=None))), len(data)):
        reject(data[:n], "truncated")


def test_color_payload_of_the_wrong_size_is_corrupt() -> None:
    f = random_color_file()
    payload = color_payload(f.color)  # type: ignore[arg-type]
    reject(file_with([geom_chunk(f), encode_chunk(TAG_COLOR, payload[:-1])], minor=1), "corrupt")  # brotli cut


def test_color_crc_and_every_byte_of_the_chunk_are_verified() -> None:
    f = random_color_file()
    data = write_nfc(f)
    start = len(write_nfc(dataclasses.replace(f, color=None)))
    damaged = bytearray(data)
    damaged[-1] ^= 0x01  # the stored CRC
    reject(bytes(damaged), "corrupt")
    for i in range(start, len(data)):
        damaged = bytearray(data)
        damaged[i] ^= 0x80
        reject(bytes(damaged))


def test_color_chunk_order() -> None:
    f = random_color_file()
    reject(file_with([color_chunk(f), geom_chunk(f)], minor=1), "corrupt")  # GEOM not first
    reject(file_with([geom_chunk(f), color_chunk(f), color_chunk(f)], minor=1), "corrupt")  # duplicate


# ---- the 64-bit frame (1.2) -------------------------------------------------------------------

FAR_CENTER = (600123.4567891, 200654.3219876, -12.25)  # UTM-like metres, not representable in f32


def geo_file(with_color: bool = False) -> NfcFile:
    f = random_color_file() if with_color else random_file()
    f.geometry.center = tuple(f32(c) for c in FAR_CENTER)  # type: ignore[assignment]
    f.geometry.scale = 12.5
    f.geometry.frame64 = Frame64(FAR_CENTER, 12.5)
    return f


def frame_chunk(center: tuple[float, ...], scale: float, extra: bytes = b"") -> bytes:
    return encode_chunk(TAG_FRAME64, struct.pack("<4d", *center, scale) + extra)


def test_frame64_round_trip_is_version_1_2_with_fram_after_geom() -> None:
    for with_color in (False, True):
        data = write_nfc(geo_file(with_color))
        assert (data[4], data[5]) == (1, 2)
        decoded = read_nfc(data)
        assert decoded.minor == 2 and decoded.geometry.frame64 == Frame64(FAR_CENTER, 12.5)
        assert list(decoded.chunk_bytes) == ["GEOM", "fram"] + (["colr"] if with_color else [])
        assert decoded.chunk_bytes["fram"] == 12 + 32
        assert write_nfc(decoded) == data


def test_frame64_rules_are_corrupt_and_unwritable() -> None:
    f = geo_file()
    geom = geom_chunk(f)
    assert read_nfc(file_with([geom, frame_chunk(FAR_CENTER, 12.5)], minor=2)).geometry.frame64 is not None
    nudged = (FAR_CENTER[0], float(np.nextafter(np.float32(FAR_CENTER[1]), np.float32(0))) - 1.0, FAR_CENTER[2])
    for center, scale in [(nudged, 12.5), (FAR_CENTER, 12.6), (FAR_CENTER, 0.0), (FAR_CENTER, -12.5),
                          (FAR_CENTER, math.nan), ((math.inf, 0.0, 0.0), 12.5), ((FAR_CENTER[0], math.nan, 0.0), 12.5)]:
        reject(file_with([geom, frame_chunk(center, scale)], minor=2), "corrupt")
        bad = geo_file()
        bad.geometry.frame64 = Frame64(center, scale)  # type: ignore[arg-type]
        with pytest.raises(ValueError):
            write_nfc(bad)
    reject(file_with([geom, encode_chunk(TAG_FRAME64, struct.pack("<4d", *FAR_CENTER, 12.5)[:31])], minor=2),
           "truncated")
    reject(file_with([geom, frame_chunk(FAR_CENTER, 12.5, b"\0")], minor=2), "corrupt")


def test_frame64_only_directly_after_geom_and_once() -> None:
    f = geo_file(with_color=True)
    geom, frame, colr = geom_chunk(f), frame_chunk(FAR_CENTER, 12.5), color_chunk(f)
    assert read_nfc(file_with([geom, frame, colr], minor=2)).color is not None
    reject(file_with([geom, colr, frame], minor=2), "corrupt")
    reject(file_with([geom, frame, frame], minor=2), "corrupt")
    reject(file_with([frame, geom], minor=2), "corrupt")  # GEOM first


def test_frame64_file_corruption_and_truncation_are_rejected() -> None:
    data = write_nfc(geo_file())
    for n in range(len(data)):
        reject(data[:n])
    for i in range(len(data)):
        damaged = bytearray(data)
        damaged[i] ^= 0x10
        reject(bytes(damaged))


@pytest.mark.parametrize("center,scale", [((3e38, 0.0, 0.0), 3e38), ((0.0, 0.0, -(2.0**126)), 2.0**100)])
def test_frames_whose_positions_overflow_f32_are_corrupt_and_unwritable(center, scale) -> None:
    f = random_file()
    f.geometry.center, f.geometry.scale = center, scale
    with pytest.raises(ValueError):
        write_nfc(f)
    reject(file_with([geom_chunk(f, check=False)]), "corrupt")
    f.geometry.center, f.geometry.scale = (0.0, 0.0, 0.0), 2.0**126  # at the cap
    assert read_nfc(write_nfc(f)).geometry.scale == 2.0**126
