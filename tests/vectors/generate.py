#!/usr/bin/env python3
"""Writes the golden vectors. Run only on purpose (`.venv/bin/python tests/vectors/generate.py`):
an existing `.nfc` is never re-encoded (a vector's bytes and field values are fixed for good; a
format change gets new names), only its meshes are rewritten from it, when the reference decoder's
algorithm changes on purpose.

For each vector `v1_0_<name>` (geometry only, format 1.0), `v1_1_<name>` (with colour, 1.1) or
`v1_2_<name>` (geometry with a 64-bit frame, 1.2):
  <name>.nfc          a real encode of a shape from ../shared/data (short schedule: these vectors
                      test decoding, not rate-distortion); written once
  <name>.values.txt   `x y z value` per line: unit-frame query points and the numpy reference
                      decoder's field values (%.9g); written once, with the .nfc
  <name>.colours.txt  (v1_1 only) `x y z r g b`: the same points and the reference colours in
                      [0, 1] (%.9g); written once, with the .nfc
  <name>.mesh64.ply   the reference decoder's mesh at resolution 64 (SDF or UDF), original frame
                      relative to the frame offset (v1_2: the 64-bit center; else 0), vertices
                      and faces in the reference's order (README.md); v1_1: float red, green,
                      blue in [0, 1] per vertex after the normal
  <name>.grid128.txt  the reference's sparse grid at 128, whose two levels below the coarsest
                      follow the surface (at 64 only the finest does): per level, coarsest first,
                      `level L cells C vertices V`, then `evaluated E`, the field points evaluated
                      over all levels, and for a UDF `gradients G`, the gradient points
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from nfencode.bitstream import FIELD_SDF, read_nfc
from nfencode.encoder import EncodeConfig, compress
from nfencode.grid import build_grid
from nfencode.io import load_shape, save_mesh
from nfencode.reference import (dequantize, evaluate, evaluate_color, extract_mesh, field_function,
                                gradient_function)

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"  # ../shared beside the checkout
MESH_RESOLUTION = 64
GRID_RESOLUTION = 128
VECTORS = [  # name, shape, field, width, bits, frequencies L, β, epochs, colour width (None: geometry only)
    ("v1_0_bunny_sdf_w16", "stanford/bun_zipper_res3.ply.gz", "sdf", 16, 8, 16, 1.4, 40, None),
    ("v1_0_bunny_sdf_w32", "stanford/bun_zipper_res3.ply.gz", "sdf", 32, 8, 16, 1.4, 40, None),
    ("v1_0_spot_sdf_w24_b6", "misc/spot.obj.gz", "sdf", 24, 6, 16, 1.4, 40, None),
    ("v1_0_tshirt_udf_w16", "garments/TShirtNoCoat.obj.gz", "udf", 16, 8, 16, 1.4, 30, None),
    # The bunny's ten range scans merged by bun.conf's transforms: a point cloud (nfencode.io).
    ("v1_0_bunny_scans_udf_w16", "stanford/bunny_scans/bun.conf", "udf", 16, 8, 16, 1.4, 30, None),
    # A coloured point cloud (13,704 points): colour network of width 16 at 8 bits.
    ("v1_1_milk_udf_w16_c16", "colored/pcl_milk_color.ply.gz", "udf", 16, 8, 16, 1.4, 30, 16),
    # The colour network of the 0.13.12 encoder: three sine layers at ω₀ = 20 (four linear layers).
    ("v1_1_milk_udf_w16_L8_c16_deep", "colored/pcl_milk_color.ply.gz", "udf", 16, 8, 8, 1.4, 30, 16),
    # The range-scan cloud placed as geo-referenced survey data (UTM-like metres, GEO_OFFSETS):
    # the encoder keeps its frame in 64 bits.
    ("v1_2_bunny_scans_geo_udf_w16", "stanford/bunny_scans/bun.conf", "udf", 16, 8, 16, 1.4, 30, None),
    # The encoder's default since 0.6: 8 frequencies (51 inputs to the first layer).
    ("v1_0_armadillo_sdf_w24_L8", "stanford/armadillo_remeshed_odedstein.obj.gz", "sdf", 24, 8, 8, 1.4, 40, None),
    # `--frequencies 5 --frequency-base 1.8` (the same top frequency as L = 8, β = 1.4 with 33 inputs
    # to the first layer): an L that is no multiple of the GPU kernel's blocks of 4, a β other than
    # 1.4, on a garment UDF (value and gradient kernels).
    ("v1_0_pants_udf_w16_L5", "garments/Pants1.obj.gz", "udf", 16, 8, 5, 1.8, 30, None),
    # The encoder's default since 2026-12-07: 7 frequencies at β = 1.5 (45 inputs to the first
    # layer; an L that is no multiple of 4 on an SDF) and an SDF's d* = 0.05.
    ("v1_0_armadillo_sdf_w24_L7", "stanford/armadillo_remeshed_odedstein.obj.gz", "sdf", 24, 8, 7, 1.5, 40, None),
    # The dragon's thin parts at the same default: at 128 some vertices above the finest level lie
    # within half a cell of zero with no child around them reached by the flood, so the flood goes
    # on from them (grid.h, step 1, since 0.13.17; here without new cells): C++ and numpy seed and
    # evaluate the same points.
    ("v1_0_dragon_sdf_w32_L7", "stanford/dragon_vrip_res3.ply.gz", "sdf", 32, 8, 7, 1.5, 40, None),
]
GEO_OFFSETS = {"v1_2_bunny_scans_geo_udf_w16": (600123.456, 200654.321, 0.0)}  # added to the shape
COLOR_EPOCHS = 30  # the colour schedule's epochs for the v1_1 vectors (short, as the geometry's)


def query_points(seed: int = 1234) -> np.ndarray:
    """Fixed unit-frame queries: a uniform set in the cube plus the extreme corners (where the
    positional encoding's arguments are largest)."""
    rng = np.random.default_rng(seed)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return np.concatenate([rng.uniform(-1, 1, (1016, 3)), corners]).astype(np.float32)


def encode(name: str, rel: str, field: str, width: int, bits: int, frequencies: int, frequency_base: float,
           epochs: int, color_width: int | None) -> None:
    stem = HERE / name
    config = EncodeConfig(field=field, width=width, bits=bits, frequencies=frequencies, frequency_base=frequency_base,
                          epochs=epochs, seed=7, quiet=True, color="off" if color_width is None else "on",
                          color_width=color_width or 16, color_epochs=COLOR_EPOCHS)
    shape = load_shape(DATA / rel)
    if name in GEO_OFFSETS:
        shape = dataclasses.replace(shape, vertices=shape.vertices + np.asarray(GEO_OFFSETS[name]))
    data = compress(shape, config).data
    stem.with_suffix(".nfc").write_bytes(data)
    points = query_points()
    nfc = read_nfc(data)
    values = evaluate(dequantize(nfc.geometry.network), points)
    np.savetxt(stem.with_suffix(".values.txt"), np.column_stack([points, values]), fmt="%.9g")
    if nfc.color is not None:
        colors = evaluate_color(dequantize(nfc.color.network), points)
        np.savetxt(stem.with_suffix(".colours.txt"), np.column_stack([points, colors]), fmt="%.9g")
    print(f"{stem.name}: encoded, {len(data)} bytes")


def grid_summary(data: bytes) -> str:
    """The `.grid128.txt` text of a vector's `.nfc` bytes."""
    nfc = read_nfc(data)
    udf = nfc.geometry.field_type != FIELD_SDF
    grid = build_grid(field_function(nfc), GRID_RESOLUTION, gradient_function(nfc) if udf else None,
                      truncation=nfc.geometry.truncation)
    lines = [f"level {lv.level} cells {len(lv.cells)} vertices {len(lv.values)}"
             for lv in reversed(grid.levels)]
    lines.append(f"evaluated {grid.points_evaluated}")
    if udf:
        lines.append(f"gradients {grid.gradients_evaluated}")
    return "\n".join(lines) + "\n"


def main() -> None:
    for name, *encoding in VECTORS:
        stem = HERE / name
        if not stem.with_suffix(".nfc").exists():
            encode(name, *encoding)
        mesh = extract_mesh(read_nfc(stem.with_suffix(".nfc").read_bytes()), MESH_RESOLUTION)
        colors = None if mesh.colors is None else mesh.colors.astype(np.float32)
        save_mesh(stem.with_suffix(f".mesh{MESH_RESOLUTION}.ply"), mesh.vertices, mesh.faces, mesh.normals, colors)
        print(f"{stem.name}: mesh at {MESH_RESOLUTION}, {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles")
        summary = grid_summary(stem.with_suffix(".nfc").read_bytes())
        stem.with_suffix(f".grid{GRID_RESOLUTION}.txt").write_text(summary)


if __name__ == "__main__":
    main()
