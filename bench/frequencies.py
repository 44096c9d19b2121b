#!/usr/bin/env python3
"""Where the parameters go (issue 10, item 2): the positional encoding's frequency count L, its
spacing β (frequencies π·β^k) and the bit width.

At widths 16-32 the first layer (3 + 6L inputs) holds most of the network. For each shape, width,
encoding and bit width this encodes with the `fast` preset (seed 0), decodes with nfc-decode (CPU
path) at 256 and measures CD (metrics.md, bench/rd.py's measure_nfc), then prints bytes / CD per
setting and the BD-rate of each against the anchor (L = 16, β = 1.4 at 8 bits, format 1.0's choice)
per shape. An encoding is `L` (β = 1.4, the 1.0 and 0.6 encoders' spacing) or `L:β`, optionally
followed by `@d*`, the truncation distance (`nfc encode --truncation`; without it the paper's 0.1,
that of format 1.0 and of every row before d* was a column, not the encoder's default for SDFs),
then by `/E`, the training epochs (`nfc encode --epochs`; without it 60, format 1.0's `fast`
preset's count and that of every row before epochs were a column, whatever the preset's is now).
Points are cached in bench/out/frequencies.csv, so a rerun only encodes what is missing.

One seed's BD-rate over four widths moves by 5-10 points from seed to seed (the w16 fits vary by
5-7% in CD; bench/RESULTS.md), so `--seeds` encodes every point at each seed: the tables then show
the geometric means over the seeds, and the BD-rate is that of the mean curves, with the range of
the seeds' own BD-rates beside it.

    .venv/bin/python bench/frequencies.py --shapes bunny armadillo dragon spot happy \
        --widths 16 24 32 48 --frequencies 16 8 5:1.8 8@0.05 8@0.05/90 [--bits 8 7] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import csv
import itertools
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from nfencode.encoder import EncodeConfig, compress
from nfencode.io import load_shape
from rd import SHAPES, SHARED, measure_nfc

OUT = Path(__file__).resolve().parent / "out"
CSV = OUT / "frequencies.csv"
FIELDS = ("shape", "width", "frequencies", "base", "bits", "bytes", "cd", "seconds", "seed", "truncation", "epochs")
LEGACY_BASE = "1.4"  # rows written before the base was a column, and a bare `L` on the command line
LEGACY_TRUNCATION = "0.1"  # rows written before d* was a column, and an encoding without `@d*`
LEGACY_EPOCHS = 60  # rows written before epochs were a column, and an encoding without `/E`
Encoding = tuple[int, str, str, int]  # L, β and d* as written, epochs
Setting = tuple[int, str, int, str, int]  # L, β, bits, d*, epochs
Key = tuple[str, int, int, str, int, str, int, int]  # shape, width, L, β, bits, d*, epochs, seed


def parse_encoding(text: str) -> Encoding:
    """`L[:β][@d*][/E]` (β and d* as written, so that they key the CSV exactly)."""
    encoding, _, epochs = text.partition("/")
    encoding, _, truncation = encoding.partition("@")
    frequencies, _, base = encoding.partition(":")
    return (int(frequencies), str(float(base)) if base else LEGACY_BASE,
            str(float(truncation)) if truncation else LEGACY_TRUNCATION, int(epochs) if epochs else LEGACY_EPOCHS)


def setting_name(setting: Setting) -> str:
    L, base, bits, truncation, epochs = setting
    return f"L={L} β={base} b{bits} d*={truncation}" + ("" if epochs == LEGACY_EPOCHS else f" {epochs} epochs")


def bd_rate(anchor: list[tuple[float, float]], test: list[tuple[float, float]]) -> float | None:
    """Bjøntegaard delta rate of `test` against `anchor` ((bytes, CD) points): the mean difference
    of log(bytes) at equal log(CD) over the CD range both curves cover, as a fraction (-0.25: 25%
    fewer bytes). Piecewise-cubic Hermite interpolation of log(bytes) over log(CD) (the pchip form of
    the metric), each curve reduced to its lower envelope first. None when the ranges do not
    overlap or a curve has fewer than two points."""
    curves = []
    for points in (anchor, test):
        front: list[tuple[float, float]] = []
        for b, cd in sorted(points):
            if not front or cd < front[-1][1]:
                front.append((b, cd))
        if len(front) < 2:
            return None
        d = np.log([cd for _, cd in front])[::-1]  # increasing log CD
        r = np.log([b for b, _ in front])[::-1]
        curves.append((d, PchipInterpolator(d, r)))
    low = max(curves[0][0][0], curves[1][0][0])
    high = min(curves[0][0][-1], curves[1][0][-1])
    if high <= low:
        return None
    mean = [float(f.integrate(low, high)) / (high - low) for _, f in curves]
    return float(np.exp(mean[1] - mean[0]) - 1.0)


def load_points() -> dict[Key, dict[str, str]]:
    if not CSV.exists():
        return {}
    with CSV.open() as f:
        # early rows: 8 bits, β = 1.4, d* = 0.1, 60 epochs, seed 0
        rows = [{**r, "bits": r.get("bits") or "8", "base": r.get("base") or LEGACY_BASE, "seed": r.get("seed") or "0",
                 "truncation": r.get("truncation") or LEGACY_TRUNCATION,
                 "epochs": r.get("epochs") or str(LEGACY_EPOCHS)}
                for r in csv.DictReader(f)]
    return {(r["shape"], int(r["width"]), int(r["frequencies"]), r["base"], int(r["bits"]), r["truncation"],
             int(r["epochs"]), int(r["seed"])): r
            for r in rows}


def mean_point(rows: list[dict[str, str]]) -> tuple[float, float]:
    """Geometric means of bytes and CD over the seeds' rows of one point."""
    return (float(np.exp(np.mean([np.log(int(r["bytes"])) for r in rows]))),
            float(np.exp(np.mean([np.log(float(r["cd"])) for r in rows]))))


def save_points(points: dict[Key, dict[str, str]]) -> None:
    """Writes `points` merged with what the file holds now (another run may have added rows)."""
    points.update({k: r for k, r in load_points().items() if k not in points})
    partial = CSV.with_suffix(".csv.partial")
    with partial.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(points[k] for k in sorted(points))
    partial.replace(CSV)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=["bunny", "armadillo", "dragon", "spot", "happy"],
                        choices=list(SHAPES))
    parser.add_argument("--widths", nargs="+", type=int, default=[16, 24, 32, 48, 64])
    parser.add_argument("--frequencies", nargs="+", type=parse_encoding,
                        default=[(16, "1.4", "0.1", 60), (8, "1.4", "0.1", 60), (5, "1.8", "0.1", 60)],
                        metavar="L[:BETA][@D][/E]",
                        help="encodings: L frequencies, spaced by β (default 1.4), truncated at d* = D (default 0.1), "
                             "E epochs (default 60)")
    parser.add_argument("--bits", nargs="+", type=int, default=[8])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="encode every point at each seed")
    parser.add_argument("--anchor", nargs=2, default=["16", "8"], metavar=("L[:BETA][@D][/E]", "BITS"),
                        help="the setting the BD-rates are measured against")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--threads", type=int, default=None, help="torch threads per encode")
    args = parser.parse_args()

    done = load_points()
    OUT.mkdir(parents=True, exist_ok=True)
    keep = OUT / "freq"
    keep.mkdir(exist_ok=True)
    settings: list[Setting] = [(L, base, b, t, e) for b in args.bits for L, base, t, e in args.frequencies]
    for shape in args.shapes:
        rel, field, _ = SHAPES[shape]
        gt = None
        for width in args.widths:
            for (frequencies, base, bits, truncation, epochs), seed in itertools.product(settings, args.seeds):
                key = (shape, width, frequencies, base, bits, truncation, epochs, seed)
                if key in done:
                    continue
                if gt is None:
                    gt = load_shape(SHARED / "data" / rel)
                cfg = EncodeConfig(field=field, width=width, frequencies=frequencies, frequency_base=float(base),
                                   bits=bits, seed=seed, quiet=True, threads=args.threads,
                                   truncation=float(truncation), epochs=epochs)
                t0 = time.perf_counter()
                data = compress(gt, cfg).data
                seconds = time.perf_counter() - t0
                suffix = (("" if base == LEGACY_BASE else f"_beta{base}") + ("" if bits == 8 else f"_b{bits}")
                          + ("" if truncation == LEGACY_TRUNCATION else f"_d{truncation}")
                          + ("" if epochs == LEGACY_EPOCHS else f"_e{epochs}")
                          + ("" if seed == 0 else f"_s{seed}"))
                path = keep / f"{shape}_w{width}_L{frequencies}{suffix}.nfc"
                path.write_bytes(data)
                point = measure_nfc(gt, path, path.stem, args.resolution, seconds)
                done[key] = {
                    "shape": shape, "width": str(width), "frequencies": str(frequencies), "base": base,
                    "bits": str(bits), "bytes": str(point.bytes), "cd": f"{point.cd:.6g}",
                    "seconds": f"{seconds:.1f}", "seed": str(seed), "truncation": truncation,
                    "epochs": str(epochs)}
                save_points(done)
                name = setting_name((frequencies, base, bits, truncation, epochs))
                print(f"{shape} w{width} {name} seed {seed}: {point.bytes} B, "
                      f"CD {point.cd:.6g}, {seconds:.0f} s", flush=True)

    def point(shape: str, width: int, setting: Setting, seeds: list[int]) -> tuple[float, float] | None:
        """The point's mean over `seeds`, if every one of them was measured."""
        found = [done[k] for seed in seeds if (k := (shape, width, *setting, seed)) in done]
        return mean_point(found) if len(found) == len(seeds) else None

    names = [setting_name(s) for s in settings]
    seeds = "" if len(args.seeds) == 1 else f" (geometric means over seeds {', '.join(map(str, args.seeds))})"
    print(f"\nBytes / CD{seeds}\n")
    print("| shape | width | " + " | ".join(f"{n} bytes / CD" for n in names) + " |")
    print("|---|---:|" + "---:|" * len(settings))
    for shape in args.shapes:
        for width in args.widths:
            cells = []
            for setting in settings:
                mean = point(shape, width, setting, args.seeds)
                cells.append("—" if mean is None else f"{mean[0]:.0f} / {mean[1]:.5f}")
            print(f"| {shape} | {width} | " + " | ".join(cells) + " |")

    frequencies, base, truncation, epochs = parse_encoding(args.anchor[0])
    anchor: Setting = (frequencies, base, int(args.anchor[1]), truncation, epochs)
    others = [s for s in settings if s != anchor]
    print(f"\nBD-rate against {setting_name(anchor)} over widths {', '.join(map(str, args.widths))} "
          "(log bytes at equal log CD, pchip; negative: fewer bytes)\n")
    print("| shape | " + " | ".join(setting_name(s) for s in others) + " |")
    print("|---|" + "---:|" * len(others))
    for shape in args.shapes:
        def curve(setting: Setting, seeds: list[int]) -> list[tuple[float, float]]:
            return [m for width in args.widths if (m := point(shape, width, setting, seeds)) is not None]
        cells = []
        for setting in others:
            rate = bd_rate(curve(anchor, args.seeds), curve(setting, args.seeds))
            cell = "—" if rate is None else f"{100 * rate:+.1f}%"
            per_seed = [r for seed in args.seeds
                        if (r := bd_rate(curve(anchor, [seed]), curve(setting, [seed]))) is not None]
            if len(args.seeds) > 1 and per_seed:
                cell += f" [{100 * min(per_seed):+.1f}, {100 * max(per_seed):+.1f}]"
            cells.append(cell)
        print(f"| {shape} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
