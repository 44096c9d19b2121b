"""Shared fixtures: small hand-built networks and .nfc files, and paths to the shared data."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nfencode.bitstream import (
    COLOR_SPACE_RGB,
    FIELD_SDF,
    FIELD_UDF,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    OUTPUT_SIGMOID,
    ColorChunk,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    layer_inputs,
    max_level,
    write_nfc,
)

SHARED = Path(__file__).resolve().parents[2].parent / "shared"  # beside the checkout
SHARED_DATA = SHARED / "data"


def random_network(
    num_frequencies: int = 2,
    widths: tuple[int, ...] = (8, 8, 1),
    bits: int = 8,
    output: int = OUTPUT_IDENTITY,
    seed: int = 0,
) -> NetworkBlock:
    """A network with random levels spanning the whole b-bit grid (extremes included)."""
    rng = np.random.default_rng(seed)
    limit = max_level(bits)
    levels = []
    for n_in, n_out in zip(layer_inputs(num_frequencies, list(widths)), widths):
        w = rng.integers(-limit, limit + 1, size=(n_out, n_in))
        w.flat[0], w.flat[-1] = limit, -limit
        levels.append((w, rng.integers(-limit, limit + 1, size=n_out)))
    steps = [(float(rng.uniform(1e-3, 1e-2)), float(rng.uniform(1e-3, 1e-2))) for _ in widths]
    return NetworkBlock(num_frequencies, 1.4, 30.0, output, bits, list(widths), steps, levels)


def random_file(field_type: int = FIELD_SDF, **network_args) -> NfcFile:
    output = OUTPUT_IDENTITY if field_type == FIELD_SDF else OUTPUT_ABS
    net = random_network(output=output, **network_args)
    return NfcFile(GeometryChunk(field_type, 0.1, (0.25, -1.5, 3.0), 0.75, net))


def random_color_file(field_type: int = FIELD_SDF, widths: tuple[int, ...] = (8, 8, 3), seed: int = 1) -> NfcFile:
    """`random_file` plus a colour chunk with random levels (sigmoid, 3 outputs)."""
    f = random_file(field_type)
    f.color = ColorChunk(COLOR_SPACE_RGB, random_network(num_frequencies=3, widths=widths, output=OUTPUT_SIGMOID,
                                                         seed=seed))
    return f


COS_BLOB_LEVEL = 3.0 - 0.18  # zero set of g(u) = c - sum(cos u_i): nearly a sphere of radius ~0.6


def cos_blob(u: np.ndarray, blob_center: float = 0.0) -> np.ndarray:
    """The field the hand-built `cos_blob_file` network computes: c - sum_i cos(u_i - blob_center)."""
    return COS_BLOB_LEVEL - np.cos(np.asarray(u, dtype=np.float64) - blob_center).sum(axis=-1)


def cos_blob_file(center=(0.5, -1.0, 2.0), scale: float = 3.0, blob_center: float = 0.0) -> NfcFile:
    """An SDF file whose network is exactly cos_blob, up to f32 rounding of the weights:
    no positional encoding, omega0 = 1, hidden h_i = sin(u_i - blob_center + pi/2) = cos(u_i -
    blob_center), output c - (h0 + h1 + h2). Negative inside, like an SDF; the blob is centred at
    (blob_center,) * 3 in the unit frame (0 <= blob_center < pi / 2)."""
    net = NetworkBlock(
        num_frequencies=0,
        frequency_base=1.0,
        omega0=1.0,
        output=OUTPUT_IDENTITY,
        bits=8,
        out_features=[3, 1],
        steps=[(1.0, math.pi / 2 - blob_center), (1.0, COS_BLOB_LEVEL)],
        levels=[(np.eye(3, dtype=np.int64), np.ones(3, dtype=np.int64)),
                (-np.ones((1, 3), dtype=np.int64), np.ones(1, dtype=np.int64))],
    )
    return NfcFile(GeometryChunk(FIELD_SDF, 0.1, center, scale, net))


@pytest.fixture
def sdf_bytes() -> bytes:
    return write_nfc(random_file(FIELD_SDF))


@pytest.fixture
def udf_bytes() -> bytes:
    return write_nfc(random_file(FIELD_UDF))


@pytest.fixture
def blob_bytes() -> bytes:
    return write_nfc(cos_blob_file())
