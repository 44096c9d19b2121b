"""Per-tensor symmetric uniform quantization, its straight-through estimator, and export.

Each weight matrix and each bias vector gets its own grid: step = max|x| / (2^(b-1) − 1) in float32
(1.0 for an all-zero tensor), levels q = round(x / step) clipped to ±(2^(b-1) − 1), so the 2^b − 1
levels truly fit in b bits; the decoder's value is f32(q) · step (FORMAT.md). Training-time fake
quantization and the export use the same functions, so QAT sees exactly the network that is written.
"""

from __future__ import annotations

import numpy as np
import torch

from .bitstream import NetworkBlock, max_level


def quantization_step(x: torch.Tensor, bits: int) -> torch.Tensor:
    """float32 scalar step of the symmetric b-bit grid that spans max|x| (1.0 when x is all zero)."""
    peak = x.detach().abs().max().to(torch.float32)
    step = peak / max_level(bits)
    return torch.where(peak > 0, step, torch.ones_like(step))


def quantize(x: torch.Tensor, bits: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(integer levels as int64, float32 step) of x."""
    step = quantization_step(x, bits)
    limit = max_level(bits)
    # Divide in f64: an f32 quotient can be off by |x/step|·2^-24 ≈ 0.002 levels at 16 bits.
    levels = torch.round(x.detach().to(torch.float64) / step.to(torch.float64)).clamp_(-limit, limit)
    return levels.to(torch.int64), step


def dequantize(levels: torch.Tensor, step: torch.Tensor) -> torch.Tensor:
    """f32(q) · step, one float32 multiplication as in FORMAT.md."""
    return levels.to(torch.float32) * step.to(torch.float32)


def fake_quantize(x: torch.Tensor, bits: int) -> torch.Tensor:
    """Straight-through estimator: the forward pass sees dequantize(quantize(x)), the backward pass
    the identity, so gradients reach the float weights that QAT keeps training."""
    snapped = dequantize(*quantize(x, bits))
    return x + (snapped - x).detach()


def quantize_layers(
    layers: torch.nn.ModuleList, bits: int
) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[tuple[float, float]]]:
    """Levels [(W (out, in) int64, b (out,) int64)] and steps [(w_step, b_step)] of every linear layer."""
    levels: list[tuple[np.ndarray, np.ndarray]] = []
    steps: list[tuple[float, float]] = []
    for layer in layers:
        w_levels, w_step = quantize(layer.weight, bits)
        b_levels, b_step = quantize(layer.bias, bits)
        levels.append((w_levels.numpy(), b_levels.numpy()))
        steps.append((float(w_step), float(b_step)))
    return levels, steps


def quantized_network(
    layers: torch.nn.ModuleList, bits: int, *, num_frequencies: int, frequency_base: float, omega0: float,
    output: int,
) -> NetworkBlock:
    """The bitstream's network block of trained (CPU) layers at b bits."""
    levels, steps = quantize_layers(layers, bits)
    return NetworkBlock(
        num_frequencies=num_frequencies,
        frequency_base=frequency_base,
        omega0=omega0,
        output=output,
        bits=bits,
        out_features=[layer.out_features for layer in layers],
        steps=steps,
        levels=levels,
    )
