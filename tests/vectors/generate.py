#!/usr/bin/env python3
"""Regenerates the golden vectors. Run only on purpose (a format change gets new names; old vectors
are never deleted): `.venv/bin/python tests/vectors/generate.py`.

For each vector `v1_0_<name>`:
  <name>.nfc          a real encode of a shape from ../shared/data (short schedule: these vectors
                      test decoding, not rate-distortion)
  <name>.values.txt   `x y z value` per line: unit-frame query points and the numpy reference
                      decoder's field values (%.9g)
  <name>.mesh64.ply   SDF only: the reference decoder's mesh at resolution 64, original frame
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nfencode.bitstream import read_nfc
from nfencode.encoder import EncodeConfig, compress
from nfencode.io import load_shape, save_mesh
from nfencode.reference import dequantize, evaluate, extract_mesh

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"  # ../shared beside the checkout
VECTORS = [  # name, shape, field, width, bits, epochs
    ("bunny_sdf_w16", "stanford/bun_zipper_res3.ply.gz", "sdf", 16, 8, 40),
    ("bunny_sdf_w32", "stanford/bun_zipper_res3.ply.gz", "sdf", 32, 8, 40),
    ("spot_sdf_w24_b6", "misc/spot.obj.gz", "sdf", 24, 6, 40),
    ("tshirt_udf_w16", "garments/TShirtNoCoat.obj.gz", "udf", 16, 8, 30),
]


def query_points(seed: int = 1234) -> np.ndarray:
    """Fixed unit-frame queries: a uniform set in the cube plus the extreme corners (where the
    positional encoding's arguments are largest)."""
    rng = np.random.default_rng(seed)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return np.concatenate([rng.uniform(-1, 1, (1016, 3)), corners]).astype(np.float32)


def main() -> None:
    for name, rel, field, width, bits, epochs in VECTORS:
        shape = load_shape(str(DATA / rel))
        config = EncodeConfig(field=field, width=width, bits=bits, epochs=epochs, seed=7,
                              quiet=True)
        data = compress(shape, config).data
        stem = HERE / f"v1_0_{name}"
        stem.with_suffix(".nfc").write_bytes(data)
        nfc = read_nfc(data)
        points = query_points()
        values = evaluate(dequantize(nfc.geometry.network), points)
        np.savetxt(stem.with_suffix(".values.txt"), np.column_stack([points, values]),
                   fmt="%.9g")
        if nfc.geometry.field_type == 0:
            vertices, faces, normals, _ = extract_mesh(nfc, resolution=64)
            save_mesh(str(stem.with_suffix(".mesh64.ply")), vertices, faces, normals)
        print(f"{stem.name}: {len(data)} bytes")


if __name__ == "__main__":
    main()
