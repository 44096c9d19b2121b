#!/usr/bin/env python3
"""Where the sparse grid's SDF mesh differs from the dense grid's (issue 11, item 2).

For each file: the field on the dense (r + 1)^3 grid (numpy reference, f32), its sign-change
cells, and those the reference's sparse grid (nfencode.grid.build_grid: surface following, the
decoders' default) does not visit. Each lost cell is classed by the region of f >= 0 its
non-negative corners belong to (6-connected components of the dense grid's non-negative
vertices): "pocket" when no such region reaches the grid's boundary (a void inside the solid),
"outside" otherwise. Prints a markdown table.

    python3 bench/lost_cells.py bench/out/keep/dragon_w32.nfc --resolution 256
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy import ndimage

from evaluation_schedules import dense_field, sign_change_cells
from nfencode import bitstream, grid, reference
from nfencode.mc_tables import CORNER_OFFSET


def classify(field: np.ndarray, lost: np.ndarray) -> tuple[int, int, float]:
    """(lost cells on pockets, lost cells touching an outside region, the pockets' largest f)."""
    labels, _ = ndimage.label(field >= 0)
    faces = [labels[0], labels[-1], labels[:, 0], labels[:, -1], labels[:, :, 0], labels[:, :, -1]]
    outside = np.setdiff1d(np.unique(np.concatenate([f.ravel() for f in faces])), [0])
    corner_labels = np.stack([labels[lost[:, 2] + o[2], lost[:, 1] + o[1], lost[:, 0] + o[0]]
                              for o in CORNER_OFFSET], axis=1)
    touches_outside = np.isin(corner_labels, outside).any(axis=1)
    pocket_ids = np.setdiff1d(np.unique(corner_labels), np.concatenate([outside, [0]]))
    peak = max((float(field[labels == p].max()) for p in pocket_ids), default=0.0)
    return int((~touches_outside).sum()), int(touches_outside.sum()), peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--resolution", type=int, default=256)
    args = ap.parse_args()
    print("| file | res | dense sign-change cells | lost | on pockets | touching the outside | pockets' max f |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for path in args.files:
        field = dense_field(path, args.resolution)
        dense = sign_change_cells(field)
        nfc = bitstream.read_nfc(path.read_bytes())
        found = grid.build_grid(reference.field_function(nfc), args.resolution,
                                truncation=nfc.geometry.truncation).finest.cells
        side = args.resolution + 1
        lost = dense[~np.isin(grid.vertex_keys(dense, side), grid.vertex_keys(found, side))]
        pockets, outside, peak = classify(field, lost)
        print(f"| {path.name} | {args.resolution} | {len(dense)} | {len(lost)} | {pockets} | {outside} | "
              f"{peak:.4f} |", flush=True)


if __name__ == "__main__":
    main()
