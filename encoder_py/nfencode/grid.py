"""The sparse grid of libnfdecode/src/grid.h: coarse-to-fine field sampling near the surface.

Grid of `resolution` cells per axis over the unit frame [-1, 1]^3; vertex i sits at
-1 + 2 i / resolution, computed in f32 as libnfdecode does. Level l (0 = finest) has
ceil(resolution / 2^l) cells per axis; the coarsest level, refinement_levels() up, is visited
whole in raster order (x fastest), its values from coarsest_values(): above the finest level, a
probe level twice as coarse is evaluated first, then the child vertices of the probe cells that
the keep rule keeps, and the other vertices hold the mean of the probe vertices around them.
Below it (grid.h has the rules and their reasons):

* The band (build_grid's `band`), the keep rule: a cell is kept when
  its corners change sign (SDF) or min |f| <= keep_threshold(udf, h) = margin * h * sqrt(3)/2
  (f32 arithmetic); the kept cells pass their children, in parent order and
  mc_tables.CORNER_OFFSET order within a parent, to the next level, dropping children that start
  at or past the last cell.
* SDF, surface following (libnfdecode/src/grid_follow.cpp): a level visits the cells seeded at
  the crossed edges of the sign-change cells above, flooded across faces with a sign change and,
  above the finest level, across every face of a cell whose corners all lie within
  SDF_NEAR_ZERO_CELL * h of zero, inside the region of those cells and their 26 neighbours, plus
  every child of the isolated cells above (no sign change, no sign-change neighbour, kept by the
  keep rule held to SDF_ISOLATED_TRUNCATION * the file's d*, or above the finest level a corner
  within SDF_NEAR_ZERO_CELL * the finest step of zero: isolated_threshold()); then, above the
  finest level, flooded again from the children around each vertex above within
  SDF_NEAR_ZERO_VERTEX * h of zero none of which the flood visited, or within
  SDF_SECOND_SHEET_VERTEX * h whether or not (inside the region); in visit_order().
* UDF, surface following with the mesher's valid edges (f_a + f_b <= udf_edge_limit(h)) in place
  of sign changes: seeded at the children holding a valid half of each valid edge of the cells
  above, and at every child of a cell above with a valid edge but no seed in itself or its 26
  neighbours; flooded across faces holding an edge with f_a + f_b <= UDF_FLOOD_EDGE * h, inside
  the region of the cells above with a valid edge and their 26 neighbours, plus every child of
  the isolated cells above (UDF keep margin, no valid edge, no such neighbour); in visit_order().

Vertices with all-even indices are copied from the parent level where it has them, the others
evaluated. Values are stored in f32, as the C++ grid stores them, so that every decision downstream
is taken on the same numbers.
"""

from __future__ import annotations

import math
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
UDF_KEEP_MARGIN = np.float32(1.5)  # kUdfKeepMargin
SDF_NEAR_ZERO_CELL = np.float32(0.5)  # kSdfNearZeroCell
SDF_NEAR_ZERO_VERTEX = np.float32(0.5)  # kSdfNearZeroVertex
SDF_SECOND_SHEET_VERTEX = np.float32(0.15)  # kSdfSecondSheetVertex
SDF_ISOLATED_TRUNCATION = np.float32(0.9)  # kSdfIsolatedTruncation
HALF_DIAGONAL = np.float32(0.8660254)  # sqrt(3) / 2 as the f32 constant of grid.h
UDF_EDGE_FACTOR = np.float32(1.5)  # kUdfEdgeFactor
UDF_FLOOD_EDGE = np.float32(2.0)  # kUdfFloodEdge


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


def isolated_threshold(udf: bool, level: int, step: np.float32,
                       truncation: float = math.inf) -> np.float32:
    """grid.h's isolated_threshold: the keep rule's at the level's edge step * 2^level, for an SDF
    at most SDF_ISOLATED_TRUNCATION times the field's truncation d* (a truncated fit reads about d*
    wherever the surface is farther), and for an SDF level whose children are the finest,
    SDF_NEAR_ZERO_CELL times the finest cell's edge `step` (f32)."""
    keep = keep_threshold(udf, step * np.float32(1 << level))
    if udf:
        return keep
    if level == 1:
        return SDF_NEAR_ZERO_CELL * step
    return min(keep, SDF_ISOLATED_TRUNCATION * np.float32(truncation))


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


def edges_within(corner_values: np.ndarray, limit: np.float32) -> np.ndarray:
    """(N, 12): the edges (EDGE_CORNERS order) of cells whose ends' values sum to at most `limit`
    (f32; NaN: not)."""
    sums = corner_values[..., EDGE_CORNERS[:, 0]] + corner_values[..., EDGE_CORNERS[:, 1]]
    return sums <= limit


def udf_valid_edges(corner_values: np.ndarray, h: np.float32) -> np.ndarray:
    """(N, 12): the UDF mesher's valid edges of cells of edge h (sum <= udf_edge_limit(h))."""
    return edges_within(corner_values, udf_edge_limit(h))


def udf_cell_is_near(corner_values: np.ndarray, h: np.float32) -> np.ndarray:
    """A finest cell of a UDF may carry triangles: all corners finite, and its valid edges
    (f_a + f_b <= udf_edge_limit(h)) include the three edges of some triangle of the table."""
    finite = np.isfinite(corner_values).all(axis=1)
    valid = (udf_valid_edges(corner_values, h) << np.arange(12)).sum(axis=1)
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


def _raster_vertices(side: int) -> np.ndarray:
    """(side^3, 3) int64 vertex coordinates in raster order (x fastest)."""
    axis = np.arange(side, dtype=np.int64)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def coarsest_values(field_fn: FieldFn, resolution: int, level: int,
                    udf: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """grid.h's evaluate_coarsest_level: the coarsest level's (side^3,) f32 values in raster
    order, the probe's verdict per cell (cells_at_level(resolution, level + 1)^3, raster order;
    all kept at level 0) and the evaluations made."""
    n = cells_at_level(resolution, level)
    side = n + 1
    m = cells_at_level(resolution, level + 1)
    vertices = _raster_vertices(side)
    if level == 0:  # the coarsest level is the finest: all of it
        values = field_fn(grid_coordinates(vertices, resolution)).astype(np.float32)
        return values, np.ones(m ** 3, dtype=bool), len(vertices)
    values = np.zeros(len(vertices), dtype=np.float32)
    even = (vertices % 2 == 0).all(axis=1)
    values[even] = field_fn(grid_coordinates(vertices[even] << level, resolution))
    probe = _raster_vertices(m)  # the probe's cells, raster order
    corners = 2 * (probe[:, None, :] + CORNER_OFFSET[None, :, :])
    past = (corners > n).any(axis=(1, 2))  # reaches past the grid: kept
    corner_values = values[vertex_keys(np.minimum(corners, n), side)]
    threshold = keep_threshold(udf, grid_step(resolution) * np.float32(1 << (level + 1)))
    kept = past | cell_may_contain_surface(corner_values, threshold)
    offsets = _raster_vertices(3)
    children = (2 * probe[kept][:, None, :] + offsets[None, :, :]).reshape(-1, 3)
    children = children[(children <= n).all(axis=1)]
    wanted = np.zeros(len(vertices), dtype=bool)
    wanted[vertex_keys(children, side)] = True
    todo = wanted & ~even
    values[todo] = field_fn(grid_coordinates(vertices[todo] << level, resolution))
    # The rest: the f32 sum of the probe vertices at -1 and +1 along the odd axes, in raster
    # order of the offsets (z slowest, -1 first), times 1/2, 1/4 or 1/8.
    fill = ~wanted & ~even
    odd = vertices % 2 == 1
    for mask in range(1, 8):
        axes = np.array([(mask >> a) & 1 for a in range(3)], dtype=bool)
        rows = np.nonzero(fill & (odd == axes).all(axis=1))[0]
        if len(rows) == 0:
            continue
        total = np.zeros(len(rows), dtype=np.float32)
        for offset in _raster_vertices(2):
            if (offset.astype(bool) & ~axes).any():
                continue
            neighbour = vertices[rows] + np.where(axes, 2 * offset - 1, 0)
            total += values[vertex_keys(neighbour, side)]
        values[rows] = total * np.float32(0.5 ** int(axes.sum()))
    return values, kept, int(even.sum() + todo.sum())


def _evaluate_level(
    field_fn: FieldFn, resolution: int, level: int, cells: np.ndarray, parent: GridLevel | None,
    udf: bool = False
) -> tuple[GridLevel, int]:
    """The level visiting `cells`, with its corner values, and the number of new evaluations;
    without a parent, the coarsest level (every cell, coarsest_values())."""
    side = cells_at_level(resolution, level) + 1
    corner_vertices = cells[:, None, :] + CORNER_OFFSET[None, :, :]
    keys, inverse = np.unique(vertex_keys(corner_vertices, side).ravel(), return_inverse=True)
    vertices = np.stack([keys % side, keys // side % side, keys // (side * side)], axis=1)
    if parent is None:
        raster, _, evaluated = coarsest_values(field_fn, resolution, level, udf)
        grid_level = GridLevel(level, side - 1, cells, keys, vertices, inverse.reshape(-1, 8),
                               raster[keys])
        return grid_level, evaluated
    values = np.empty(len(keys), dtype=np.float32)
    todo = (vertices % 2 == 1).any(axis=1)
    index, found = parent.find(vertices[~todo] // 2)
    assert found.all(), "an even vertex of a child cell is a corner of its parent"
    values[~todo] = parent.values[index]
    values[todo] = field_fn(grid_coordinates(vertices[todo] << level, resolution))
    grid_level = GridLevel(level, side - 1, cells, keys, vertices, inverse.reshape(-1, 8), values)
    return grid_level, int(todo.sum())


def _children(level: GridLevel, step: np.float32, child_cells: int, udf: bool) -> np.ndarray:
    """The keep rule: the children of the cells that may contain the surface, in parent order,
    each parent's in CORNER_OFFSET order, dropping those that start at or past the last cell."""
    threshold = keep_threshold(udf, step * np.float32(1 << level.level))
    kept = level.cells[cell_may_contain_surface(level.corner_values(), threshold)]
    children = (2 * kept[:, None, :] + CORNER_OFFSET[None, :, :]).reshape(-1, 3)
    return children[(children < child_cells).all(axis=1)]


def _sign_change(corner_values: np.ndarray) -> np.ndarray:
    """Cells whose corners include f < 0 and not f < 0 (NaN counts as not negative)."""
    negative = corner_values < 0
    return negative.any(axis=-1) & ~negative.all(axis=-1)


def cell_keys(cells: np.ndarray, n: int) -> np.ndarray:
    """Raster index (x fastest) of cell coordinates on a grid of n cells per axis."""
    return vertex_keys(cells, n)


def visit_order(cells: np.ndarray, side: int) -> np.ndarray:
    """grid_follow.cpp's order of a level's cells (FloodStore::for_each_visited): by 8^3 block
    of a grid of `side` vertices per axis in raster order, inside a block by 2^3 group in raster
    order, inside a group in CORNER_OFFSET order. The sort key of each cell."""
    per_axis = (side + 7) // 8
    block = ((cells[:, 2] >> 3) * per_axis + (cells[:, 1] >> 3)) * per_axis + (cells[:, 0] >> 3)
    local = cells & 7
    group = (local[:, 2] >> 1) * 16 + (local[:, 1] >> 1) * 4 + (local[:, 0] >> 1)
    child = (cells[:, 0] & 1) | (cells[:, 1] & 1) << 1 | (cells[:, 2] & 1) << 2
    return (block * 64 + group) * 8 + child


_AROUND = np.array([(x, y, z) for z in (-1, 0, 1) for y in (-1, 0, 1) for x in (-1, 0, 1)])
# Per face of a cell (axis, side): its corners and its edges (EDGE_CORNERS indices).
_FACES = [(axis, side, np.flatnonzero(CORNER_OFFSET[:, axis] == side),
           np.flatnonzero((CORNER_OFFSET[EDGE_CORNERS][:, :, axis] == side).all(axis=1)))
          for axis in range(3) for side in (0, 1)]


def _followed(corner_values: np.ndarray, h: np.float32, udf: bool) -> np.ndarray:
    """The cells that surface following grows from: a sign change (SDF), a valid edge (UDF)."""
    return udf_valid_edges(corner_values, h).any(axis=1) if udf else _sign_change(corner_values)


def _follow_region(level: GridLevel, step: np.float32, udf: bool,
                   truncation: float) -> tuple[np.ndarray, np.ndarray]:
    """grid_follow.cpp's follow_region: the sorted cell keys of the region (the followed cells of
    `level` and their 26 neighbours) and its isolated cells."""
    n = level.cells_per_axis
    f = level.corner_values()
    h = step * np.float32(1 << level.level)
    active = _followed(f, h, udf)
    around = (level.cells[active][:, None, :] + _AROUND[None]).reshape(-1, 3)
    region = np.unique(cell_keys(around[((around >= 0) & (around < n)).all(axis=1)], n))
    threshold = isolated_threshold(udf, level.level, step, truncation)
    candidates = ~active & cell_may_contain_surface(f, threshold)
    isolated = level.cells[candidates]
    return region, isolated[~np.isin(cell_keys(isolated, n), region)]


class _Blocks:
    """Flags (and, `with_values`, values) over the raster keys of a grid of `side` points per axis,
    by 8^3 blocks allocated as they are first touched (grid_follow.cpp's FloodStore): a flood
    touches a thin shell, so memory follows it, and each lookup costs the same however many points
    are stored."""

    def __init__(self, side: int, with_values: bool) -> None:
        self.side = side
        self.per_axis = (side + 7) // 8
        self.table = np.full(self.per_axis ** 3, -1, dtype=np.int64)
        self.flags = np.zeros(0, dtype=bool)
        self.values = np.zeros(0, dtype=np.float32) if with_values else None

    def slots(self, keys: np.ndarray) -> np.ndarray:
        """The slot of each key, making the blocks that are missing (which replaces `flags` and
        `values`: index them after this call returns)."""
        side = self.side
        x, y, z = keys % side, keys // side % side, keys // (side * side)
        block = ((z >> 3) * self.per_axis + (y >> 3)) * self.per_axis + (x >> 3)
        new = np.unique(block[self.table[block] < 0])
        if len(new):
            first = len(self.flags) // 512
            self.table[new] = np.arange(first, first + len(new))
            self.flags = np.concatenate([self.flags, np.zeros(512 * len(new), dtype=bool)])
            if self.values is not None:
                self.values = np.concatenate([self.values, np.zeros(512 * len(new), np.float32)])
        return self.table[block] * 512 + ((z & 7) << 6 | (y & 7) << 3 | (x & 7))


def _follow_surface(field_fn: FieldFn, resolution: int, level: int, parent: GridLevel,
                    region: np.ndarray, isolated: np.ndarray, udf: bool) -> tuple[GridLevel, int]:
    """grid_follow.cpp's follow_surface: level `level` below `parent`, and its new evaluations."""
    n = cells_at_level(resolution, level)
    side = n + 1
    known = _Blocks(side, with_values=True)  # flags: the vertex's value is known
    evaluated = 0

    def value_at(keys: np.ndarray) -> np.ndarray:
        slots = known.slots(keys)
        return known.values[slots]

    def fetch(keys: np.ndarray) -> None:
        nonlocal evaluated
        keys = np.unique(keys)
        slots = known.slots(keys)
        keys = keys[~known.flags[slots]]
        vertices = np.stack([keys % side, keys // side % side, keys // (side * side)], axis=1)
        values = np.empty(len(keys), dtype=np.float32)
        copy = (vertices % 2 == 0).all(axis=1)
        index, found = parent.find(vertices[copy] // 2)
        copied = np.flatnonzero(copy)[found]
        values[copied] = parent.values[index[found]]
        todo = np.ones(len(keys), dtype=bool)
        todo[copied] = False
        values[todo] = field_fn(grid_coordinates(vertices[todo] << level, resolution))
        evaluated += int(todo.sum())
        slots = known.slots(keys)
        known.flags[slots] = True
        known.values[slots] = values

    # Seeds: SDF, one child per crossed edge of each sign-change parent, from its midpoint's sign;
    # UDF, the children holding a valid half of each valid edge of a parent with one.
    h = grid_step(resolution) * np.float32(1 << level)
    parent_h = grid_step(resolution) * np.float32(1 << (level + 1))
    f = parent.corner_values()
    active = _followed(f, parent_h, udf)
    cells, f = parent.cells[active], f[active]
    parent_valid = udf_valid_edges(f, parent_h) if udf else None
    seeded = np.zeros(len(cells), dtype=bool)
    seeds = []
    for e, (a, b) in enumerate(EDGE_CORNERS.tolist()):
        axis = int(np.argmax(CORNER_OFFSET[b] - CORNER_OFFSET[a]))
        crossed = parent_valid[:, e] if udf else (f[:, a] < 0) != (f[:, b] < 0)
        middle = 2 * (cells[crossed] + CORNER_OFFSET[a])
        middle[:, axis] += 1
        on_grid = (middle <= n).all(axis=1)
        fetch(vertex_keys(middle[on_grid], side))
        f_middle = value_at(vertex_keys(middle[on_grid], side))
        f_ends = f[crossed][on_grid]
        child = 2 * cells[crossed][on_grid] + CORNER_OFFSET[a]
        if udf:
            limit = udf_edge_limit(h)
            upper = child.copy()
            upper[:, axis] += 1
            lower_valid = f_ends[:, a] + f_middle <= limit
            upper_valid = f_middle + f_ends[:, b] <= limit
            seeds += [child[lower_valid], upper[upper_valid]]
            seeded[np.flatnonzero(crossed)[on_grid][lower_valid | upper_valid]] = True
            continue
        child[:, axis] += (f_ends[:, a] < 0) == (f_middle < 0)
        seeds.append(child)
    # UDF: a parent with a valid edge and no seed in itself or its 26 neighbours holds the surface
    # inside, away from its edges: all its children are seeds. Beside a seeded neighbour the
    # surface passes there, and the flood comes from it.
    if udf:
        pn = parent.cells_per_axis
        around = (cells[seeded][:, None, :] + _AROUND[None]).reshape(-1, 3)
        near_seeded = np.unique(cell_keys(around[((around >= 0) & (around < pn)).all(axis=1)], pn))
        lone = ~seeded & ~np.isin(cell_keys(cells, pn), near_seeded)
        seeds.append((2 * cells[lone][:, None, :] + CORNER_OFFSET[None]).reshape(-1, 3))
    seeds.append((2 * isolated[:, None, :] + CORNER_OFFSET[None]).reshape(-1, 3))
    first = np.concatenate(seeds)
    visited = _Blocks(n, with_values=False)  # flags: the cell was visited
    waves: list[np.ndarray] = []

    def visit(keys: np.ndarray) -> np.ndarray:
        """Marks the cells of `keys` not visited yet as the next wave; their coordinates."""
        keys = np.unique(keys)
        slots = visited.slots(keys)
        new = ~visited.flags[slots]
        keys = keys[new]
        visited.flags[slots[new]] = True
        waves.append(keys)
        return np.stack([keys % n, keys // n % n, keys // (n * n)], axis=1)

    # The flood, a wave at a time, inside the region: SDF, across faces with a sign change, and
    # above the finest level every face of a cell near zero; UDF, across faces holding an edge
    # with f_a + f_b <= UDF_FLOOD_EDGE * h.
    near_zero_limit = SDF_NEAR_ZERO_CELL * h if level > 0 and not udf else np.float32(0)

    def flood(frontier: np.ndarray) -> None:
        while len(frontier):
            corners = vertex_keys(frontier[:, None, :] + CORNER_OFFSET[None], side)
            fetch(corners.ravel())
            values = value_at(corners)
            near_zero = (np.abs(values) < near_zero_limit).all(axis=1)
            floodable = edges_within(values, UDF_FLOOD_EDGE * h) if udf else None
            grown = []
            for axis, face, corner_ids, edge_ids in _FACES:
                if udf:
                    through = floodable[:, edge_ids].any(axis=1)
                else:
                    through = _sign_change(values[:, corner_ids]) | near_zero
                neighbour = frontier[through].copy()
                neighbour[:, axis] += 1 if face else -1
                neighbour = neighbour[((neighbour >= 0) & (neighbour < n)).all(axis=1)]
                grown.append(neighbour[np.isin(cell_keys(neighbour // 2, (n + 1) // 2), region)])
            frontier = visit(cell_keys(np.concatenate(grown), n))

    flood(visit(cell_keys(first[(first < n).all(axis=1)], n)))
    if not udf and level > 0:
        # SDF above the finest level, once the flood is done: the children around each vertex
        # above within SDF_NEAR_ZERO_VERTEX * h of zero none of which was visited, or within
        # SDF_SECOND_SHEET_VERTEX * h whether or not, inside the region, then the flood from them
        # (grid.h, step 1).
        distance = np.abs(parent.values)
        close = distance <= SDF_NEAR_ZERO_VERTEX * h
        near, second_sheet = parent.vertices[close], distance[close] <= SDF_SECOND_SHEET_VERTEX * h
        around = 2 * near[:, None, :] - CORNER_OFFSET[None]  # (vertices, 8, 3)
        inside = ((around >= 0) & (around < n)).all(axis=2)
        reached = np.zeros(inside.shape, dtype=bool)
        slots = visited.slots(cell_keys(around[inside], n))
        reached[inside] = visited.flags[slots]
        around = around[inside & (second_sheet | ~reached.any(axis=1))[:, None]]
        flood(visit(cell_keys(around[np.isin(cell_keys(around // 2, parent.cells_per_axis), region)], n)))

    keys = np.concatenate(waves)
    cells = np.stack([keys % n, keys // n % n, keys // (n * n)], axis=1)
    cells = cells[np.argsort(visit_order(cells, side), kind="stable")]
    corner_keys = vertex_keys(cells[:, None, :] + CORNER_OFFSET[None, :, :], side)
    keys, inverse = np.unique(corner_keys.ravel(), return_inverse=True)
    vertices = np.stack([keys % side, keys // side % side, keys // (side * side)], axis=1)
    grid_level = GridLevel(level, n, cells, keys, vertices, inverse.reshape(-1, 8), value_at(keys))
    return grid_level, evaluated


def _udf_gradients(gradient_fn: GradientFn, grid: SparseGrid) -> tuple[np.ndarray, int]:
    """Gradients at every corner of every near cell of the finest level, NaN elsewhere."""
    fine = grid.finest
    near = udf_cell_is_near(fine.corner_values(), grid.step)
    wanted = np.zeros(len(fine.values), dtype=bool)
    wanted[fine.corners[near].ravel()] = True
    gradients = np.full((len(fine.values), 3), np.nan, dtype=np.float32)
    gradients[wanted] = gradient_fn(grid.coordinates(fine.vertices[wanted]))
    return gradients, int(wanted.sum())


def build_grid(field_fn: FieldFn, resolution: int, udf_gradient: GradientFn | None = None,
               band: bool = False, truncation: float = math.inf) -> SparseGrid:
    """The sparse grid of `field_fn` at `resolution` (MIN_RESOLUTION..MAX_RESOLUTION); with
    `udf_gradient` the field is a UDF (its keep margin) and the gradients at the corners of the
    finest near cells are evaluated too. An SDF's levels follow the surface, or with `band` the
    keep rule (nfd_mesh_options.sample_band); `truncation` is the file's d* (infinity: a field
    that is not truncated)."""
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise InputError(f"resolution {resolution} outside {MIN_RESOLUTION}..{MAX_RESOLUTION}")
    top = refinement_levels(resolution)
    cells = _raster_vertices(cells_at_level(resolution, top))  # every cell, raster order
    level, evaluated = _evaluate_level(field_fn, resolution, top, cells, None,
                                       udf_gradient is not None)
    levels = [level]
    for lower in range(top - 1, -1, -1):
        if not band:
            udf = udf_gradient is not None
            region, isolated = _follow_region(levels[0], grid_step(resolution), udf, truncation)
            level, new = _follow_surface(field_fn, resolution, lower, levels[0], region, isolated,
                                         udf)
        else:
            cells = _children(levels[0], grid_step(resolution), cells_at_level(resolution, lower),
                              udf_gradient is not None)
            level, new = _evaluate_level(field_fn, resolution, lower, cells, levels[0])
        levels.insert(0, level)
        evaluated += new
    grid = SparseGrid(resolution, levels, evaluated)
    if udf_gradient is not None:
        grid.gradients, grid.gradients_evaluated = _udf_gradients(udf_gradient, grid)
    return grid
