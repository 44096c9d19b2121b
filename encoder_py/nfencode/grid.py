"""The sparse grid of libnfdecode/src/grid.h: coarse-to-fine field sampling near the surface.

Grid of `resolution` cells per axis over the unit frame [-1, 1]^3; vertex i sits at
-1 + 2 i / resolution, computed in f32 as libnfdecode does. Level l (0 = finest) has
ceil(resolution / 2^l) cells per axis; the coarsest level, refinement_levels() up, is visited
whole in raster order (x fastest). A cell is kept when its corner values change sign or
min |f| <= keep_threshold(udf, h) = margin * h * sqrt(3)/2 (f32 arithmetic; the margin is
SDF_KEEP_MARGIN or UDF_KEEP_MARGIN, chosen in grid.h); the kept cells pass their children,
in parent order and mc_tables.CORNER_OFFSET order within a parent, to the next level, dropping
children that start at or past the last cell. Vertices with all-even indices are copied from the
parent level, the others evaluated. Values are stored in f32, as the C++ grid stores them, so that
every decision downstream is taken on the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import InputError
from .mc_tables import CORNER_OFFSET, EDGE_CORNERS, HOLDS_TRIANGLE

FieldFn = Callable[[np.ndarray], np.ndarray]
"""Field values at (N, 3) float32 unit-frame points: (N,)."""
GradientFn = Callable[[np.ndarray], np.ndarray]
"""Field gradients (d value / d unit coordinate) at (N, 3) float32 unit-frame points: (N, 3)."""

MIN_RESOLUTION = 8  # NFD_MIN_RESOLUTION (include/nfdecode/nfdecode.h)
MAX_RESOLUTION = 1024  # NFD_MAX_RESOLUTION
MIN_COARSE = 32  # refinement stops before a level coarser than this (grid.h, refinement_levels)
SDF_KEEP_MARGIN = np.float32(1.0)  # kSdfKeepMargin
UDF_KEEP_MARGIN = np.float32(2.0)  # kUdfKeepMargin
HALF_DIAGONAL = np.float32(0.8660254)  # sqrt(3) / 2 as the f32 constant of grid.h
UDF_EDGE_FACTOR = np.float32(1.5)  # kUdfEdgeFactor


def cells_at_level(resolution: int, level: int) -> int:
    """ceil(resolution / 2^level)."""
    return (resolution + (1 << level) - 1) >> level


def refinement_levels(resolution: int) -> int:
    """The largest l with ceil(resolution / 2^l) >= MIN_COARSE, else 0."""
    levels = 0
    while levels < 31 and cells_at_level(resolution, levels + 1) >= MIN_COARSE:
        levels += 1
    return levels


def coarse_resolution(resolution: int) -> int:
    return cells_at_level(resolution, refinement_levels(resolution))


def grid_step(resolution: int) -> np.float32:
    """The fine cell edge in the unit frame, 2.0f / resolution."""
    return np.float32(2.0) / np.float32(resolution)


def grid_coordinates(fine_indices: np.ndarray, resolution: int) -> np.ndarray:
    """-1.0f + float(i) * step, element-wise in f32."""
    return np.float32(-1.0) + np.asarray(fine_indices).astype(np.float32) * grid_step(resolution)


def keep_threshold(udf: bool, h: np.float32) -> np.float32:
    """grid.h's keep_threshold for a cell of edge h: margin * h * sqrt(3)/2 in f32."""
    return (UDF_KEEP_MARGIN if udf else SDF_KEEP_MARGIN) * h * HALF_DIAGONAL


def cell_may_contain_surface(corner_values: np.ndarray, threshold: np.float32) -> np.ndarray:
    """grid.h's keep rule over (N, 8) f32 corner values. As in C++ (std::min), NaN corners are left
    out of min |f| and count as neither sign."""
    negative = (corner_values < 0).any(axis=1)
    positive = (corner_values >= 0).any(axis=1)
    min_abs = np.fmin.reduce(np.abs(corner_values), axis=1, initial=np.float32(np.inf))
    return (negative & positive) | (min_abs <= threshold)


def udf_edge_limit(h: np.float32) -> np.float32:
    """The largest f_a + f_b of a valid edge of a finest cell of edge h (grid.h, udf_edge_limit)."""
    return UDF_EDGE_FACTOR * h


def udf_cell_is_near(corner_values: np.ndarray, h: np.float32) -> np.ndarray:
    """A finest cell of a UDF may carry triangles: all corners finite, and its valid edges
    (f_a + f_b <= udf_edge_limit(h)) include the three edges of some triangle of the table."""
    finite = np.isfinite(corner_values).all(axis=1)
    sums = corner_values[:, EDGE_CORNERS[:, 0]] + corner_values[:, EDGE_CORNERS[:, 1]]
    valid = ((sums <= udf_edge_limit(h)) << np.arange(12)).sum(axis=1)
    return finite & HOLDS_TRIANGLE[valid]


@dataclass
class GridLevel:
    """The cells visited at one level, in visiting order, and the field at their corners."""

    level: int  # l: vertex v of this level is fine vertex v << l
    cells_per_axis: int
    cells: np.ndarray  # (N, 3) int64 cell coordinates (minimum corner)
    keys: np.ndarray  # (V,) int64 vertex_keys of the corners, sorted (raster order, x fastest)
    vertices: np.ndarray  # (V, 3) int64 corner coordinates, in key order
    corners: np.ndarray  # (N, 8) int64: the vertex of each cell corner, CORNER_OFFSET order
    values: np.ndarray  # (V,) float32

    @property
    def side(self) -> int:
        return self.cells_per_axis + 1

    def corner_values(self) -> np.ndarray:
        return self.values[self.corners]

    def find(self, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(index, found) for (M, 3) vertex coordinates, which may lie off the grid: found where the
        vertex is a corner of a visited cell, index valid only there."""
        on_grid = ((vertices >= 0) & (vertices < self.side)).all(axis=1)
        if len(self.keys) == 0:
            return np.zeros(len(vertices), dtype=np.int64), np.zeros(len(vertices), dtype=bool)
        keys = vertex_keys(np.where(on_grid[:, None], vertices, 0), self.side)
        index = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        return index, on_grid & (self.keys[index] == keys)


@dataclass
class SparseGrid:
    resolution: int
    levels: list[GridLevel]  # levels[l] is level l: levels[0] is the finest
    points_evaluated: int  # field value evaluations over all levels
    gradients: np.ndarray | None = None  # (V, 3) float32 per finest vertex, NaN off near cells
    gradients_evaluated: int = 0

    @property
    def step(self) -> np.float32:
        return grid_step(self.resolution)

    @property
    def finest(self) -> GridLevel:
        return self.levels[0]

    def coordinates(self, fine_indices: np.ndarray) -> np.ndarray:
        return grid_coordinates(fine_indices, self.resolution)


def vertex_keys(vertices: np.ndarray, side: int) -> np.ndarray:
    """Raster index (x fastest) of vertex coordinates on a grid of `side` vertices per axis."""
    return (vertices[..., 2] * side + vertices[..., 1]) * side + vertices[..., 0]


def _evaluate_level(
    field_fn: FieldFn, resolution: int, level: int, cells: np.ndarray, parent: GridLevel | None
) -> tuple[GridLevel, int]:
    """The level visiting `cells`, with its corner values, and the number of new evaluations."""
    side = cells_at_level(resolution, level) + 1
    corner_vertices = cells[:, None, :] + CORNER_OFFSET[None, :, :]
    keys, inverse = np.unique(vertex_keys(corner_vertices, side).ravel(), return_inverse=True)
    vertices = np.stack([keys % side, keys // side % side, keys // (side * side)], axis=1)
    values = np.empty(len(keys), dtype=np.float32)
    todo = np.ones(len(keys), dtype=bool)
    if parent is not None:
        todo = (vertices % 2 == 1).any(axis=1)
        index, found = parent.find(vertices[~todo] // 2)
        assert found.all(), "an even vertex of a child cell is a corner of its parent"
        values[~todo] = parent.values[index]
    values[todo] = field_fn(grid_coordinates(vertices[todo] << level, resolution))
    grid_level = GridLevel(level, side - 1, cells, keys, vertices, inverse.reshape(-1, 8), values)
    return grid_level, int(todo.sum())


def _children(level: GridLevel, step: np.float32, child_cells: int, udf: bool) -> np.ndarray:
    """The children of the cells that may contain the surface, in parent order, each parent's in
    CORNER_OFFSET order, dropping those that start at or past the last cell."""
    threshold = keep_threshold(udf, step * np.float32(1 << level.level))
    kept = level.cells[cell_may_contain_surface(level.corner_values(), threshold)]
    children = (2 * kept[:, None, :] + CORNER_OFFSET[None, :, :]).reshape(-1, 3)
    return children[(children < child_cells).all(axis=1)]


def _udf_gradients(gradient_fn: GradientFn, grid: SparseGrid) -> tuple[np.ndarray, int]:
    """Gradients at every corner of every near cell of the finest level, NaN elsewhere."""
    fine = grid.finest
    near = udf_cell_is_near(fine.corner_values(), grid.step)
    wanted = np.zeros(len(fine.values), dtype=bool)
    wanted[fine.corners[near].ravel()] = True
    gradients = np.full((len(fine.values), 3), np.nan, dtype=np.float32)
    gradients[wanted] = gradient_fn(grid.coordinates(fine.vertices[wanted]))
    return gradients, int(wanted.sum())


def build_grid(field_fn: FieldFn, resolution: int, udf_gradient: GradientFn | None = None) -> SparseGrid:
    """The sparse grid of `field_fn` at `resolution` (MIN_RESOLUTION..MAX_RESOLUTION); with
    `udf_gradient` the field is a UDF (its keep margin) and the gradients at the corners of the
    finest near cells are evaluated too."""
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise InputError(f"resolution {resolution} outside {MIN_RESOLUTION}..{MAX_RESOLUTION}")
    top = refinement_levels(resolution)
    n = cells_at_level(resolution, top)
    axis = np.arange(n, dtype=np.int64)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    cells = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)  # raster order, x fastest
    level, evaluated = _evaluate_level(field_fn, resolution, top, cells, None)
    levels = [level]
    for lower in range(top - 1, -1, -1):
        cells = _children(levels[0], grid_step(resolution), cells_at_level(resolution, lower),
                          udf_gradient is not None)
        level, new = _evaluate_level(field_fn, resolution, lower, cells, levels[0])
        levels.insert(0, level)
        evaluated += new
    grid = SparseGrid(resolution, levels, evaluated)
    if udf_gradient is not None:
        grid.gradients, grid.gradients_evaluated = _udf_gradients(udf_gradient, grid)
    return grid
