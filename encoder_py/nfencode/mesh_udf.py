"""Pseudo-signed marching cubes of an unsigned field (libnfdecode/src/extract.h, "UDF", steps 1-7).

A UDF has no sign; MeshUDF (Guillard et al., ECCV 2022) recovers one locally from the gradient,
since corners on opposite sides of the surface have opposite gradient directions. Per cell:
  1. only near cells (grid.udf_cell_is_near) are meshed;
  2. the cell orientation n is the gradient at its smallest-valued corner (lowest index on ties),
     made canonical (largest-magnitude component positive, lowest axis on ties); none if n is zero
     or not finite;
  3. corner c is inside when dot(g_c, n) < 0;
  4. a crossed edge a-b gets its vertex at t = f_a / (f_a + f_b) (0.5 when the sum is 0);
  5. a triangle is emitted only when its three edges are valid: f_a + f_b <= grid.udf_edge_limit(h);
  6. the vertex normal is canonical(g_a - g_b) normalised, else the edge axis;
  7. order as for the SDF mesher.
All arithmetic in f32, in the order of mesh_udf_cpu.cpp.
"""

from __future__ import annotations

import numpy as np

from .grid import SparseGrid, udf_cell_is_near, udf_edge_limit
from .marching import CrossedEdges, UnitMesh, edge_points, march_cells


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a . b in f32, summed x, y, z in that order as C++ does."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def canonical_direction(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(v flipped so that its largest-magnitude component, lowest axis on ties, is positive; usable):
    unusable rows are zero or not finite."""
    rows = np.arange(len(v))
    major = v[rows, np.argmax(np.abs(v), axis=1)]
    usable = np.isfinite(v).all(axis=1) & (major != 0)
    return np.where((major > 0)[:, None], v, -v), usable


def mesh_udf(grid: SparseGrid) -> UnitMesh:
    """The surface of the grid's unsigned field, unit frame; needs grid.gradients."""
    level, gradients = grid.finest, grid.gradients
    if gradients is None:
        raise ValueError("the UDF mesher needs a grid built with gradients")
    max_edge_sum = udf_edge_limit(grid.step)

    def classify(corner_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        near = np.nonzero(udf_cell_is_near(corner_values, grid.step))[0]
        nearest = np.argmin(corner_values[near], axis=1)  # the first of equal minima
        g = gradients[level.corners[near]]  # (near cells, 8, 3)
        n, oriented = canonical_direction(g[np.arange(len(near)), nearest])
        meshed = np.zeros(len(corner_values), dtype=bool)
        cases = np.zeros(len(corner_values), dtype=np.int64)
        meshed[near] = oriented
        cases[near] = ((_dot(g, n[:, None, :]) < 0) << np.arange(8)).sum(axis=1)
        return meshed, cases

    def edge_valid(edges: CrossedEdges) -> np.ndarray:
        return edges.fa + edges.fb <= max_edge_sum

    def place(edges: CrossedEdges) -> tuple[np.ndarray, np.ndarray]:
        total = edges.fa + edges.fb
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(total > 0, edges.fa / total, np.float32(0.5))
            d = gradients[edges.index_a] - gradients[edges.index_b]
            m, usable = canonical_direction(d)
            length = np.sqrt(_dot(d, d))
            usable &= (length > 0) & np.isfinite(length)
            normals = m / length[:, None]
        fallback = np.zeros_like(d)
        fallback[np.arange(len(d)), edges.axis] = 1.0
        return edge_points(grid, edges, t.astype(np.float32)), np.where(usable[:, None], normals, fallback)

    return march_cells(grid, classify, edge_valid, place)
