#!/usr/bin/env python3
"""Decoded surface that lies outside the shape's ball: the fit's floaters (FORMAT.md, "The shape's ball").

An encoder puts the shape inside the unit ball of its frame, so a connected component of a decoded
mesh whose every vertex lies farther than `--radius` from the origin (unit frame) is not the
shape's. Per file: `nfc-decode --device cpu --resolution R` of this tree's build (and with
--baseline of another build, e.g. the previous release's from a `git worktree`), the mesh's
components, those beyond the radius (how many, their faces, the range of their vertices' norms)
and the largest vertex norm. Prints a markdown table of the files where either build has such a
component, then a summary line over all files.

    .venv/bin/python bench/beyond_ball.py bench/out/nfc/*.nfc --baseline /tmp/old/build/samples/nfc-decode
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from evaluations import NFC_DECODE, run
from nfencode.bitstream import read_nfc
from nfencode.io import load_shape
from nfencode.reference import frame_of


def beyond(decoder: Path, path: Path, frame: tuple[np.ndarray, float], resolution: int,
           radius: float) -> tuple[int, int, str, float]:
    """(components, faces of those entirely beyond `radius`, their norm range, largest norm) of the
    mesh `decoder` extracts from `path`, whose unit frame is `frame` (center, scale)."""
    center, scale = frame
    with tempfile.TemporaryDirectory() as tmp:
        run(decoder, path, f"{tmp}/m.ply", "--resolution", str(resolution))
        mesh = load_shape(f"{tmp}/m.ply")
    if mesh.faces is None or len(mesh.faces) == 0:
        return 0, 0, "-", 0.0
    norm = np.linalg.norm((mesh.vertices - center) / scale, axis=1)
    n, faces = len(norm), mesh.faces
    edges = coo_matrix((np.ones(faces.size), (np.repeat(faces[:, 0], 3), faces.ravel())), shape=(n, n))
    count, label = connected_components(edges, directed=False)
    nearest = np.full(count, np.inf)
    np.minimum.at(nearest, label, norm)
    outside = nearest > radius
    if not outside.any():
        return count, 0, "-", float(norm.max())
    on = outside[label]
    return (count, int(outside[label[faces[:, 0]]].sum()),
            f"{norm[on].min():.3f}-{norm[on].max():.3f}", float(norm.max()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--resolution", type=int, default=256)
    ap.add_argument("--radius", type=float, default=1.02, help="unit-frame radius (default 1.02)")
    ap.add_argument("--baseline", type=Path, help="another nfc-decode build to compare with")
    args = ap.parse_args()

    builds = [("this build", NFC_DECODE)] + ([("baseline", args.baseline)] if args.baseline else [])
    print("| file | " + " | ".join(f"{name}: faces beyond, their norms, largest norm" for name, _ in builds) + " |")
    print("|---" * (1 + len(builds)) + "|")
    with_floaters = {name: 0 for name, _ in builds}
    for path in args.files:
        frame = frame_of(read_nfc(path.read_bytes()).geometry)
        rows = [beyond(decoder, path, frame, args.resolution, args.radius) for _, decoder in builds]
        for (name, _), row in zip(builds, rows):
            with_floaters[name] += row[1] > 0
        if any(row[1] for row in rows):
            cells = " | ".join(f"{faces}, {norms}, {largest:.3f}" for _, faces, norms, largest in rows)
            print(f"| {path.name} | {cells} |", flush=True)
    print(f"\n{len(args.files)} files at {args.resolution}, components beyond {args.radius}: " +
          "; ".join(f"{name} {n} files" for name, n in with_floaters.items()))


if __name__ == "__main__":
    main()
