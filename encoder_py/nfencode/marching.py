"""The marching-cubes loop shared by the SDF and UDF meshers (libnfdecode/src/marching.h).

Cells of the finest level in grid order, the generated table (mc_tables), one welded vertex per
grid edge, triangles in cell then table order, vertices numbered by first use. The meshers differ
only in how a cell gets its case (`classify`), which edges may carry a vertex (`edge_valid`: a
triangle is emitted only when its three edges are valid) and where a vertex sits (`place`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Callable, NamedTuple

import numpy as np

from .grid import SparseGrid
from .mc_tables import CORNER_OFFSET, EDGE_AXIS, EDGE_CORNERS, TRIANGLE_COUNT, TRIANGLES


@dataclass
class CrossedEdges:
    """Grid edges, one per row: from vertex `origin` (finest-level coordinates) along `axis`, with
    the finest-level vertex indices and the f32 values of its two ends."""

    origin: np.ndarray  # (K, 3) int64
    axis: np.ndarray  # (K,) int64
    index_a: np.ndarray  # (K,) int64
    index_b: np.ndarray  # (K,) int64
    fa: np.ndarray  # (K,) float32
    fb: np.ndarray  # (K,) float32

    def take(self, rows: np.ndarray) -> CrossedEdges:
        return CrossedEdges(*(getattr(self, f.name)[rows] for f in fields(self)))


class UnitMesh(NamedTuple):
    vertices: np.ndarray  # (V, 3) float32, unit frame
    faces: np.ndarray  # (F, 3) int64
    normals: np.ndarray  # (V, 3) float32
    active_cells: int  # finest cells that emitted a triangle


Classify = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""(N, 8) f32 corner values -> (meshed (N,) bool, case index (N,) int64)."""
EdgeValid = Callable[[CrossedEdges], np.ndarray]
Place = Callable[[CrossedEdges], tuple[np.ndarray, np.ndarray]]
"""Crossed edges -> (unit-frame positions (K, 3) f32, normals (K, 3) f32)."""


def march_cells(grid: SparseGrid, classify: Classify, edge_valid: EdgeValid | None, place: Place) -> UnitMesh:
    level = grid.finest
    meshed, cases = classify(level.corner_values())
    triangles = np.where(meshed, TRIANGLE_COUNT[cases], 0)
    # One row per triangle corner, in cell order then table order.
    cell = np.repeat(np.arange(len(cases)), 3 * triangles)
    first_slot = np.cumsum(3 * triangles) - 3 * triangles
    edge = TRIANGLES[cases[cell], np.arange(len(cell)) - first_slot[cell]]
    a, b = EDGE_CORNERS[edge, 0], EDGE_CORNERS[edge, 1]
    index_a, index_b = level.corners[cell, a], level.corners[cell, b]
    edges = CrossedEdges(
        level.cells[cell] + CORNER_OFFSET[a], EDGE_AXIS[edge], index_a, index_b,
        level.values[index_a], level.values[index_b],
    )
    if edge_valid is not None:
        emitted = np.repeat(edge_valid(edges).reshape(-1, 3).all(axis=1), 3)
        edges, cell = edges.take(emitted), cell[emitted]

    # Welding: one vertex per grid edge (start vertex, axis), numbered by first use.
    keys = edges.index_a * 3 + edges.axis
    _, first_use, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first_use)
    number = np.empty_like(order)
    number[order] = np.arange(len(order))
    positions, normals = place(edges.take(first_use[order]))
    faces = number[inverse].reshape(-1, 3)
    return UnitMesh(positions, faces, normals, len(np.unique(cell)))


def edge_points(grid: SparseGrid, edges: CrossedEdges, t: np.ndarray) -> np.ndarray:
    """The unit-frame point at t (f32) along each edge: u[axis] += t * (coord(v + 1) - u[axis])."""
    u = grid.coordinates(edges.origin)
    rows = np.arange(len(u))
    start = u[rows, edges.axis]
    u[rows, edges.axis] = start + t * (grid.coordinates(edges.origin[rows, edges.axis] + 1) - start)
    return u
