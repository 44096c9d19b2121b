#!/usr/bin/env python3
"""Geo-referenced frames (issue 13, item 6): a real scan moved far from its origin, encoded with the
64-bit frame (format 1.2, `fram`) and without it (the f32 frame of 1.0/1.1, emulated by switching
the encoder's `needs_frame64` off), decoded by the numpy reference (= libnfdecode's algorithm).

Per shape and offset it prints the file's bytes, whether it has `fram`, the frame error (the
largest distance between a decoded vertex as written and its exact placement
`center64 + u * scale64` of the same unit-frame vertex: in 1.2 `offset + f32(u * scale)`, in 1.1
the f32 original coordinate `f32(f32(u * scale) + f32 center)`), and the CD (metrics.md) of the
written surface against the ground truth, in the ground truth's frame (f64).

    .venv/bin/python bench/geo_frame.py --shapes milk office1 --offsets 0 1e5 6e5 5e6
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from nfencode import encoder
from nfencode.bitstream import read_nfc
from nfencode.encoder import EncodeConfig, compress
from nfencode.io import Shape, load_shape
from nfencode.metrics import chamfer_distance
from nfencode.reference import emitted_positions, extract_unit_mesh, frame_of, frame_offset

SHARED = Path(__file__).resolve().parents[2] / "shared"
SHAPES = {  # real scanned point clouds, in metres
    "milk": "colored/pcl_milk_color.ply.gz",
    "office1": "colored/pcl_office1.ply.gz",
    "bunny_scans": "stanford/bunny_scans/bun.conf",
}
RESOLUTION = 256
CD_SAMPLES = 100_000


def written_vertices(data: bytes) -> tuple[np.ndarray, np.ndarray, float]:
    """The decoded mesh as a decoder writes it (f64: offset + f32 position), its faces, and the
    frame error in the shape's units."""
    f = read_nfc(data)
    unit = extract_unit_mesh(f, RESOLUTION)
    written = frame_offset(f) + emitted_positions(f, unit.vertices).astype(np.float64)
    center, scale = frame_of(f.geometry)
    exact = center + unit.vertices.astype(np.float64) * scale
    return written, unit.faces, float(np.abs(written - exact).max()) if len(written) else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="+", default=["milk", "office1"], choices=sorted(SHAPES))
    ap.add_argument("--offsets", nargs="+", type=float, default=[0.0, 1e5, 6e5, 5e6],
                    help="metres added to x (and 1/3 of it to y)")
    ap.add_argument("--width", type=int, default=16)
    ap.add_argument("--epochs", type=int, default=None, help="override the fast preset's epochs")
    args = ap.parse_args()
    cfg = EncodeConfig(field="udf", width=args.width, epochs=args.epochs, seed=0, quiet=True)
    print("| shape | offset (m) | encoder | file | bytes | frame error | CD | encode s |")
    print("|---|---:|---|---|---:|---:|---:|---:|")
    for name in args.shapes:
        base = dataclasses.replace(load_shape(SHARED / "data" / SHAPES[name], colors="off"), faces=None)
        for offset in args.offsets:
            shape = dataclasses.replace(base, vertices=base.vertices + np.array([offset, offset / 3, 0.0]))
            for label, frame64 in (("64-bit frame when needed", True), ("f32 frame only (1.1)", False)):
                if not frame64 and offset == 0.0:
                    continue  # the same file
                original = encoder.needs_frame64
                if not frame64:
                    encoder.needs_frame64 = lambda center, scale: False  # type: ignore[assignment]
                try:
                    start = time.perf_counter()
                    data = compress(shape, cfg).data
                    seconds = time.perf_counter() - start
                finally:
                    encoder.needs_frame64 = original  # type: ignore[assignment]
                written, faces, error = written_vertices(data)
                cd = chamfer_distance(shape, Shape(written, faces, None, "decoded"), CD_SAMPLES, 0)
                f = read_nfc(data)
                fmt = f"{f.major}.{f.minor}" + (" + fram" if f.geometry.frame64 is not None else "")
                print(f"| {name} | {offset:.0f} | {label} | {fmt} | {len(data)} | {error * 1e3:.3g} mm | "
                      f"{cd:.5f} | {seconds:.0f} |", flush=True)


if __name__ == "__main__":
    main()
