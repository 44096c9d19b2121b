"""Marching cubes of a signed field over the sparse grid (libnfdecode/src/extract.h, "SDF").

Case bit c is set when f(corner c) < 0; a crossed edge a-b gets its vertex at t = f_a / (f_a - f_b)
(0.5 where that is not in [0, 1]: an infinite corner). Normals are the normalised gradient of the
grid values, with no field evaluation of their own: along the edge f_b - f_a, across it (axis b) the
derivatives at both ends lerped by t, each central (f(w + e_b) - f(w - e_b)) / 2 where both
neighbours were evaluated, one-sided where one was, 0 where neither was. Where the gradient
vanishes, the edge direction from its inside to its outside end. All arithmetic in f32, in the
order of mesh_sdf_cpu.cpp.
"""

from __future__ import annotations

import numpy as np

from .grid import GridLevel, SparseGrid
from .marching import CrossedEdges, UnitMesh, edge_points, march_cells

_HALF = np.float32(0.5)


def _classify(corner_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cases = ((corner_values < 0) << np.arange(8)).sum(axis=1)
    return np.ones(len(cases), dtype=bool), cases


def _grid_derivative(level: GridLevel, w: np.ndarray, fw: np.ndarray, b: int) -> np.ndarray:
    """Derivative along axis b at vertices w (values fw), in units of 1 / cell."""
    step = np.eye(3, dtype=np.int64)[b]
    hi_index, has_hi = level.find(w + step)
    lo_index, has_lo = level.find(w - step)
    hi, lo = level.values[hi_index], level.values[lo_index]
    return np.where(
        has_hi & has_lo, _HALF * (hi - lo),
        np.where(has_hi, hi - fw, np.where(has_lo, fw - lo, np.float32(0.0))),
    ).astype(np.float32)


def _edge_normals(level: GridLevel, edges: CrossedEdges, t: np.ndarray) -> np.ndarray:
    rows = np.arange(len(t))
    far_end = edges.origin.copy()
    far_end[rows, edges.axis] += 1
    g = np.empty((len(t), 3), dtype=np.float32)
    for b in range(3):
        d0 = _grid_derivative(level, edges.origin, edges.fa, b)
        d1 = _grid_derivative(level, far_end, edges.fb, b)
        g[:, b] = d0 + t * (d1 - d0)
    g[rows, edges.axis] = edges.fb - edges.fa
    length = np.sqrt(g[:, 0] * g[:, 0] + g[:, 1] * g[:, 1] + g[:, 2] * g[:, 2])
    usable = (length > 0) & np.isfinite(length)
    with np.errstate(divide="ignore", invalid="ignore"):
        normals = g / length[:, None]
    # A flat field at the vertex: its edge still tells inside from outside.
    fallback = np.zeros_like(g)
    fallback[rows, edges.axis] = np.where(edges.fa < 0, np.float32(1.0), np.float32(-1.0))
    return np.where(usable[:, None], normals, fallback)


def mesh_sdf(grid: SparseGrid) -> UnitMesh:
    """The zero level set of the grid's field, unit frame; triangles counter-clockwise seen from
    the positive side, normals towards it."""

    def place(edges: CrossedEdges) -> tuple[np.ndarray, np.ndarray]:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = edges.fa / (edges.fa - edges.fb)
        t = np.where((t >= 0) & (t <= 1), t, _HALF)
        return edge_points(grid, edges, t), _edge_normals(grid.finest, edges, t)

    return march_cells(grid, _classify, None, place)
