"""The torch model computes the function of FORMAT.md that the numpy reference decoder evaluates."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nfencode import config, reference
from nfencode.bitstream import (
    FIELD_SDF,
    FIELD_UDF,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    positional_frequencies,
    read_nfc,
    write_nfc,
)
from nfencode.model import PositionalEncoding, Siren
from nfencode.quantize import fake_quantize, quantize_layers


def _points(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (n, 3)).astype(np.float32)


def test_encoding_matches_reference_layout_and_frequencies() -> None:
    enc = PositionalEncoding()
    assert np.array_equal(enc.frequencies.numpy(), positional_frequencies(config.NUM_FREQUENCIES, config.FREQUENCY_BASE))
    u = _points(2000)
    ours = enc(torch.from_numpy(u)).numpy()
    ref = reference.positional_encoding(enc.frequencies.numpy(), u)
    assert ours.shape == ref.shape == (2000, 3 + 6 * config.NUM_FREQUENCIES)
    assert np.array_equal(ours[:, :3], u)
    # Same f32 products; torch's f32 sine vs. the reference's correctly rounded one: a few ulp.
    assert np.abs(ours - ref).max() < 1e-6


def test_siren_initialisation_bounds() -> None:
    model = Siren(48, "identity", generator=torch.Generator().manual_seed(3)).requires_grad_(False)
    first, *others = model.layers
    inputs = 3 + 6 * config.NUM_FREQUENCIES
    assert first.in_features == inputs and float(first.weight.abs().max()) <= 1 / inputs
    for layer in others:
        bound = np.sqrt(6 / layer.in_features) / config.OMEGA0
        assert float(layer.weight.abs().max()) <= bound
        assert float(layer.weight.abs().max()) > 0.8 * bound  # really uniform over the range


@pytest.mark.parametrize("field_type,output,width", [(FIELD_SDF, "identity", 16), (FIELD_UDF, "abs", 32)])
def test_torch_forward_matches_reference_decoder_on_the_written_file(field_type: int, output: str, width: int) -> None:
    model = Siren(width, output, generator=torch.Generator().manual_seed(width))
    with torch.no_grad():  # move away from the init so the comparison covers a trained-like spread
        for layer in model.layers:
            layer.weight.mul_(1.5)
    levels, steps = quantize_layers(model.layers, 8)
    block = NetworkBlock(
        config.NUM_FREQUENCIES, config.FREQUENCY_BASE, config.OMEGA0,
        OUTPUT_IDENTITY if output == "identity" else OUTPUT_ABS, 8, [width, width, 1], steps, levels,
    )
    file = read_nfc(write_nfc(NfcFile(GeometryChunk(field_type, 0.1, (0.0, 0.0, 0.0), 1.0, block))))
    u = _points(5000, seed=width)
    expected = reference.evaluate(reference.dequantize(file.geometry.network), u)
    with torch.no_grad():
        ours = model(torch.from_numpy(u), lambda t: fake_quantize(t, 8)).double().numpy()
    assert np.abs(expected).max() > 0.05  # a non-trivial field
    assert np.abs(ours - expected).max() < 1e-5
