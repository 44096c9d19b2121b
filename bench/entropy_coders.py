#!/usr/bin/env python3
"""Entropy coding candidates against brotli on real `.nfc` files (issue 10, item 4).

Issue 10 keeps brotli "unless a candidate measured on all widths beats it". For each file this
takes the quantized levels of the geometry network (the bytes brotli compresses) and prints the
size brotli gives them against adaptive arithmetic-coding models that see structure brotli cannot:

- `order0`: the zeroth-order entropy of each tensor's levels, with no table counted (a lower bound
  of any static per-tensor model, not a real coder);
- `adaptive`: adaptive multi-symbol model per tensor (counts start at 1/8 per level of the grid);
- `binary`: levels binarised as zero flag, sign and an Exp-Golomb magnitude (unary exponent, then
  mantissa bits), each bin an adaptive binary model per tensor (CABAC's scheme without the
  neighbourhood);
- `binary+band`: as `binary`, and in layer 0 the bins are also conditioned on the encoding column's
  frequency (its magnitude falls with the frequency: the top octaves of a 16-frequency network are
  mostly zero);
- `binary+neighbours`: as `binary`, conditioned on the magnitude of the left and upper neighbour in
  the weight matrix (row-major raster).

Sizes of the arithmetic coders are their ideal adaptive code lengths (sum of -log2 p of the
model's own running estimate), which a range coder reaches within a few bytes; `order0` is a bound.

    .venv/bin/python bench/entropy_coders.py bench/out/freq/*.nfc bench/out/nfc/*.nfc
"""

from __future__ import annotations

import argparse
import math
from collections import defaultdict
from collections.abc import Callable, Hashable
from pathlib import Path

import brotli
import numpy as np

from nfencode.bitstream import BROTLI_QUALITY, NetworkBlock, read_nfc


class AdaptiveBinary:
    """Ideal code length of bins coded with adaptive counts (Krichevsky–Trofimov) per context."""

    def __init__(self) -> None:
        self.counts: dict[Hashable, list[float]] = defaultdict(lambda: [0.5, 0.5])
        self.bits = 0.0

    def code(self, context: Hashable, bit: int) -> None:
        c = self.counts[context]
        self.bits -= math.log2(c[bit] / (c[0] + c[1]))
        c[bit] += 1.0


def code_level(coder: AdaptiveBinary, level: int, context: Hashable) -> None:
    """Zero flag, sign, then |level| - 1 in Exp-Golomb order 0: exponent in unary, mantissa bits."""
    magnitude = abs(level)
    coder.code((context, "zero"), int(magnitude == 0))
    if magnitude == 0:
        return
    coder.code((context, "sign"), int(level < 0))
    value = magnitude  # >= 1: exponent = floor(log2(value))
    exponent = value.bit_length() - 1
    for e in range(exponent):
        coder.code((context, "exp", e), 1)
    coder.code((context, "exp", exponent), 0)
    for i in range(exponent - 1, -1, -1):
        coder.code((context, "mantissa", exponent, i), (value >> i) & 1)


def magnitude_class(x: int) -> int:
    return 0 if x == 0 else min(5, x.bit_length())


ContextOf = Callable[[int, int, int, int, np.ndarray], Hashable]  # layer, row, column, inputs, W


def binary_bytes(net: NetworkBlock, context_of: ContextOf) -> float:
    coder = AdaptiveBinary()
    for layer, (weights, bias) in enumerate(net.levels):
        w = np.asarray(weights, dtype=np.int64)
        for row in range(w.shape[0]):
            for column in range(w.shape[1]):
                code_level(coder, int(w[row, column]), ("w", layer, context_of(layer, row, column, w.shape[1], w)))
        for value in np.asarray(bias, dtype=np.int64).tolist():
            code_level(coder, int(value), ("b", layer))
    return coder.bits / 8


def per_tensor(layer: int, row: int, column: int, inputs: int, w: np.ndarray) -> Hashable:
    return 0


def frequency_band(layer: int, row: int, column: int, inputs: int, w: np.ndarray) -> Hashable:
    # Layer 0's columns: u (3), then per frequency k six columns (FORMAT.md "Evaluation").
    return 0 if layer > 0 or column < 3 else 1 + (column - 3) // 6


def neighbours(layer: int, row: int, column: int, inputs: int, w: np.ndarray) -> Hashable:
    left = abs(int(w[row, column - 1])) if column else 0
    up = abs(int(w[row - 1, column])) if row else 0
    return magnitude_class((left + up + 1) // 2) if row or column else -1


def band_and_neighbours(layer: int, row: int, column: int, inputs: int, w: np.ndarray) -> Hashable:
    return (frequency_band(layer, row, column, inputs, w), neighbours(layer, row, column, inputs, w))


def adaptive_symbol_bytes(net: NetworkBlock) -> float:
    alphabet = 2 ** net.bits - 1
    bits = 0.0
    for weights, bias in net.levels:
        for tensor in (weights, bias):
            counts: dict[int, float] = defaultdict(float)
            total = 0.0
            for value in np.asarray(tensor).reshape(-1).tolist():
                bits -= math.log2((counts[value] + 0.125) / (total + 0.125 * alphabet))
                counts[value] += 1.0
                total += 1.0
    return bits / 8


def order0_bytes(net: NetworkBlock) -> float:
    bits = 0.0
    for weights, bias in net.levels:
        for tensor in (weights, bias):
            _, counts = np.unique(np.asarray(tensor), return_counts=True)
            bits += float(-(counts * np.log2(counts / counts.sum())).sum())
    return bits / 8


def brotli_bytes(net: NetworkBlock) -> int:
    raw = b"".join(np.concatenate([np.asarray(w).reshape(-1), np.asarray(b)]).astype("<i1" if net.bits <= 8 else "<i2")
                   .tobytes() for w, b in net.levels)
    return len(brotli.compress(raw, quality=BROTLI_QUALITY))


CANDIDATES: dict[str, Callable[[NetworkBlock], float]] = {
    "order0 (bound)": order0_bytes,
    "adaptive": adaptive_symbol_bytes,
    "binary": lambda net: binary_bytes(net, per_tensor),
    "binary+band": lambda net: binary_bytes(net, frequency_band),
    "binary+neighbours": lambda net: binary_bytes(net, neighbours),
    "binary+band+neighbours": lambda net: binary_bytes(net, band_and_neighbours),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("files", nargs="+", type=Path)
    args = parser.parse_args()

    names = list(CANDIDATES)
    print("| file | width | L | parameters | brotli B | " + " | ".join(names) + " |")
    print("|---|---:|---:|---:|---:|" + "---:|" * len(names))
    by_width: dict[tuple[int, int], list[list[float]]] = defaultdict(list)
    for path in sorted(args.files):
        net = read_nfc(path.read_bytes()).geometry.network
        base = brotli_bytes(net)
        ratios = [CANDIDATES[n](net) / base - 1.0 for n in names]
        width = net.out_features[0]
        by_width[(width, net.num_frequencies)].append(ratios)
        cells = " | ".join(f"{100 * r:+.1f}%" for r in ratios)
        print(f"| {path.name} | {width} | {net.num_frequencies} | {net.parameter_count} | {base} | {cells} |")

    print("\nPer width and L: mean size against brotli (files where the candidate is smaller)\n")
    print("| width | L | files | " + " | ".join(names) + " |")
    print("|---:|---:|---:|" + "---:|" * len(names))
    for width, frequencies in sorted(by_width):
        rows = np.array(by_width[(width, frequencies)])
        cells = " | ".join(f"{100 * rows[:, i].mean():+.1f}% ({int((rows[:, i] < 0).sum())})" for i in range(len(names)))
        print(f"| {width} | {frequencies} | {len(rows)} | {cells} |")


if __name__ == "__main__":
    main()
