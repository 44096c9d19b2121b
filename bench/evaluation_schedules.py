#!/usr/bin/env python3
"""Field evaluations per active finest cell under candidate sparse-grid schedules (issue 11).

Evaluates a file's SDF densely at the resolution's (r + 1)^3 grid vertices with the numpy reference
(nfencode.reference: the decoders' algorithm, f32), then replays each schedule on those values:
what it would evaluate, and which finest cells with a sign change it finds, against the dense
grid's (the "lost" column; 0 means the mesh is the dense grid's). The schedules:

  * keep rule: today's (libnfdecode/src/grid.h, nfencode.grid): every child of every kept cell,
    each new corner evaluated once;
  * cone L: the same, but a child is visited only if every corner k of its parent allows a zero
    in it under slope L, |f_k| <= t + L * (the farthest point of the child from k), t being the
    child's own keep threshold (0 at the finest level);
  * trilinear m: a child is visited only if the trilinear interpolation of its parent's corners
    at its corners changes sign or comes within t + m * h of zero;
  * surface following: below the dense coarsest level, each level visits only cells with a sign
    change: seeds are the cells around the halves of the coarser level's crossed edges (one
    evaluation at each crossed edge's midpoint), then a flood across every face with a sign change
    (the neighbour behind it has one too) until no new cell appears. Evaluations are then the
    corners of the cells with a sign change, plus the midpoints.

    python3 bench/evaluation_schedules.py bench/out/keep/bunny_w32.nfc --resolution 256
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from nfencode import bitstream, grid, reference
from nfencode.mc_tables import CORNER_OFFSET

Field = np.ndarray  # (r + 1)^3 f32 values, indexed [z, y, x] by fine vertex


def dense_field(path: Path, resolution: int) -> Field:
    fn = reference.field_function(bitstream.read_nfc(path.read_bytes()))
    n = resolution + 1
    axis = grid.grid_coordinates(np.arange(n), resolution)
    ys, xs = np.meshgrid(axis, axis, indexing="ij")
    values = np.empty((n, n, n), np.float32)
    for z in range(n):
        points = np.stack([xs.ravel(), ys.ravel(), np.full(n * n, axis[z])], axis=1)
        values[z] = fn(points.astype(np.float32)).reshape(n, n)
    return values


def values_at(field: Field, level: int, vertices: np.ndarray) -> np.ndarray:
    fine = vertices << level
    return field[fine[..., 2], fine[..., 1], fine[..., 0]]


def corner_values(field: Field, level: int, cells: np.ndarray) -> np.ndarray:
    return values_at(field, level, cells[:, None, :] + CORNER_OFFSET[None])


def sign_change(values: np.ndarray) -> np.ndarray:
    return (values < 0).any(axis=-1) & (values >= 0).any(axis=-1)


def keys_of(vertices: np.ndarray, side: int) -> np.ndarray:
    return grid.vertex_keys(vertices, side)


def new_evaluations(cells: np.ndarray, cells_per_axis: int,
                    known_above: np.ndarray) -> tuple[int, np.ndarray]:
    """Corners of `cells` not known from the level above (whose vertex keys, on its own grid, are
    `known_above`), and this level's corner keys."""
    side = cells_per_axis + 1
    keys = np.unique(keys_of((cells[:, None, :] + CORNER_OFFSET[None]).reshape(-1, 3), side))
    vertices = np.stack([keys % side, keys // side % side, keys // (side * side)], axis=1)
    even = (vertices % 2 == 0).all(axis=1)
    side_above = (cells_per_axis + 1) // 2 + 1
    above = np.zeros(len(keys), dtype=bool)
    above[even] = np.isin(keys_of(vertices[even] // 2, side_above), known_above)
    return int((~above).sum()), keys


def coarse_cells(resolution: int) -> tuple[int, np.ndarray]:
    top = grid.refinement_levels(resolution)
    n = grid.cells_at_level(resolution, top)
    axis = np.arange(n)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    return top, np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def trilinear_weights() -> np.ndarray:
    """[child, child corner, parent corner]: the weight of each parent corner at each corner of
    each child, in the parent's trilinear interpolation."""
    where = (CORNER_OFFSET[:, None, :] + CORNER_OFFSET[None, :, :]) / 2  # [child, corner, axis]
    ones = CORNER_OFFSET[None, None, :, :] == 1
    return np.prod(np.where(ones, where[:, :, None, :], 1 - where[:, :, None, :]), axis=3)


TRILINEAR = trilinear_weights()
HAMMING = (CORNER_OFFSET[:, None, :] != CORNER_OFFSET[None, :, :]).sum(axis=2)  # [child, corner]


def refine(field: Field, resolution: int, cull: str, parameter: float) -> tuple[int, np.ndarray]:
    """The keep rule's schedule, with an optional child cull: evaluations and the finest cells."""
    top, cells = coarse_cells(resolution)
    side = grid.cells_at_level(resolution, top) + 1
    evaluations = side ** 3
    known = np.arange(side ** 3)
    step = grid.grid_step(resolution)
    for level in range(top, 0, -1):
        h = step * np.float32(1 << level)
        f = corner_values(field, level, cells)
        kept = grid.cell_may_contain_surface(f, grid.keep_threshold(False, h))
        parents, f = cells[kept], f[kept]
        child_cells = grid.cells_at_level(resolution, level - 1)
        children = (2 * parents[:, None, :] + CORNER_OFFSET[None]).reshape(-1, 3)
        visit = (children < child_cells).all(axis=1)
        hc = float(h) / 2
        t = float(grid.keep_threshold(False, np.float32(hc))) if level > 1 else 0.0
        if cull == "cone":
            reach = hc * np.sqrt(3 + 3 * HAMMING)
            visit &= ~(np.abs(f)[:, None, :] > t + parameter * reach[None]).any(axis=2).reshape(-1)
        elif cull == "trilinear":
            g = np.einsum("ock,pk->poc", TRILINEAR, f)
            visit &= (sign_change(g) | (np.abs(g).min(axis=2) <= t + parameter * hc)).reshape(-1)
        cells = children[visit]
        new, known = new_evaluations(cells, child_cells, known)
        evaluations += new
    return evaluations, cells[sign_change(corner_values(field, 0, cells))]


def cube_edges() -> list[tuple[int, int, int]]:
    """(corner a, corner b, axis) of the 12 edges, b = a + the axis' unit step."""
    edges = []
    for a in range(8):
        for b in range(8):
            d = CORNER_OFFSET[b] - CORNER_OFFSET[a]
            if d.min() == 0 and d.sum() == 1:
                edges.append((a, b, int(np.argmax(d))))
    return edges


EDGES = cube_edges()
FACES = [(axis, side, [k for k in range(8) if CORNER_OFFSET[k][axis] == side])
         for axis in range(3) for side in (0, 1)]


def follow_surface(field: Field, resolution: int) -> tuple[int, np.ndarray]:
    """The surface-following schedule: evaluations and the finest cells with a sign change."""
    top, cells = coarse_cells(resolution)
    side = grid.cells_at_level(resolution, top) + 1
    evaluations = side ** 3
    known = np.arange(side ** 3)
    active = cells[sign_change(corner_values(field, top, cells))]
    for level in range(top - 1, -1, -1):
        n = grid.cells_at_level(resolution, level)
        f = corner_values(field, level + 1, active)
        seeds, midpoints = [], []
        for a, b, axis in EDGES:
            crossed = (f[:, a] < 0) != (f[:, b] < 0)
            start = 2 * (active[crossed] + CORNER_OFFSET[a])
            step = np.zeros(3, dtype=np.int64)
            step[axis] = 1
            middle = start + step
            midpoints.append(middle)
            ends = [values_at(field, level, start), values_at(field, level, middle),
                    values_at(field, level, middle + step)]
            for half, origin in enumerate((start, middle)):
                edge = origin[(ends[half] < 0) != (ends[half + 1] < 0)]
                others = [o for o in range(3) if o != axis]
                for d1 in (0, -1):
                    for d2 in (0, -1):
                        c = edge.copy()
                        c[:, others[0]] += d1
                        c[:, others[1]] += d2
                        seeds.append(c[((c >= 0) & (c < n)).all(axis=1)])
        frontier = np.unique(np.concatenate(seeds), axis=0)
        reached = set(keys_of(frontier, n).tolist())
        found = []
        while len(frontier):
            f = corner_values(field, level, frontier)
            crossing = sign_change(f)
            found.append(frontier[crossing])
            grow = []
            for axis, face, corners in FACES:
                through = crossing & sign_change(f[:, corners])
                neighbour = frontier[through].copy()
                neighbour[:, axis] += 1 if face else -1
                grow.append(neighbour[((neighbour >= 0) & (neighbour < n)).all(axis=1)])
            grown = np.unique(np.concatenate(grow), axis=0) if grow else np.zeros((0, 3), np.int64)
            fresh = [c for c, k in zip(grown, keys_of(grown, n).tolist()) if k not in reached]
            reached.update(keys_of(np.array(fresh), n).tolist() if fresh else [])
            frontier = np.array(fresh, dtype=np.int64).reshape(-1, 3)
        active = np.concatenate(found)
        new, known = new_evaluations(active, n, known)
        middle = np.unique(np.concatenate(midpoints), axis=0)
        new += int((~np.isin(keys_of(middle, n + 1), known)).sum())  # midpoints off the corners
        evaluations += new
    return evaluations, active


def sign_change_cells(field: Field) -> np.ndarray:
    """(N, 3) x, y, z of the dense grid's cells whose corners include f < 0 and f >= 0."""
    r = field.shape[0] - 1
    corners = np.stack([field[o[2]:r + o[2], o[1]:r + o[1], o[0]:r + o[0]]
                        for o in CORNER_OFFSET], axis=-1)
    z, y, x = np.nonzero(sign_change(corners))
    return np.stack([x, y, z], axis=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--resolution", type=int, default=256)
    args = ap.parse_args()
    print("| file | res | schedule | evaluations | per active cell | active cells | dense | lost |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for path in args.files:
        t0 = time.time()
        field = dense_field(path, args.resolution)
        dense = len(sign_change_cells(field))
        runs = [("keep rule", lambda: refine(field, args.resolution, "", 0.0))]
        runs += [(f"cone {L}", lambda L=L: refine(field, args.resolution, "cone", L))
                 for L in (1.0, 1.5)]
        runs += [(f"trilinear {m}", lambda m=m: refine(field, args.resolution, "trilinear", m))
                 for m in (0.0, 0.25)]
        runs += [("surface following", lambda: follow_surface(field, args.resolution))]
        for name, run in runs:
            evaluations, active = run()
            print(f"| {path.name} | {args.resolution} | {name} | {evaluations} | "
                  f"{evaluations / max(len(active), 1):.2f} | {len(active)} | {dense} | "
                  f"{dense - len(active)} |", flush=True)
        print(f"<!-- {path.name}: {time.time() - t0:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
