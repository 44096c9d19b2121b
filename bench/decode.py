#!/usr/bin/env python3
"""Decode-speed benchmark: libnfdecode (`nfc-decode`, Vulkan or CPU) against the numpy reference
decoder and against the paper's decode path (dense grid evaluation of the same network in PyTorch,
then scikit-image marching cubes), on the same .nfc files in the same run.

Prints one markdown table: per file and resolution, median wall seconds of each path (from the .nfc
bytes to a mesh in memory; nfc-decode's per-stage split from --stats), peak RSS, and speed-ups.

    .venv/bin/python bench/decode.py bench/out/nfc/bunny_fast_w*.nfc --resolutions 128 256 512
"""

from __future__ import annotations

import argparse
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def run_libnfdecode(path: Path, resolution: int, device: str) -> tuple[dict[str, float], float]:
    """One nfc-decode run: its --stats lines as {stage: seconds} plus counts, and peak RSS in MB.
    `total` is bytes-in-memory to mesh-in-memory: parse + device init + field + mesh."""
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run(
            ["/usr/bin/time", "-f", "maxrss_kb %M", str(NFC_DECODE), str(path), "-o",
             f"{tmp}/out.ply", "--resolution", str(resolution), "--device", device, "--stats"],
            check=True, capture_output=True, text=True)
    stats: dict[str, float] = {}
    for line in (out.stdout + out.stderr).splitlines():
        m = re.match(r"([a-z_ ]+?)\s+([0-9.]+)( ms)?\b", line)
        if m:
            scale = 1e-3 if m.group(3) else 1.0
            stats[m.group(1).strip().replace(" ", "_")] = float(m.group(2)) * scale
    stats["total"] = sum(stats.get(k, 0.0) for k in ("parse", "device_init", "field", "mesh"))
    return stats, stats.get("maxrss_kb", float("nan")) / 1024


def time_reference(nfc, resolution: int) -> float:
    from nfencode.reference import extract_mesh

    t0 = time.perf_counter()
    extract_mesh(nfc, resolution=resolution)
    return time.perf_counter() - t0


def time_paper_path(nfc, resolution: int) -> float:
    """Dense (N+1)^3 grid through the network in PyTorch (chunks of 1M points), then skimage MC."""
    import torch
    from skimage.measure import marching_cubes

    from nfencode.reference import dequantize

    t0 = time.perf_counter()
    net = dequantize(nfc.geometry.network)
    freqs = torch.from_numpy(net.frequencies)
    layers = [(torch.from_numpy(w), torch.from_numpy(b)) for w, b in zip(net.weights, net.biases)]
    axis = torch.linspace(-1.0, 1.0, resolution + 1)
    values = torch.empty((resolution + 1) ** 3)
    grid = torch.stack(torch.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    with torch.no_grad():
        for start in range(0, len(grid), 1 << 20):
            u = grid[start:start + (1 << 20)]
            arg = u[:, None, :] * freqs[None, :, None]
            h = torch.cat([u, torch.cat([arg.sin(), arg.cos()], 2).reshape(len(u), -1)], 1)
            for i, (w, b) in enumerate(layers):
                h = h @ w.T + b
                if i < len(layers) - 1:
                    h = torch.sin(float(net.omega0) * h)
            values[start:start + len(u)] = h[:, 0]
    marching_cubes(values.reshape((resolution + 1,) * 3).numpy(), level=0.0)
    return time.perf_counter() - t0


def opt(x: float, spec: str, suffix: str = "") -> str:
    """A measurement, or a dash for a path that was not run."""
    return "—" if np.isnan(x) else f"{x:{spec}}{suffix}"


def median_of(fn, repeats: int) -> float:
    return statistics.median(fn() for _ in range(repeats))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--resolutions", nargs="+", type=int, default=[128, 256, 512])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--device", default="vulkan", choices=["vulkan", "cpu", "auto"])
    parser.add_argument("--no-paper", action="store_true", help="skip the dense PyTorch path")
    parser.add_argument("--no-reference", action="store_true", help="skip the numpy reference")
    args = parser.parse_args()
    if not NFC_DECODE.exists():
        sys.exit(f"decode.py: error: {NFC_DECODE} not built (run scripts/setup.sh)")

    from nfencode.bitstream import read_nfc

    print("| file | res | libnfdecode s | field s | mesh s | peak MB | triangles | "
          "reference s | paper path s | vs reference | vs paper |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for path in args.files:
        nfc = read_nfc(path.read_bytes())
        for res in args.resolutions:
            runs = [run_libnfdecode(path, res, args.device) for _ in range(args.repeats)]
            total = statistics.median(r[0].get("total", float("nan")) for r in runs)
            field = statistics.median(r[0].get("field", float("nan")) for r in runs)
            mesh = statistics.median(r[0].get("mesh", float("nan")) for r in runs)
            peak = max(r[1] for r in runs)
            tris = runs[0][0].get("triangles", float("nan"))
            ref = float("nan") if args.no_reference else median_of(
                lambda: time_reference(nfc, res), 1 if res > 256 else args.repeats)
            paper = float("nan") if args.no_paper else median_of(
                lambda: time_paper_path(nfc, res), 1 if res > 256 else args.repeats)
            print(f"| {path.name} | {res} | {total:.3f} | {field:.3f} | {mesh:.3f} | {peak:.0f} | "
                  f"{tris:.0f} | {opt(ref, '.2f')} | {opt(paper, '.2f')} | "
                  f"{opt(ref / total, '.1f', 'x')} | {opt(paper / total, '.1f', 'x')} |", flush=True)
    print(f"\npython peak RSS (reference + paper paths): "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
