"""The `.nfc` bitstream: writer and verifying reader of libnfdecode/FORMAT.md, version 1.2.

This is the only Python module that knows the byte layout. The reader treats its input as untrusted:
every rule and cap of FORMAT.md is checked, every failure is a `FormatError` with FORMAT.md's error
kind, and nothing is allocated beyond what the caps allow (the brotli payload is decompressed with an
output limit). The writer applies the same rules, so it cannot produce a file the reader rejects.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field

import brotli
import numpy as np

from .errors import FormatError

MAGIC = b"\x89NFC"
FORMAT_MAJOR = 1
FORMAT_MINOR = 0  # what a geometry-only file is written as: byte for byte a 1.0 file
COLOR_MINOR = 1  # a file with a `colr` chunk
FRAME64_MINOR = 2  # a file with a `fram` chunk (64-bit frame)
HEADER_SIZE = 16
CHUNK_OVERHEAD = 12  # tag, length, crc
TAG_GEOM = "GEOM"
TAG_COLOR = "colr"
TAG_FRAME64 = "fram"
FRAME64_PAYLOAD_SIZE = 32  # f64 center[3], f64 scale

# Hard caps of version 1 (FORMAT.md, "Hard caps").
MAX_FILE_SIZE = 64 * 1024 * 1024
MAX_CHUNK_SIZE = 16 * 1024 * 1024
MAX_FREQUENCIES = 24
MAX_LAYERS = 8
MAX_WIDTH = 512
MAX_PARAMETERS = 1024 * 1024
MAX_FRAME_EXTENT = 2.0**126  # max |center| + scale: decoded f32 positions stay finite
MIN_LAYERS = 2
MIN_BITS = 2
MAX_BITS = 16
MIN_FREQUENCY_BASE, MAX_FREQUENCY_BASE = 1.0, 2.0

FIELD_SDF = 0
FIELD_UDF = 1
FIELD_NAMES = {FIELD_SDF: "sdf", FIELD_UDF: "udf"}

OUTPUT_IDENTITY = 0
OUTPUT_ABS = 1
OUTPUT_SIGMOID = 2
OUTPUT_NAMES = {OUTPUT_IDENTITY: "identity", OUTPUT_ABS: "abs", OUTPUT_SIGMOID: "sigmoid"}
GEOM_OUTPUT_FOR_FIELD = {FIELD_SDF: OUTPUT_IDENTITY, FIELD_UDF: OUTPUT_ABS}

COLOR_SPACE_RGB = 0  # the input's RGB divided by 255, no transfer function (FORMAT.md, `colr`)
COLOR_SPACE_NAMES = {COLOR_SPACE_RGB: "rgb"}
COLOR_OUTPUT = OUTPUT_SIGMOID
COLOR_CHANNELS = 3

BROTLI_QUALITY = 11

# FORMAT.md step 1 fixes pi by its bit pattern; Python's math.pi is that double.
_PI_BITS = 0x400921FB54442D18
assert struct.unpack("<d", struct.pack("<Q", _PI_BITS))[0] == math.pi


@dataclass
class NetworkBlock:
    """A quantized SIREN: positional encoding, sine hidden layers, one linear output layer."""

    num_frequencies: int
    frequency_base: float
    omega0: float
    output: int  # OUTPUT_IDENTITY, OUTPUT_ABS or OUTPUT_SIGMOID
    bits: int
    out_features: list[int]
    steps: list[tuple[float, float]]  # per layer (weight_step, bias_step)
    levels: list[tuple[np.ndarray, np.ndarray]]  # per layer (W (out, in), b (out,)) integer levels

    @property
    def in_features(self) -> list[int]:
        return layer_inputs(self.num_frequencies, self.out_features)

    @property
    def parameter_count(self) -> int:
        return parameter_count(self.num_frequencies, self.out_features)


@dataclass
class Frame64:
    """The `fram` chunk: the frame in f64 (original = unit * scale + center, exactly)."""

    center: tuple[float, float, float]
    scale: float


@dataclass
class GeometryChunk:
    field_type: int  # FIELD_SDF or FIELD_UDF
    truncation: float
    center: tuple[float, float, float]  # f32 values; with frame64, its center rounded to f32
    scale: float
    network: NetworkBlock
    frame64: Frame64 | None = None  # written as the `fram` chunk after GEOM (format 1.2)


@dataclass
class ColorChunk:
    color_space: int  # COLOR_SPACE_RGB
    network: NetworkBlock  # sigmoid output, 3 channels (red, green, blue in [0, 1])


@dataclass
class NfcFile:
    """A parsed file. `major` and `minor` are the version the reader found; the writer writes the
    version the content needs (1.2 with a 64-bit frame, 1.1 with a colour chunk, else 1.0),
    whatever they say."""

    geometry: GeometryChunk
    major: int = FORMAT_MAJOR
    minor: int = FORMAT_MINOR
    skipped_chunks: list[str] = field(default_factory=list)  # optional tags a reader skipped
    color: ColorChunk | None = None
    chunk_bytes: dict[str, int] = field(default_factory=dict)  # reader: each chunk's size, framing included


def layer_inputs(num_frequencies: int, out_features: list[int]) -> list[int]:
    """in_features of every layer: 3 + 6L for the first, the previous width after that."""
    return [3 + 6 * num_frequencies] + list(out_features[:-1])


def parameter_count(num_frequencies: int, out_features: list[int]) -> int:
    return sum(i * o + o for i, o in zip(layer_inputs(num_frequencies, out_features), out_features))


def max_level(bits: int) -> int:
    """Largest |q| of the symmetric b-bit grid: its 2^b - 1 levels fit in b bits."""
    return (1 << (bits - 1)) - 1


def positional_frequencies(num_frequencies: int, base: float) -> np.ndarray:
    """f[k] of FORMAT.md step 1: pi * beta^k by repeated f64 multiplication, each rounded to f32.

    `base` is first rounded to f32, as it is stored in the file, so callers may pass 1.4 directly.
    """
    beta = float(np.float32(base))
    a = math.pi
    out = np.empty(num_frequencies, dtype=np.float32)
    for k in range(num_frequencies):
        out[k] = np.float32(a)
        a = a * beta
    return out


def crc32(data: bytes | memoryview) -> int:
    """CRC-32/ISO-HDLC, the zlib polynomial, as FORMAT.md specifies."""
    return zlib.crc32(data) & 0xFFFFFFFF


def _f32(x: float) -> float:
    """x rounded to binary32 (inf when it overflows), as a Python float."""
    with np.errstate(over="ignore"):
        return float(np.float32(x))


def _corrupt(message: str) -> FormatError:
    return FormatError("corrupt", message)


# --------------------------------------------------------------------------------------------
# Rules shared by the reader and the writer. They see values already rounded to f32.
# --------------------------------------------------------------------------------------------


def _check_field_type(field_type: int) -> None:
    if field_type not in FIELD_NAMES:
        raise _corrupt(f"unknown field type {field_type}")


def _check_truncation(truncation: float) -> None:
    if not (math.isfinite(truncation) and 0.0 < truncation <= 1.0):
        raise _corrupt(f"truncation {truncation} outside (0, 1]")


def _check_center_coordinate(c: float) -> None:
    if not math.isfinite(c):
        raise _corrupt("non-finite frame center")


def _check_scale(scale: float) -> None:
    if not (math.isfinite(scale) and scale > 0.0):
        raise _corrupt(f"frame scale {scale} is not a finite positive number")


def _check_frame_extent(center: tuple[float, ...] | list[float], scale: float) -> None:
    extent = max(abs(c) for c in center) + scale
    if not extent <= MAX_FRAME_EXTENT:
        raise _corrupt(f"frame extent {extent:.3g} (|center| + scale) exceeds {MAX_FRAME_EXTENT:.3g}")


def _check_frequencies(num_frequencies: int) -> None:
    if not 0 <= num_frequencies <= MAX_FREQUENCIES:
        raise _corrupt(f"{num_frequencies} frequencies (at most {MAX_FREQUENCIES})")


def frequency_base_in_range(frequency_base: float) -> bool:
    """β finite and within [MIN_FREQUENCY_BASE, MAX_FREQUENCY_BASE] (FORMAT.md, network block)."""
    return math.isfinite(frequency_base) and MIN_FREQUENCY_BASE <= frequency_base <= MAX_FREQUENCY_BASE


def _check_frequency_base(frequency_base: float) -> None:
    if not frequency_base_in_range(frequency_base):
        raise _corrupt(f"frequency base {frequency_base} outside [1, 2]")


def _check_omega0(omega0: float) -> None:
    if not (math.isfinite(omega0) and 0.0 < omega0 <= 1000.0):
        raise _corrupt(f"omega0 {omega0} outside (0, 1000]")


@dataclass(frozen=True)
class _Role:
    """What a chunk requires of its network block: the output activation and the output count."""

    chunk: str  # "geometry" or "colour", for messages
    output: int
    outputs: int
    output_reason: str  # why that activation, for messages


def _geometry_role(field_type: int) -> _Role:
    """GEOM's rule: the activation that matches the field type (identity for SDF, abs for UDF)."""
    return _Role("geometry", GEOM_OUTPUT_FOR_FIELD[field_type], 1, f"field type {FIELD_NAMES[field_type]}")


COLOR_ROLE = _Role("colour", COLOR_OUTPUT, COLOR_CHANNELS, "a colour network")


def _check_output(output: int, role: _Role) -> None:
    if output != role.output:
        raise _corrupt(f"output activation {OUTPUT_NAMES.get(output, output)} does not match {role.output_reason}")


def _check_bits(bits: int) -> None:
    if not MIN_BITS <= bits <= MAX_BITS:
        raise _corrupt(f"bit width {bits} outside [{MIN_BITS}, {MAX_BITS}]")


def _check_layer_count(num_layers: int) -> None:
    if not MIN_LAYERS <= num_layers <= MAX_LAYERS:
        raise _corrupt(f"{num_layers} layers (must be {MIN_LAYERS}..{MAX_LAYERS})")


def _check_width(width: int) -> None:
    if not 1 <= width <= MAX_WIDTH:
        raise _corrupt(f"layer width {width} outside [1, {MAX_WIDTH}]")


def _check_network_outputs(out_features: list[int], role: _Role) -> None:
    if out_features[-1] != role.outputs:
        raise _corrupt(f"{role.chunk} network has {out_features[-1]} outputs (must be {role.outputs})")


def _check_color_space(color_space: int) -> None:
    if color_space not in COLOR_SPACE_NAMES:
        raise _corrupt(f"unknown colour space {color_space}")


def _check_step(step: float) -> None:
    if not (math.isfinite(step) and step > 0.0):
        raise _corrupt(f"quantization step {step} is not a finite positive number")


def _check_parameter_count(num_frequencies: int, out_features: list[int]) -> None:
    count = parameter_count(num_frequencies, out_features)
    if count > MAX_PARAMETERS:
        raise _corrupt(f"{count} parameters (at most {MAX_PARAMETERS})")


def _check_geometry(g: GeometryChunk) -> None:
    """Every rule of FORMAT.md on a GEOM chunk, in the order the reader meets them in the bytes."""
    _check_field_type(g.field_type)
    _check_truncation(g.truncation)
    if len(g.center) != 3:
        raise _corrupt("frame center must have 3 coordinates")
    for c in g.center:
        _check_center_coordinate(c)
    _check_scale(g.scale)
    _check_frame_extent(g.center, g.scale)
    _check_network(g.network, _geometry_role(g.field_type))


def _check_network(net: NetworkBlock, role: _Role) -> None:
    """Every rule of FORMAT.md on a network block, in byte order."""
    _check_frequencies(net.num_frequencies)
    _check_frequency_base(net.frequency_base)
    _check_omega0(net.omega0)
    _check_output(net.output, role)
    _check_bits(net.bits)
    _check_layer_count(len(net.out_features))
    for w in net.out_features:
        _check_width(w)
    _check_network_outputs(net.out_features, role)
    if len(net.steps) != len(net.out_features):
        raise _corrupt(f"{len(net.steps)} step pairs for {len(net.out_features)} layers")
    for pair in net.steps:
        for step in pair:
            _check_step(step)
    _check_parameter_count(net.num_frequencies, net.out_features)


def _check_levels(flat: np.ndarray, bits: int) -> None:
    limit = max_level(bits)
    if flat.size and int(np.abs(flat.astype(np.int64)).max()) > limit:
        raise _corrupt(f"a quantization level exceeds +-{limit}, the {bits}-bit symmetric grid")


# --------------------------------------------------------------------------------------------
# Writer
# --------------------------------------------------------------------------------------------


def _level_dtype(bits: int) -> str:
    return "<i1" if bits <= 8 else "<i2"


def _network_bytes(net: NetworkBlock, check: bool) -> bytes:
    inputs = net.in_features
    parts: list[np.ndarray] = []
    if check and len(net.levels) != len(net.out_features):
        raise _corrupt(f"{len(net.levels)} level pairs for {len(net.out_features)} layers")
    for i, (weights, bias) in enumerate(net.levels):
        weights = np.asarray(weights)
        bias = np.asarray(bias)
        if check and (weights.shape != (net.out_features[i], inputs[i]) or bias.shape != (net.out_features[i],)):
            raise _corrupt(
                f"layer {i} levels have shapes {weights.shape} and {bias.shape}, "
                f"expected ({net.out_features[i]}, {inputs[i]}) and ({net.out_features[i]},)"
            )
        for array in (weights, bias):
            if check and not np.issubdtype(array.dtype, np.integer):
                raise _corrupt(f"layer {i} levels are {array.dtype}, not integers")
            parts.append(array.reshape(-1).astype(np.int64))
    flat = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    if check:
        _check_levels(flat, net.bits)
    raw = flat.astype(_level_dtype(net.bits)).tobytes()
    head = struct.pack(
        "<BffBBB", net.num_frequencies, net.frequency_base, net.omega0, net.output, net.bits, len(net.out_features)
    )
    head += struct.pack(f"<{len(net.out_features)}H", *net.out_features)
    head += struct.pack(f"<{2 * len(net.steps)}f", *(s for pair in net.steps for s in pair))
    return head + brotli.compress(raw, quality=BROTLI_QUALITY)


def _rounded_network(net: NetworkBlock) -> NetworkBlock:
    return NetworkBlock(
        num_frequencies=int(net.num_frequencies),
        frequency_base=_f32(net.frequency_base),
        omega0=_f32(net.omega0),
        output=int(net.output),
        bits=int(net.bits),
        out_features=[int(w) for w in net.out_features],
        steps=[(_f32(ws), _f32(bs)) for ws, bs in net.steps],
        levels=net.levels,
    )


def geometry_payload(g: GeometryChunk, check: bool = True) -> bytes:
    """The GEOM chunk payload. With check=False nothing is validated (levels wrap to the stored
    integer width): only tests use that, to build files a reader must reject."""
    rounded = GeometryChunk(
        field_type=int(g.field_type),
        truncation=_f32(g.truncation),
        center=tuple(_f32(c) for c in g.center),  # type: ignore[arg-type]
        scale=_f32(g.scale),
        network=_rounded_network(g.network),
    )
    if check:
        _check_geometry(rounded)
    head = struct.pack("<Bf3ff", rounded.field_type, rounded.truncation, *rounded.center, rounded.scale)
    return head + _network_bytes(rounded.network, check)


def color_payload(c: ColorChunk, check: bool = True) -> bytes:
    """The `colr` chunk payload; check=False as for geometry_payload."""
    network = _rounded_network(c.network)
    if check:
        _check_color_space(int(c.color_space))
        _check_network(network, COLOR_ROLE)
    return struct.pack("<B", int(c.color_space)) + _network_bytes(network, check)


def required_minor(f: NfcFile) -> int:
    """The minor version the content of `f` needs: the newest of its chunks' (FORMAT.md)."""
    if f.geometry.frame64 is not None:
        return FRAME64_MINOR
    return COLOR_MINOR if f.color is not None else FORMAT_MINOR


def _check_frame64_center(c64: float, c32: float) -> None:
    """FORMAT.md `fram`: finite, and GEOM holding it rounded to f32."""
    if not math.isfinite(c64) or _f32(c64) != c32:
        raise _corrupt(f"64-bit frame center {c64!r} does not round to GEOM's {c32!r}")


def _check_frame64_scale(s64: float, s32: float) -> None:
    if not (math.isfinite(s64) and s64 > 0.0) or _f32(s64) != s32:
        raise _corrupt(f"64-bit frame scale {s64!r} does not round to GEOM's {s32!r}")


def _check_frame64(frame: Frame64, g: GeometryChunk) -> None:
    for c64, c32 in zip(frame.center, g.center):
        _check_frame64_center(c64, c32)
    _check_frame64_scale(frame.scale, g.scale)


def frame64_payload(g: GeometryChunk) -> bytes:
    """The `fram` chunk payload of a geometry with a 64-bit frame."""
    assert g.frame64 is not None
    rounded = GeometryChunk(g.field_type, g.truncation, tuple(_f32(c) for c in g.center),  # type: ignore[arg-type]
                            _f32(g.scale), g.network)
    _check_frame64(g.frame64, rounded)
    return struct.pack("<4d", *g.frame64.center, g.frame64.scale)


def encode_chunk(tag: str, payload: bytes) -> bytes:
    """One chunk: tag, length, payload, CRC-32 of all three."""
    body = tag.encode("ascii") + struct.pack("<I", len(payload)) + payload
    return body + struct.pack("<I", crc32(body))


def assemble(chunks: list[bytes], major: int = FORMAT_MAJOR, minor: int = FORMAT_MINOR) -> bytes:
    """File header (with the total size and its CRC) followed by already encoded chunks."""
    body = b"".join(chunks)
    head = MAGIC + struct.pack("<BBHI", major, minor, 0, HEADER_SIZE + len(body))
    return head + struct.pack("<I", crc32(head)) + body


def write_nfc(f: NfcFile) -> bytes:
    """Serialise `f`: GEOM, then `fram` when the geometry has a 64-bit frame, then `colr` when
    `f.color` is set, at version 1.required_minor(f).
    Raises ValueError for values FORMAT.md forbids (the reader would reject them)."""
    if f.major != FORMAT_MAJOR:
        raise ValueError(f"cannot write .nfc version {f.major}.{f.minor}: this writer writes {FORMAT_MAJOR}.x")
    try:
        payloads = [(TAG_GEOM, geometry_payload(f.geometry))]
        if f.geometry.frame64 is not None:
            payloads.append((TAG_FRAME64, frame64_payload(f.geometry)))
        if f.color is not None:
            payloads.append((TAG_COLOR, color_payload(f.color)))
    except FormatError as e:
        raise ValueError(f"cannot write .nfc: {e.detail}") from None
    for tag, payload in payloads:
        if len(payload) > MAX_CHUNK_SIZE:
            raise ValueError(f"cannot write .nfc: {tag} chunk of {len(payload)} bytes exceeds {MAX_CHUNK_SIZE}")
    return assemble([encode_chunk(tag, payload) for tag, payload in payloads], FORMAT_MAJOR, required_minor(f))


# --------------------------------------------------------------------------------------------
# Reader
# --------------------------------------------------------------------------------------------


class _Cursor:
    """Reads little-endian values from data[pos:end]; running past `end` is *truncated*."""

    def __init__(self, data: memoryview, pos: int, end: int, what: str) -> None:
        self.data, self.pos, self.end, self.what = data, pos, end, what

    def take(self, n: int) -> memoryview:
        if self.end - self.pos < n:
            raise FormatError("truncated", f"{self.what} ends {n - (self.end - self.pos)} bytes early")
        view = self.data[self.pos : self.pos + n]
        self.pos += n
        return view

    def unpack(self, fmt: str) -> tuple:
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def remaining(self) -> int:
        return self.end - self.pos


def _read_levels(payload: memoryview, net_bits: int, count: int) -> np.ndarray:
    size = count * (1 if net_bits <= 8 else 2)
    decompressor = brotli.Decompressor()
    try:
        # The output limit bounds memory even for a decompression bomb; one byte more than expected
        # is enough to see that a stream is too long.
        raw = decompressor.process(bytes(payload), output_buffer_limit=size + 1)
    except brotli.error:
        raise _corrupt("invalid brotli payload") from None
    if len(raw) != size or not decompressor.is_finished():
        raise _corrupt(f"brotli payload does not decompress to exactly {size} bytes")
    flat = np.frombuffer(raw, dtype=_level_dtype(net_bits)).astype(np.int32)
    _check_levels(flat, net_bits)
    return flat


def _read_network(cur: _Cursor, role: _Role) -> NetworkBlock:
    """A network block (GEOM's or colr's). Each value is checked as soon as it is read, like
    libnfdecode does, so that both readers report the same error kind for the same bytes."""
    (num_frequencies,) = cur.unpack("B")
    _check_frequencies(num_frequencies)
    (frequency_base,) = cur.unpack("f")
    _check_frequency_base(frequency_base)
    (omega0,) = cur.unpack("f")
    _check_omega0(omega0)
    (output,) = cur.unpack("B")
    _check_output(output, role)
    (bits,) = cur.unpack("B")
    _check_bits(bits)
    (num_layers,) = cur.unpack("B")
    _check_layer_count(num_layers)
    out_features = []
    for _ in range(num_layers):
        (width,) = cur.unpack("H")
        _check_width(width)
        out_features.append(width)
    _check_network_outputs(out_features, role)
    flat_steps = []
    for _ in range(2 * num_layers):
        (step,) = cur.unpack("f")
        _check_step(step)
        flat_steps.append(step)
    steps = [(flat_steps[2 * i], flat_steps[2 * i + 1]) for i in range(num_layers)]
    _check_parameter_count(num_frequencies, out_features)
    # The caps now bound every size: decompress.
    if cur.remaining() < 1:
        raise FormatError("truncated", "network block has no payload")
    inputs = layer_inputs(num_frequencies, out_features)
    flat = _read_levels(cur.take(cur.remaining()), bits, parameter_count(num_frequencies, out_features))
    levels: list[tuple[np.ndarray, np.ndarray]] = []
    at = 0
    for n_in, n_out in zip(inputs, out_features):
        weights = flat[at : at + n_in * n_out].reshape(n_out, n_in)
        at += n_in * n_out
        bias = flat[at : at + n_out]
        at += n_out
        levels.append((weights, bias))
    return NetworkBlock(num_frequencies, frequency_base, omega0, output, bits, out_features, steps, levels)


def _read_geometry(data: memoryview, start: int, end: int) -> GeometryChunk:
    cur = _Cursor(data, start, end, "GEOM chunk")
    (field_type,) = cur.unpack("B")
    _check_field_type(field_type)
    (truncation,) = cur.unpack("f")
    _check_truncation(truncation)
    center = []
    for _ in range(3):
        (c,) = cur.unpack("f")
        _check_center_coordinate(c)
        center.append(c)
    (scale,) = cur.unpack("f")
    _check_scale(scale)
    _check_frame_extent(center, scale)
    network = _read_network(cur, _geometry_role(field_type))
    return GeometryChunk(field_type, truncation, (center[0], center[1], center[2]), scale, network)


def _read_frame64(data: memoryview, start: int, end: int, g: GeometryChunk) -> Frame64:
    cur = _Cursor(data, start, end, "fram chunk")
    center = []
    for c32 in g.center:  # each value checked as soon as it is read, as GEOM's
        (c,) = cur.unpack("d")
        _check_frame64_center(c, c32)
        center.append(c)
    (scale,) = cur.unpack("d")
    _check_frame64_scale(scale, g.scale)
    frame = Frame64((center[0], center[1], center[2]), scale)
    if cur.remaining():
        raise _corrupt(f"fram chunk has {cur.remaining()} bytes after the frame")
    return frame


def _read_color(data: memoryview, start: int, end: int) -> ColorChunk:
    cur = _Cursor(data, start, end, "colr chunk")
    (color_space,) = cur.unpack("B")
    _check_color_space(color_space)
    return ColorChunk(color_space, _read_network(cur, COLOR_ROLE))


def _read_header(data: memoryview) -> tuple[int, int, int]:
    if len(data) < HEADER_SIZE:
        raise FormatError("truncated", f"{len(data)} bytes, shorter than the {HEADER_SIZE}-byte header")
    if bytes(data[:4]) != MAGIC:
        raise _corrupt("bad magic (not an .nfc file)")
    major, minor, flags, file_size, header_crc = struct.unpack("<BBHII", data[4:HEADER_SIZE])
    if crc32(data[:12]) != header_crc:
        raise _corrupt("header CRC mismatch")
    if major != FORMAT_MAJOR:
        raise FormatError("unsupported_version", f"format version {major}.{minor} (this reader reads {FORMAT_MAJOR}.x)")
    if flags != 0:
        raise _corrupt(f"reserved header flags {flags:#06x} are set")
    if not HEADER_SIZE + CHUNK_OVERHEAD <= file_size <= MAX_FILE_SIZE:
        raise _corrupt(f"announced file size {file_size} out of range")
    if len(data) < file_size:
        raise FormatError("truncated", f"{len(data)} of the announced {file_size} bytes")
    if len(data) > file_size:
        raise _corrupt(f"{len(data) - file_size} trailing bytes after the announced end")
    return major, minor, file_size


def read_nfc(data: bytes) -> NfcFile:
    """Parse and fully verify an `.nfc` file. Raises FormatError with FORMAT.md's error kind."""
    view = memoryview(bytes(data))
    major, minor, file_size = _read_header(view)
    geometry: GeometryChunk | None = None
    color: ColorChunk | None = None
    seen: set[str] = set()
    skipped: list[str] = []
    sizes: dict[str, int] = {}
    pos = HEADER_SIZE
    while pos < file_size:
        cur = _Cursor(view, pos, file_size, "chunk")
        raw_tag, length = cur.unpack("4sI")
        if length > MAX_CHUNK_SIZE:
            raise _corrupt(f"chunk of {length} bytes exceeds {MAX_CHUNK_SIZE}")
        cur.take(length)
        (stored_crc,) = cur.unpack("I")
        if crc32(view[pos : pos + 8 + length]) != stored_crc:
            raise _corrupt(f"CRC mismatch in the chunk at offset {pos}")
        if not (raw_tag.isascii() and raw_tag.isalpha()):
            raise _corrupt(f"chunk tag {raw_tag!r} is not four ASCII letters")
        tag = raw_tag.decode("ascii")
        if tag in seen:
            raise _corrupt(f"duplicate chunk {tag}")
        if not seen and tag != TAG_GEOM:
            raise _corrupt(f"first chunk is {tag}, not {TAG_GEOM}")
        seen.add(tag)
        if tag == TAG_GEOM:
            geometry = _read_geometry(view, pos + 8, pos + 8 + length)
        elif tag == TAG_FRAME64:
            if len(seen) != 2:  # GEOM and this one: it must come directly after GEOM
                raise _corrupt("fram chunk not directly after GEOM")
            assert geometry is not None
            geometry.frame64 = _read_frame64(view, pos + 8, pos + 8 + length, geometry)
        elif tag == TAG_COLOR:
            color = _read_color(view, pos + 8, pos + 8 + length)
        elif tag[0].isupper():
            raise FormatError("unsupported_feature", f"unknown critical chunk {tag}")
        else:
            skipped.append(tag)
        sizes[tag] = cur.pos - pos
        pos = cur.pos
    assert geometry is not None  # file_size >= 28 guarantees one chunk, and the first is GEOM
    return NfcFile(geometry=geometry, major=major, minor=minor, skipped_chunks=skipped, color=color,
                   chunk_bytes=sizes)
