#!/usr/bin/env python3
"""Thin synthetic shapes for the evaluations-per-active-cell figure (issue 11, item 2).

A shape whose surface is small next to its unit ball (a pole, a ring) meshes few active cells,
while every decode evaluates the whole 33^3 coarsest level: its evaluations per active cell are
the highest of any shape. Writes a rod (cylinder of radius 0.05, length 2) and a ring (torus of
major radius 1, minor radius 0.04) as OBJ and encodes each as an SDF with `nfc encode`; then

    build-bench/bench/keep_rule --resolutions 128,256,512 OUT/rod_w32.nfc OUT/ring_w32.nfc

    python3 bench/thin_shapes.py bench/out/thin [--width 32]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import trimesh

from nfencode import cli

SHAPES = {
    "rod": lambda: trimesh.creation.cylinder(radius=0.05, height=2.0, sections=64),
    "ring": lambda: trimesh.creation.torus(major_radius=1.0, minor_radius=0.04),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder for the .obj and .nfc files")
    parser.add_argument("--width", type=int, default=32)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, make in SHAPES.items():
        mesh_path = args.out / f"{name}.obj"
        make().export(mesh_path)
        encoded = args.out / f"{name}_w{args.width}.nfc"
        if cli.main(["encode", str(mesh_path), "-o", str(encoded), "--width", str(args.width),
                     "--field", "sdf"]) != 0:
            raise SystemExit(f"encoding {mesh_path} failed")


if __name__ == "__main__":
    main()
