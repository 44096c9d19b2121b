"""Per-tensor symmetric uniform quantization and its straight-through estimator."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nfencode.bitstream import max_level
from nfencode.model import Siren
from nfencode.quantize import dequantize, fake_quantize, quantize, quantize_layers, quantization_step


def _tensors(seed: int) -> list[torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    return [
        torch.randn(64, 99, generator=g) * 0.03,  # weight-like
        torch.rand(17, generator=g) * 5.0 - 1.0,  # asymmetric range
        torch.tensor([-2.5, 0.0, 1e-9, 2.5]),  # both extremes reached
        torch.tensor([3e-7]),  # single value
    ]


@pytest.mark.parametrize("bits", range(2, 17))
def test_levels_fit_in_bits_and_error_is_at_most_half_a_step(bits: int) -> None:
    limit = max_level(bits)
    for x in _tensors(bits):
        levels, step = quantize(x, bits)
        assert levels.dtype == torch.int64
        assert int(levels.abs().max()) <= limit
        # The symmetric grid really fits: offsetting by the limit gives values in [0, 2^b - 2].
        assert int((levels + limit).max()) < (1 << bits)
        assert int(levels.abs().max()) == limit  # the peak lands on the outermost level
        assert step.dtype == torch.float32 and float(step) > 0
        error = (dequantize(levels, step).double() - x.double()).abs().max()
        # Half a step, plus the f32 rounding of the dequantized product f32(q)·step (half an ulp).
        assert float(error) <= float(step) / 2 + float(x.abs().max()) * 2.0**-24


def test_all_zero_tensor_gets_unit_step() -> None:
    levels, step = quantize(torch.zeros(5, 3), 8)
    assert float(step) == 1.0 and int(levels.abs().max()) == 0


def test_step_is_max_abs_over_max_level_in_float32() -> None:
    x = torch.tensor([0.3, -0.7, 0.1])
    assert float(quantization_step(x, 8)) == float(np.float32(np.float32(0.7) / np.float32(127)))


def test_straight_through_estimator_passes_gradients() -> None:
    x = torch.linspace(-1.0, 1.0, 101, requires_grad=True)
    weights = torch.linspace(0.5, 2.0, 101)
    (fake_quantize(x, 3) * weights).sum().backward()
    assert x.grad is not None
    # Identity backward: the gradient is exactly what it would be without quantization.
    assert torch.equal(x.grad, weights)
    # ... while the forward pass really is quantized (3 bits: 7 levels).
    assert len(torch.unique(fake_quantize(x, 3).detach())) == 7


def test_gradients_reach_every_parameter_through_a_quantized_network() -> None:
    model = Siren(16, "identity", generator=torch.Generator().manual_seed(0))
    u = torch.rand(256, 3) * 2 - 1
    model(u, lambda t: fake_quantize(t, 8)).pow(2).mean().backward()
    for name, p in model.named_parameters():
        assert p.grad is not None and float(p.grad.abs().sum()) > 0, name


def test_quantize_layers_exports_what_fake_quantization_computes() -> None:
    model = Siren(24, "abs", generator=torch.Generator().manual_seed(1))
    levels, steps = quantize_layers(model.layers, 6)
    for layer, (w_levels, b_levels), (w_step, b_step) in zip(model.layers, levels, steps):
        assert w_levels.shape == tuple(layer.weight.shape) and b_levels.shape == tuple(layer.bias.shape)
        assert np.float32(w_step) == w_step and np.float32(b_step) == b_step  # exactly representable
        w = w_levels.astype(np.float32) * np.float32(w_step)
        assert np.array_equal(w, fake_quantize(layer.weight, 6).detach().numpy())
