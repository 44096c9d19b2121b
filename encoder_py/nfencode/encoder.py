"""Public encoder API: `compress(shape, EncodeConfig()) -> EncodeResult` with the `.nfc` bytes.

Pipeline (Postels et al., CVPR 2024): unit-ball frame → ground-truth distance pool → SIREN fit on the
truncated loss → per-layer b-bit quantization with quantization-aware retraining → `.nfc`
(brotli inside `bitstream.write_nfc`); then, for a coloured shape, the colour network on the decoded
surface (`color.fit_color`) in a `colr` chunk.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import torch

from . import config
from .bitstream import (
    FIELD_NAMES,
    FIELD_SDF,
    FIELD_UDF,
    MAX_BITS,
    MAX_FRAME_EXTENT,
    MAX_FREQUENCIES,
    MAX_WIDTH,
    MIN_BITS,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    Frame64,
    GeometryChunk,
    NfcFile,
    frequency_base_in_range,
    read_nfc,
    write_nfc,
)
from .color import ColorFit, ColorOptions, ColorSurface, check_color_options, color_surface, fit_color
from .devices import cpu_threads, resolve_device
from .errors import InputError
from .io import COLOR_MODES, Shape
from .model import Siren
from .normalize import needs_frame64, to_unit, unit_ball_frame
from .quantize import quantized_network
from .sampling import DistancePool, SurfaceSampler, build_pool, resolve_field
from .train import TrainingData, fit, prepare_data, signed_epochs, validation_loss


@dataclass
class EncodeConfig:
    """What `nfc encode` exposes. `epochs` overrides the preset's epoch count (QAT unchanged)."""

    field: str = "auto"  # "auto", "sdf" or "udf"
    width: int = config.DEFAULT_WIDTH
    bits: int = config.DEFAULT_BITS
    frequencies: int = config.NUM_FREQUENCIES  # L of the positional encoding
    frequency_base: float = config.FREQUENCY_BASE  # β: the encoding's frequencies are π·β^k
    preset: str = config.DEFAULT_PRESET
    epochs: int | None = None
    seed: int = 0
    quiet: bool = False
    device: str = "auto"  # "auto" (CUDA when torch sees a GPU), "cpu" or "cuda"
    threads: int | None = None  # CPU torch threads; None: devices.cpu_threads()
    color: str = "auto"  # "auto" (when the shape has colours), "on" (it must have them) or "off"
    color_width: int = config.COLOR_WIDTH
    color_bits: int = config.DEFAULT_BITS
    color_resolution: int = config.COLOR_RESOLUTION
    color_frequencies: int = config.COLOR_NUM_FREQUENCIES
    color_epochs: int | None = None  # overrides the colour schedule's epoch count
    truncation: float | None = None  # d*; None: the field's (config.TRUNCATION)



@dataclass
class EncodeResult:
    data: bytes  # the `.nfc` file
    field: str  # "sdf" or "udf", after resolving "auto"
    field_reason: str  # why that field (sampling.resolve_field), one line
    seconds: float  # wall-clock time of compress()
    final_loss: float  # truncated validation loss of the quantized network that was written (NaN: reused)
    color: ColorFit | None = None  # the colour chunk's fit, when one was written


def check_config(cfg: EncodeConfig) -> config.Preset:
    """The preset of `cfg`, after checking every value (InputError otherwise)."""
    if cfg.preset not in config.PRESETS:
        raise InputError(f"unknown preset {cfg.preset!r} (choose from {', '.join(config.PRESETS)})")
    if not 1 <= cfg.width <= MAX_WIDTH:
        raise InputError(f"width {cfg.width} outside 1..{MAX_WIDTH}")
    if not 0 <= cfg.frequencies <= MAX_FREQUENCIES:
        raise InputError(f"{cfg.frequencies} frequencies outside 0..{MAX_FREQUENCIES}")
    if not frequency_base_in_range(cfg.frequency_base):
        raise InputError(f"frequency base {cfg.frequency_base} outside [1, 2] (FORMAT.md)")
    if not MIN_BITS <= cfg.bits <= MAX_BITS:
        raise InputError(f"bit width {cfg.bits} outside {MIN_BITS}..{MAX_BITS}")
    if cfg.epochs is not None and cfg.epochs < 0:
        raise InputError(f"epochs must be non-negative, got {cfg.epochs}")
    if cfg.field not in ("auto", "sdf", "udf"):
        raise InputError(f"unknown field type {cfg.field!r} (use sdf, udf or auto)")
    if cfg.truncation is not None and not config.MIN_TRUNCATION <= cfg.truncation <= config.MAX_TRUNCATION:
        raise InputError(f"truncation {cfg.truncation} outside [{config.MIN_TRUNCATION}, {config.MAX_TRUNCATION}]")
    if cfg.color not in COLOR_MODES:
        raise InputError(f"unknown colour mode {cfg.color!r} (use {', '.join(COLOR_MODES)})")
    check_color_options(color_options(cfg))
    return config.PRESETS[cfg.preset]


def color_options(cfg: EncodeConfig) -> ColorOptions:
    return ColorOptions(width=cfg.color_width, bits=cfg.color_bits, resolution=cfg.color_resolution,
                        frequencies=cfg.color_frequencies, epochs=cfg.color_epochs, seed=cfg.seed, quiet=cfg.quiet)


def wants_color(shape: Shape, cfg: EncodeConfig) -> bool:
    """Whether `shape` gets a colour chunk: "on" requires colours (InputError without), "auto"
    follows the shape."""
    if cfg.color == "on" and shape.colors is None:
        raise InputError(f"{shape.name}: colour requested but the input has no (usable) colours")
    return cfg.color != "off" and shape.colors is not None


def add_color(result: EncodeResult, shape: Shape, cfg: EncodeConfig, device: torch.device,
              work: ShapeWork | None = None) -> EncodeResult:
    """`result` with a colour chunk fitted on the surface its geometry decodes to (replacing any),
    that surface taken from `work` when given."""
    file = read_nfc(result.data)
    options = color_options(cfg)
    surface = None if work is None else work.color_surface(result.data, shape, options, device)
    fitted = fit_color(file, shape, options, device, surface)
    file.color = fitted.chunk
    return dataclasses.replace(result, data=write_nfc(file), color=fitted,
                               seconds=result.seconds + fitted.seconds)


@dataclass
class Prepared:
    """Everything before training: the frame, the field, the ground-truth pool and the initial
    network (on the CPU; `data` on the training device)."""

    field: str
    field_reason: str
    center32: np.ndarray
    scale32: float
    frame64: Frame64 | None  # the exact frame, for shapes far from their origin (needs_frame64)
    pool: DistancePool
    model: Siren
    data: TrainingData
    rng: np.random.Generator  # the shape's numpy stream, continued by training
    truncation: float  # d* of the loss, and the file's


def prepare(shape: Shape, cfg: EncodeConfig, device: torch.device, work: ShapeWork | None = None) -> Prepared:
    """Frame, field choice, pool and initial weights of `shape`; the random draws of one seed. The
    pool comes from `work` when an earlier encode of the shape built it."""
    rng = np.random.default_rng(cfg.seed)
    generator = torch.Generator().manual_seed(cfg.seed)
    # Train in exactly the frame a decoder will apply: GEOM's f32 frame, or for a shape far from
    # its origin the f64 frame of a `fram` chunk (GEOM then holds it rounded to f32).
    center, scale = unit_ball_frame(shape.vertices)
    with np.errstate(over="ignore"):
        center32 = np.asarray(center, dtype=np.float32)
        scale32 = float(np.float32(scale))
    if not (np.all(np.isfinite(center32)) and math.isfinite(scale32) and scale32 > 0.0):
        raise InputError("the shape has no extent (all vertices coincide) or coordinates overflow float32")
    if scale32 < float(np.finfo(np.float32).tiny):  # subnormal: decoded positions lose their bits
        raise InputError(f"the shape is too small for float32 coordinates: its radius {scale:.3g} is below "
                         f"{float(np.finfo(np.float32).tiny):.3g} (scale it up, e.g. to other units)")
    if float(np.abs(center32).max()) + scale32 > MAX_FRAME_EXTENT:
        raise InputError(f"coordinates too large for float32 outputs: |center| + radius reaches "
                         f"{float(np.abs(center).max()) + scale:.3g}, the format's limit is {MAX_FRAME_EXTENT:.3g}")
    frame64 = None
    train_center, train_scale = center32, scale32
    if needs_frame64(center, scale):
        frame64 = Frame64((float(center[0]), float(center[1]), float(center[2])), float(scale))
        train_center, train_scale = center, scale
    sampler = SurfaceSampler(to_unit(shape.vertices, train_center, train_scale), shape.faces)
    field, field_reason = resolve_field(sampler, cfg.field, rng, cfg.width)
    pool = build_pool(sampler, field, rng) if work is None else work.pool(sampler, field, rng)
    if pool.sides_note:
        field_reason = f"{field_reason}; {pool.sides_note}"
    model = Siren(cfg.width, "identity" if field == "sdf" else "abs", num_frequencies=cfg.frequencies,
                  frequency_base=cfg.frequency_base, generator=generator)
    data = prepare_data(model, pool)
    if device.type != "cpu":
        data = TrainingData(*(t.to(device) for t in (data.encoded, data.distances, data.validation_encoded,
                                                      data.validation_distances)),
                            None if data.sides is None else data.sides.to(device))
    truncation = config.TRUNCATION[field] if cfg.truncation is None else cfg.truncation
    return Prepared(field, field_reason, center32, scale32, frame64, pool, model, data, rng, truncation)


def finish(prep: Prepared, best_layers: torch.nn.ModuleList, bits: int, best_loss: float, start: float) -> EncodeResult:
    """Quantize the chosen layers and write the `.nfc` bytes."""
    encoding = prep.model.encoding
    network = quantized_network(best_layers.cpu(), bits, num_frequencies=encoding.num_frequencies,
                                frequency_base=encoding.base, omega0=config.OMEGA0,
                                output=OUTPUT_IDENTITY if prep.field == "sdf" else OUTPUT_ABS)
    c = prep.center32
    geometry = GeometryChunk(
        field_type=FIELD_SDF if prep.field == "sdf" else FIELD_UDF,
        truncation=prep.truncation,
        center=(float(c[0]), float(c[1]), float(c[2])),
        scale=prep.scale32,
        network=network,
        frame64=prep.frame64,
    )
    data_bytes = write_nfc(NfcFile(geometry))
    return EncodeResult(data_bytes, prep.field, prep.field_reason, time.perf_counter() - start, best_loss)


def compress(shape: Shape, cfg: EncodeConfig, geometry: bytes | None = None,
             work: ShapeWork | None = None) -> EncodeResult:
    """Encode `shape` into `.nfc` bytes: its geometry, and its colour (see `wants_color`). With
    `geometry` (an `.nfc` file of this shape) that geometry is reused as it is and only the colour is
    fitted. `work` (one per shape) lends what an earlier encode of the shape built that this one
    needs too (`ShapeWork`). Deterministic given cfg.seed on a given device (on the CPU: and thread
    count), with or without `work`."""
    start = time.perf_counter()
    check_config(cfg)
    device = resolve_device(cfg.device)
    color = wants_color(shape, cfg)
    previous_threads = torch.get_num_threads()
    torch.set_num_threads(cpu_threads(cfg.threads))
    try:
        if geometry is None:
            result = _compress_geometry(shape, cfg, device, start, work)
        else:
            g = read_nfc(geometry).geometry
            result = EncodeResult(write_nfc(NfcFile(g)), FIELD_NAMES[g.field_type], "reused from the given .nfc",
                                  time.perf_counter() - start, float("nan"))
        return add_color(result, shape, cfg, device, work) if color else result
    finally:
        torch.set_num_threads(previous_threads)


class ShapeWork:
    """What several encodes of one shape share, whatever their widths (a rate search's tries): the
    training pool of each field, and the surface a geometry decodes to with the training pairs of
    its colour. Each is found by everything it depends on (the field and the numpy stream before
    the pool; the geometry file's bytes, resolution, seed and device for the surface), and an encode that
    finds one continues from a copy of the random stream as it stood after it was built: it writes
    the bytes it would write alone. One object per shape: the shape itself is not part of the keys."""

    def __init__(self) -> None:
        self._pools: dict[tuple[str, str], tuple[DistancePool, dict]] = {}
        self._surfaces: dict[tuple[bytes, int, int, str], ColorSurface] = {}  # by file bytes

    def pool(self, sampler: SurfaceSampler, field: str, rng: np.random.Generator) -> DistancePool:
        """`build_pool(sampler, field, rng)`, built once per field and stream."""
        key = (field, repr(rng.bit_generator.state))
        if key not in self._pools:
            pool = build_pool(sampler, field, rng)
            self._pools[key] = (pool, copy.deepcopy(rng.bit_generator.state))
        pool, after = self._pools[key]
        rng.bit_generator.state = copy.deepcopy(after)
        return pool

    def color_surface(self, data: bytes, shape: Shape, options: ColorOptions, device: torch.device) -> ColorSurface:
        """`color.color_surface` of the geometry of the `.nfc` bytes `data`, built once per file,
        resolution, seed and device (equal bytes, equal geometry: the file is its own key)."""
        key = (data, options.resolution, options.seed, str(device))
        if key not in self._surfaces:
            self._surfaces[key] = color_surface(read_nfc(data), shape, options.resolution, options.seed, device)
        return self._surfaces[key]


def _compress_geometry(shape: Shape, cfg: EncodeConfig, device: torch.device, start: float,
                       work: ShapeWork | None) -> EncodeResult:
    """Fit, QAT and write the geometry (a 1.0 file)."""
    preset = config.PRESETS[cfg.preset]
    epochs = preset.epochs if cfg.epochs is None else cfg.epochs
    prep = prepare(shape, cfg, device, work)
    model, data, pool, rng = prep.model.to(device), prep.data, prep.pool, prep.rng
    truncation = prep.truncation
    fit(model, data, pool, epochs=epochs, lr=preset.lr, cosine=preset.cosine,
        batch_size=preset.batch_size, rng=rng, truncation=truncation,
        signed=0 if data.sides is None else signed_epochs(epochs), quiet=cfg.quiet)

    # QAT; keep whichever quantized network, before or after it, validates better.
    best_loss = validation_loss(model, data, cfg.bits, truncation)
    best_layers = copy.deepcopy(model.layers)
    if preset.qat_epochs > 0:
        fit(model, data, pool, epochs=preset.qat_epochs, lr=preset.qat_lr, cosine=True,
            batch_size=preset.batch_size, rng=rng, truncation=truncation, bits=cfg.bits, quiet=cfg.quiet,
            desc="qat")
        qat_loss = validation_loss(model, data, cfg.bits, truncation)
        if qat_loss < best_loss:
            best_loss, best_layers = qat_loss, model.layers
    return finish(prep, best_layers, cfg.bits, best_loss, start)
