"""The neural field: Fourier positional encoding into a SIREN (torch).

It computes exactly the function of FORMAT.md "Evaluation" (up to float rounding): the encoding
h = [u, then for each k: sin(f_k u) (3 values), cos(f_k u) (3 values)] with the frequencies f_k of
`bitstream.positional_frequencies`, hidden layers sin(ω₀ (W h + b)), a linear output layer, then
identity (SDF), abs (UDF) or sigmoid (colour, 3 outputs).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch
from torch import nn

from . import config
from .bitstream import positional_frequencies

ParameterTransform = Callable[[torch.Tensor], torch.Tensor]


class PositionalEncoding(nn.Module):
    """u (n, 3) → (n, 3 + 6L) in the layout of FORMAT.md; products f_k·u_j in float32."""

    frequencies: torch.Tensor

    def __init__(self, num_frequencies: int = config.NUM_FREQUENCIES, base: float = config.FREQUENCY_BASE) -> None:
        super().__init__()
        self.num_frequencies = num_frequencies
        self.base = base
        self.register_buffer("frequencies", torch.from_numpy(positional_frequencies(num_frequencies, base)))

    @property
    def out_features(self) -> int:
        return 3 + 6 * self.num_frequencies

    def forward(self, u: torch.Tensor) -> torch.Tensor:
        angles = u[:, None, :] * self.frequencies[None, :, None]  # (n, L, 3)
        waves = torch.cat([torch.sin(angles), torch.cos(angles)], dim=2)  # (n, L, 6): sin xyz, cos xyz
        return torch.cat([u, waves.reshape(len(u), -1)], dim=1)


class Siren(nn.Module):
    """`hidden_layers` sine layers of width `width`, then a linear output layer of `outputs` values;
    see the module docstring."""

    def __init__(
        self,
        width: int,
        output: str,
        *,
        outputs: int = 1,
        hidden_layers: int = config.HIDDEN_LAYERS,
        num_frequencies: int = config.NUM_FREQUENCIES,
        frequency_base: float = config.FREQUENCY_BASE,
        omega0: float = config.OMEGA0,
        generator: torch.Generator | None = None,
    ) -> None:
        super().__init__()
        if output not in ("identity", "abs", "sigmoid"):
            raise ValueError(f"unknown output activation {output!r}")
        self.output = output
        self.outputs = outputs
        self.omega0 = omega0
        self.encoding = PositionalEncoding(num_frequencies, frequency_base)
        sizes = [self.encoding.out_features] + [width] * hidden_layers + [outputs]
        self.layers = nn.ModuleList(nn.Linear(n_in, n_out) for n_in, n_out in zip(sizes[:-1], sizes[1:]))
        self._siren_init(generator)

    def _siren_init(self, generator: torch.Generator | None) -> None:
        """Sitzmann et al.: first layer U(±1/in), later layers U(±sqrt(6/in)/ω₀); biases U(±1/sqrt(in))."""
        with torch.no_grad():
            for i, layer in enumerate(self.layers):
                n_in = layer.in_features
                bound = 1.0 / n_in if i == 0 else math.sqrt(6.0 / n_in) / self.omega0
                layer.weight.uniform_(-bound, bound, generator=generator)
                layer.bias.uniform_(-1.0 / math.sqrt(n_in), 1.0 / math.sqrt(n_in), generator=generator)

    def forward_encoded(self, h: torch.Tensor, transform: ParameterTransform | None = None) -> torch.Tensor:
        """Outputs for already encoded points, (n,) for one output, (n, outputs) otherwise; `transform`
        maps every weight and bias first (fake quantization during QAT)."""
        last = len(self.layers) - 1
        for i, layer in enumerate(self.layers):
            weight, bias = layer.weight, layer.bias
            if transform is not None:
                weight, bias = transform(weight), transform(bias)
            h = nn.functional.linear(h, weight, bias)
            if i < last:
                h = torch.sin(self.omega0 * h)
        y = h[:, 0] if self.outputs == 1 else h
        if self.output == "abs":
            return y.abs()
        return torch.sigmoid(y) if self.output == "sigmoid" else y

    def forward(self, u: torch.Tensor, transform: ParameterTransform | None = None) -> torch.Tensor:
        return self.forward_encoded(self.encoding(u), transform)
