"""Public encoder API: `compress(shape, EncodeConfig()) -> EncodeResult` with the `.nfc` bytes.

Pipeline (Postels et al., CVPR 2024): unit-ball frame → ground-truth distance pool → SIREN fit on the
truncated loss → per-layer b-bit quantization with quantization-aware retraining → `.nfc`
(brotli inside `bitstream.write_nfc`).
"""

from __future__ import annotations

import copy
import math
import os
import time
from dataclasses import dataclass

import numpy as np
import torch

from . import config
from .bitstream import (
    FIELD_SDF,
    FIELD_UDF,
    MAX_BITS,
    MAX_WIDTH,
    MIN_BITS,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    write_nfc,
)
from .errors import InputError
from .io import Shape
from .model import Siren
from .normalize import to_unit, unit_ball_frame
from .quantize import quantize_layers
from .sampling import SurfaceSampler, build_pool, resolve_field
from .train import fit, prepare_data, validation_loss


@dataclass
class EncodeConfig:
    """What `nfc encode` exposes. `epochs` overrides the preset's epoch count (QAT unchanged)."""

    field: str = "auto"  # "auto", "sdf" or "udf"
    width: int = 32
    bits: int = config.DEFAULT_BITS
    preset: str = config.DEFAULT_PRESET
    epochs: int | None = None
    seed: int = 0
    quiet: bool = False


@dataclass
class EncodeResult:
    data: bytes  # the `.nfc` file
    field: str  # "sdf" or "udf", after resolving "auto"
    field_reason: str  # why that field (sampling.resolve_field), one line
    seconds: float  # wall-clock time of compress()
    final_loss: float  # truncated validation loss of the quantized network that was written


def _check_config(cfg: EncodeConfig) -> config.Preset:
    if cfg.preset not in config.PRESETS:
        raise InputError(f"unknown preset {cfg.preset!r} (choose from {', '.join(config.PRESETS)})")
    if not 1 <= cfg.width <= MAX_WIDTH:
        raise InputError(f"width {cfg.width} outside 1..{MAX_WIDTH}")
    if not MIN_BITS <= cfg.bits <= MAX_BITS:
        raise InputError(f"bit width {cfg.bits} outside {MIN_BITS}..{MAX_BITS}")
    if cfg.epochs is not None and cfg.epochs < 0:
        raise InputError(f"epochs must be non-negative, got {cfg.epochs}")
    return config.PRESETS[cfg.preset]


def _torch_threads() -> int:
    available = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(available, config.MAX_TORCH_THREADS))


def compress(shape: Shape, cfg: EncodeConfig) -> EncodeResult:
    """Encode the geometry of `shape` into `.nfc` bytes. Deterministic given cfg.seed (and thread count)."""
    start = time.perf_counter()
    preset = _check_config(cfg)
    epochs = preset.epochs if cfg.epochs is None else cfg.epochs
    rng = np.random.default_rng(cfg.seed)
    generator = torch.Generator().manual_seed(cfg.seed)

    # The file stores the frame in f32; train in exactly the frame a decoder will apply.
    center, scale = unit_ball_frame(shape.vertices)
    center32 = np.asarray(center, dtype=np.float32)
    scale32 = float(np.float32(scale))
    if not (np.all(np.isfinite(center32)) and math.isfinite(scale32) and scale32 > 0.0):
        raise InputError("the shape has no extent (all vertices coincide) or coordinates overflow float32")
    sampler = SurfaceSampler(to_unit(shape.vertices, center32, scale32), shape.faces)
    field, field_reason = resolve_field(sampler, cfg.field, rng)

    previous_threads = torch.get_num_threads()
    torch.set_num_threads(_torch_threads())
    try:
        pool = build_pool(sampler, field, rng)
        model = Siren(cfg.width, "identity" if field == "sdf" else "abs", generator=generator)
        data = prepare_data(model, pool)
        fit(model, data, pool, epochs=epochs, lr=preset.lr, cosine=preset.cosine,
            batch_size=preset.batch_size, rng=rng, quiet=cfg.quiet)

        # QAT; keep whichever quantized network, before or after it, validates better.
        best_loss = validation_loss(model, data, cfg.bits)
        best_layers = copy.deepcopy(model.layers)
        if preset.qat_epochs > 0:
            fit(model, data, pool, epochs=preset.qat_epochs, lr=preset.qat_lr, cosine=True,
                batch_size=preset.batch_size, rng=rng, bits=cfg.bits, quiet=cfg.quiet, desc="qat")
            qat_loss = validation_loss(model, data, cfg.bits)
            if qat_loss < best_loss:
                best_loss, best_layers = qat_loss, model.layers
        levels, steps = quantize_layers(best_layers, cfg.bits)
    finally:
        torch.set_num_threads(previous_threads)

    network = NetworkBlock(
        num_frequencies=config.NUM_FREQUENCIES,
        frequency_base=config.FREQUENCY_BASE,
        omega0=config.OMEGA0,
        output=OUTPUT_IDENTITY if field == "sdf" else OUTPUT_ABS,
        bits=cfg.bits,
        out_features=[layer.out_features for layer in best_layers],
        steps=steps,
        levels=levels,
    )
    geometry = GeometryChunk(
        field_type=FIELD_SDF if field == "sdf" else FIELD_UDF,
        truncation=config.TRUNCATION,
        center=(float(center32[0]), float(center32[1]), float(center32[2])),
        scale=scale32,
        network=network,
    )
    data_bytes = write_nfc(NfcFile(geometry))
    return EncodeResult(data_bytes, field, field_reason, time.perf_counter() - start, best_loss)
