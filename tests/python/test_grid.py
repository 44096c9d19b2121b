"""The sparse grid of the numpy reference follows libnfdecode/src/grid.h: level schedule, keep rule
in f32, visiting order, vertices evaluated once."""

from __future__ import annotations

import numpy as np
import pytest

from nfencode import grid as grid_module
from nfencode.grid import (
    HALF_DIAGONAL,
    build_grid,
    cell_may_contain_surface,
    cells_at_level,
    coarse_resolution,
    coarsest_values,
    grid_coordinates,
    grid_step,
    isolated_threshold,
    keep_threshold,
    refinement_levels,
    udf_cell_is_near,
    udf_edge_limit,
    visit_order,
)
from nfencode.mc_tables import (CORNER_OFFSET, EDGE_CORNERS, HOLDS_TRIANGLE, TRIANGLE_COUNT,
                                TRIANGLES)


@pytest.mark.parametrize(
    "resolution,levels,coarse",
    [(1024, 5, 32), (1000, 5, 32), (512, 4, 32), (256, 3, 32), (100, 1, 50), (64, 1, 32), (63, 1, 32),
     (62, 0, 62), (8, 0, 8)],
)
def test_level_schedule(resolution: int, levels: int, coarse: int) -> None:
    assert refinement_levels(resolution) == levels
    assert coarse_resolution(resolution) == coarse
    assert cells_at_level(resolution, 0) == resolution
    assert cells_at_level(1000, 3) == 125 and cells_at_level(100, 3) == 13  # ceil


def test_vertex_coordinates_are_the_f32_formula() -> None:
    i = np.arange(0, 101)
    expected = [np.float32(-1.0) + np.float32(k) * (np.float32(2.0) / np.float32(100)) for k in range(101)]
    np.testing.assert_array_equal(grid_coordinates(i, 100), np.array(expected, dtype=np.float32))
    assert grid_coordinates(np.array([100]), 100).dtype == np.float32


def test_keep_rule_thresholds_are_f32() -> None:
    h = np.float32(2.0) / np.float32(64)
    threshold = keep_threshold(False, h)
    assert threshold == h * HALF_DIAGONAL and keep_threshold(True, h) == np.float32(1.5) * h * HALF_DIAGONAL
    above = np.nextafter(threshold, np.float32(1.0))
    cells = np.array([
        [threshold] * 8,  # at the threshold: kept
        [above] * 8,  # one ulp beyond: dropped
        [-above] + [above] * 7,  # a sign change: kept
        [np.nan] + [threshold] * 7,  # NaN corners are left out of the minimum
        [np.nan] * 8,
    ], dtype=np.float32)
    np.testing.assert_array_equal(cell_may_contain_surface(cells, threshold), [True, False, True, True, False])


def test_near_cells_are_those_whose_valid_edges_hold_a_triangle() -> None:
    h = np.float32(2.0) / np.float32(64)
    half = udf_edge_limit(h) / np.float32(2.0)  # every edge sum at the limit: valid
    above = np.nextafter(half, np.float32(1.0))
    far = np.float32(2.0) * h
    corner_cut = np.full(8, far, dtype=np.float32)
    corner_cut[0] = np.float32(0.0)  # edges 0, 4, 8 (corner 0's) valid when far <= the limit
    corner_cut[[1, 2, 4]] = half
    cells = np.array([
        [half] * 8,
        [above] * 8,  # one ulp beyond on every edge: no valid edge
        [np.inf] + [0.0] * 7,  # non-finite: not meshed
        corner_cut,  # the three edges at corner 0, a triangle of the table
        np.where(np.arange(8) == 4, far, corner_cut),  # only edges 0 and 4: no triangle
    ], dtype=np.float32)
    np.testing.assert_array_equal(udf_cell_is_near(cells, h), [True, False, False, True, False])


def test_holds_triangle_is_the_supersets_of_the_table_triangles() -> None:
    triangles = {frozenset(TRIANGLES[c, 3 * t : 3 * t + 3].tolist())
                 for c in range(256) for t in range(TRIANGLE_COUNT[c])}
    assert frozenset({0, 4, 8}) in triangles and len(triangles) > 100
    rng = np.random.default_rng(0)
    for mask in rng.integers(0, 4096, 300).tolist() + [0, 4095, 0b100010001]:
        edges = {e for e in range(12) if mask >> e & 1}
        assert HOLDS_TRIANGLE[mask] == any(t <= edges for t in triangles), mask
    # The three edges at corner 0, used above.
    assert [EDGE_CORNERS[e].tolist() for e in (0, 4, 8)] == [[0, 1], [0, 2], [0, 4]]


def sphere(points: np.ndarray) -> np.ndarray:
    return np.linalg.norm(points.astype(np.float64) - [0.05, -0.1, 0.02], axis=1) - 0.5


def test_udf_band_visits_children_of_kept_cells_in_order() -> None:
    """The band (build_grid's `band`, nfd_mesh_options.sample_band) written out cell by cell: the
    coarse level in raster order (x fastest), then per kept parent its children in CORNER_OFFSET
    order, dropping those past the last cell. At resolution 99 level 1 has 50 cells; the last one
    reaches past u = 1 and its children at fine index 99 are dropped."""
    resolution = 99
    grid = build_grid(lambda p: np.abs(p[:, 0].astype(np.float64) - 0.97), resolution,
                      lambda p: np.zeros((len(p), 3)), band=True)  # a plane near u = 1, as a UDF
    coarse, fine = grid.levels[1], grid.levels[0]
    n = coarse.cells_per_axis
    assert n == 50 and coarse.cells.tolist() == [[x, y, z] for z in range(n) for y in range(n) for x in range(n)]
    h = grid.step * np.float32(2)
    expected, dropped = [], 0
    for cell, values in zip(coarse.cells.tolist(), coarse.corner_values()):
        if cell_may_contain_surface(values[None], keep_threshold(True, h))[0]:
            for offset in CORNER_OFFSET.tolist():
                child = [2 * c + o for c, o in zip(cell, offset)]
                if max(child) < resolution:
                    expected.append(child)
                else:
                    dropped += 1
    assert fine.cells.tolist() == expected
    assert dropped > 0 and fine.cells.max() == resolution - 1


def dense_sign_change_cells(field, resolution: int) -> np.ndarray:
    """The cells of the dense grid whose corners change sign, (N, 3), in visit_order."""
    axis = np.arange(resolution + 1)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    values = field(grid_coordinates(vertices, resolution)).astype(np.float32)
    negative = (values < 0).reshape(resolution + 1, resolution + 1, resolution + 1)
    r = resolution
    corners = np.stack([negative[o[2]:r + o[2], o[1]:r + o[1], o[0]:r + o[0]] for o in CORNER_OFFSET], axis=-1)
    zz, yy, xx = np.nonzero(corners.any(axis=-1) & ~corners.all(axis=-1))
    cells = np.stack([xx, yy, zz], axis=1)
    return cells[np.argsort(visit_order(cells, resolution + 1), kind="stable")]


@pytest.mark.parametrize("resolution", [99, 128])
def test_sdf_levels_visit_the_sign_change_cells_in_visit_order(resolution: int) -> None:
    """Surface following: each level below the coarsest visits exactly the cells whose corners
    change sign, in visit_order, here a plane near u = 1 (at 99 the last cell of level 1 reaches
    past u = 1) and a sphere."""
    for field in (lambda p: p[:, 0].astype(np.float64) - 0.97, sphere):
        grid = build_grid(field, resolution)
        assert grid.finest.cells.tolist() == dense_sign_change_cells(field, resolution).tolist()


def dense_near_cells(field, resolution: int) -> set[tuple[int, ...]]:
    """The cells of the dense grid of an unsigned field that may carry a triangle (near cells)."""
    axis = np.arange(resolution + 1)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    values = field(grid_coordinates(np.stack([x, y, z], axis=-1).reshape(-1, 3), resolution))
    values = values.astype(np.float32).reshape(resolution + 1, resolution + 1, resolution + 1)
    r = resolution
    corners = np.stack([values[o[2]:r + o[2], o[1]:r + o[1], o[0]:r + o[0]] for o in CORNER_OFFSET],
                       axis=-1)
    near = udf_cell_is_near(corners.reshape(-1, 8), grid_step(resolution)).reshape(r, r, r)
    zz, yy, xx = np.nonzero(near)
    return set(zip(xx.tolist(), yy.tolist(), zz.tolist()))


@pytest.mark.parametrize("resolution", [99, 128])
def test_udf_levels_follow_the_surface_to_every_near_cell(resolution: int) -> None:
    """UDF surface following: the finest level visits every near cell of the dense grid, from
    fewer evaluations than the band, for a plane near u = 1 (at 99 the last cell of level 1
    reaches past u = 1), a sphere, and a sphere of radius 0.02 inside one coarse cell."""
    centre = grid_coordinates(np.array([4 * 8 + 4, 5 * 8 + 4, 6 * 8 + 4]), 256)
    fields = [lambda p: np.abs(p[:, 0].astype(np.float64) - 0.97),
              lambda p: np.abs(sphere(p)),
              lambda p: np.abs(np.linalg.norm(p.astype(np.float64) - centre, axis=1) - 0.02)]
    for field in fields:
        grid = build_grid(field, resolution, lambda p: np.zeros((len(p), 3)))
        fine = grid.finest
        near = fine.cells[udf_cell_is_near(fine.corner_values(), grid.step)]
        expected = dense_near_cells(field, resolution)
        assert len(expected) > 20 and set(map(tuple, near.tolist())) == expected
        band = build_grid(field, resolution, lambda p: np.zeros((len(p), 3)), band=True)
        assert grid.points_evaluated < band.points_evaluated


def test_band_visits_children_of_kept_cells_and_finds_the_same_cells() -> None:
    """build_grid's `band` (nfd_mesh_options.sample_band): an SDF by the keep rule, written out as
    for the UDF band above; its sign-change cells are those surface following visits."""
    resolution = 99
    field = lambda p: p[:, 0].astype(np.float64) - 0.97  # noqa: E731
    grid = build_grid(field, resolution, band=True)
    coarse, fine = grid.levels[1], grid.levels[0]
    h = grid.step * np.float32(2)
    kept = coarse.cells[cell_may_contain_surface(coarse.corner_values(), keep_threshold(False, h))]
    children = (2 * kept[:, None, :] + CORNER_OFFSET[None]).reshape(-1, 3)
    assert fine.cells.tolist() == children[(children < resolution).all(axis=1)].tolist()
    negative = fine.corner_values() < 0
    crossing = fine.cells[negative.any(axis=1) & ~negative.all(axis=1)]
    followed = build_grid(field, resolution)
    assert sorted(crossing.tolist()) == sorted(followed.finest.cells.tolist())
    assert grid.points_evaluated > followed.points_evaluated


def test_a_component_inside_one_coarse_cell_is_found_by_the_isolated_cell_rule() -> None:
    """A sphere of radius 0.02 centred in a coarse cell of the grid at 256 (cells 0.0625 wide)
    crosses no coarse edge, so no seed finds it; the coarse cell has no sign change and no
    neighbour with one, and the keep rule keeps it: all its children are visited, and the flood
    goes on from the one with a sign change."""
    resolution = 256
    centre = grid_coordinates(np.array([4 * 8 + 4, 5 * 8 + 4, 6 * 8 + 4]), resolution)

    def small_sphere(points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points.astype(np.float64) - centre, axis=1) - 0.02

    grid = build_grid(small_sphere, resolution)
    expected = dense_sign_change_cells(small_sphere, resolution)
    assert len(expected) > 100 and grid.finest.cells.tolist() == expected.tolist()


def test_a_truncated_fields_far_cells_are_not_isolated_cells() -> None:
    """A truncated fit reads about d* wherever the surface is farther: at d* = 0.05 the coarsest
    level's keep threshold at 128 (0.054) took every far cell at the clamp for an isolated one and
    visited all its children. Given the field's d*, isolated cells are held to
    SDF_ISOLATED_TRUNCATION * d* (isolated_threshold): the dense grid's cells either way, a third
    of the evaluations; a sphere of radius 0.02 in the middle of a coarse cell (0.034 from its
    corners) away from the rest is still found as an isolated cell's."""
    resolution = 128
    truncation = 0.05
    small = grid_coordinates(np.array([98, 98, 66]), resolution).astype(np.float64)  # a coarse cell's centre

    def clamped(points: np.ndarray) -> np.ndarray:
        p = points.astype(np.float64)
        d = np.minimum(np.linalg.norm(p, axis=1) - 0.5, np.linalg.norm(p - small, axis=1) - 0.02)
        return np.clip(d, -truncation, truncation)

    expected = dense_sign_change_cells(clamped, resolution).tolist()
    with_truncation = build_grid(clamped, resolution, truncation=truncation)
    without = build_grid(clamped, resolution)
    assert with_truncation.finest.cells.tolist() == expected == without.finest.cells.tolist()
    assert any(np.linalg.norm(grid_coordinates(c, resolution) - small) < 0.04 for c in np.array(expected))
    assert with_truncation.points_evaluated < 0.5 * without.points_evaluated
    assert isolated_threshold(False, 2, grid_step(resolution), truncation) == np.float32(0.9) * np.float32(0.05)
    assert isolated_threshold(False, 2, grid_step(resolution)) == keep_threshold(False, grid_step(32))
    assert isolated_threshold(True, 2, grid_step(resolution), truncation) == keep_threshold(True, grid_step(32))


def test_the_finest_level_refines_isolated_cells_that_nearly_touch_zero(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """At the finest level the isolated-cell rule asks for a corner within SDF_NEAR_ZERO_CELL fine
    cells of zero (isolated_threshold). A sphere of radius 0.005 (1.3 fine cells across at 256)
    that shows at no vertex of the level above: found when its surface passes 0.002 from one of
    them (and lost without the rule), lost when it sits in the middle of a cell of that level
    (0.0085 from its corners), which the keep rule's margin found."""
    resolution = 256
    radius = 0.005

    def found_and_expected(centre: np.ndarray) -> tuple[set, set]:
        def small_sphere(points: np.ndarray) -> np.ndarray:
            return np.linalg.norm(points.astype(np.float64) - centre, axis=1) - radius

        fine = build_grid(small_sphere, resolution).finest
        negative = fine.corner_values() < 0
        found = fine.cells[negative.any(axis=1) & ~negative.all(axis=1)]
        expected = dense_sign_change_cells(small_sphere, resolution)
        return set(map(tuple, found.tolist())), set(map(tuple, expected.tolist()))

    # A vertex of the level above (odd there, so no vertex of the level above that).
    vertex = grid_coordinates(np.array([70, 90, 110]), resolution).astype(np.float64)
    touching = vertex + np.array([radius + 0.002, 0.0, 0.0])
    found, expected = found_and_expected(touching)
    assert len(expected) >= 8 and found == expected
    middle = grid_coordinates(np.array([71, 91, 111]), resolution).astype(np.float64)
    found, expected = found_and_expected(middle)
    assert len(expected) == 8 and not found
    keep_rule = grid_module.keep_threshold
    monkeypatch.setattr(grid_module, "isolated_threshold",
                        lambda udf, level, step, truncation: keep_rule(udf, step * np.float32(1 << level)))
    found, expected = found_and_expected(middle)
    assert found == expected
    # The touching sphere is found by this rule, not by a seed: without it, it is lost too.
    def none_at_the_finest(udf: bool, level: int, step: np.float32, truncation: float) -> np.float32:
        return np.float32(0) if level == 1 else keep_rule(udf, step * np.float32(1 << level))

    monkeypatch.setattr(grid_module, "isolated_threshold", none_at_the_finest)
    found, expected = found_and_expected(touching)
    assert len(expected) >= 8 and not found


def test_a_void_where_the_field_hovers_at_zero_is_found_through_near_zero_cells(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A learned SDF may hover just below zero inside a thin part and rise above it at one vertex
    (a void, as in dragon and suzanne): here a shell under the top of a sphere where f = -0.001,
    with a bump to +0.001 at one vertex of the level above the finest that the level above it
    does not have, 6 fine cells under the surface. No crossed edge leads to it; the flood of that
    level reaches it through the shell's near-zero cells (|f| < SDF_NEAR_ZERO_CELL * h at all
    eight corners), and the finest level seeds from it; so do the children around the shell's
    near-zero vertices. Without both its 8 fine cells are lost."""
    resolution = 256
    centre = grid_coordinates(np.array([130, 130, 186]), resolution).astype(np.float64)

    def hovering(points: np.ndarray) -> np.ndarray:
        p = points.astype(np.float64)
        r = np.linalg.norm(p, axis=1)
        shell = (r > 0.42) & (r < 0.5) & (np.abs(p[:, 0]) < 0.08) & (np.abs(p[:, 1]) < 0.08)
        bump = -0.001 + 0.002 * np.exp(-np.sum((p - centre) ** 2, axis=1) / 0.004 ** 2)
        return np.where(shell, bump, r - 0.5)

    def found() -> set[tuple[int, ...]]:
        fine = build_grid(hovering, resolution).finest
        negative = fine.corner_values() < 0
        return set(map(tuple, fine.cells[negative.any(axis=1) & ~negative.all(axis=1)].tolist()))

    expected = set(map(tuple, dense_sign_change_cells(hovering, resolution).tolist()))
    assert found() == expected
    # The shell's vertices, within SDF_NEAR_ZERO_VERTEX * h of zero with no child around them
    # reached, seed it too (step 1).
    monkeypatch.setattr(grid_module, "SDF_NEAR_ZERO_CELL", np.float32(0))
    assert found() == expected
    monkeypatch.setattr(grid_module, "SDF_NEAR_ZERO_VERTEX", np.float32(0))
    assert len(expected - found()) == 8


def test_a_void_beside_the_surface_that_nearly_touches_a_vertex_above_is_seeded_there(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A void of radius 0.02 inside a ball of radius 0.5, one coarse cell under its surface (cells
    0.0625 wide at 256), its boundary 0.0006 from a vertex of the coarsest level: it crosses no
    coarse edge, and its coarse cells lie beside the ball's sign-change cells, so no isolated-cell
    rule sees them. It first shows at the level below (vertices 0.031 apart), where that vertex
    lies within SDF_NEAR_ZERO_VERTEX * h of zero and the flood reached none of the children
    around it, so they seed a second flood (grid.h, step 1): found down to the finest level as
    the dense grid has it, and lost without them (the dragon's holes of bench/RESULTS.md,
    "0.13.17")."""
    resolution = 256
    vertex = grid_coordinates(np.array([128, 128, 128 + 56]), resolution).astype(np.float64)
    radius, gap = 0.02, 0.0006
    centre = vertex + np.array([radius + gap, 0.0, 0.0])

    def ball_with_void(points: np.ndarray) -> np.ndarray:
        p = points.astype(np.float64)
        return np.maximum(np.linalg.norm(p, axis=1) - 0.5, radius - np.linalg.norm(p - centre, axis=1))

    def void_cells() -> tuple[set, set]:
        fine = build_grid(ball_with_void, resolution).finest
        negative = fine.corner_values() < 0
        found = fine.cells[negative.any(axis=1) & ~negative.all(axis=1)]
        expected = dense_sign_change_cells(ball_with_void, resolution)
        return near_the_void(found), near_the_void(expected)

    def near_the_void(cells: np.ndarray) -> set:
        return {tuple(c) for c in cells.tolist()
                if np.linalg.norm(grid_coordinates(np.array(c), resolution) - centre) < 0.05}

    found, expected = void_cells()
    assert len(expected) > 100 and found == expected
    monkeypatch.setattr(grid_module, "SDF_NEAR_ZERO_VERTEX", np.float32(0))
    found, expected = void_cells()
    assert len(expected) > 100 and not found


def test_children_around_a_vertex_above_very_near_zero_are_visited_beside_the_surface_too(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A sphere that passes 0.1 h above a vertex of the 64 level (h: the 128 level's cell edge):
    the flood at 128 visits the four children above that vertex, which the surface crosses, and
    not the four below, which it does not (no sign change, no face with one, corners 0.9 h from
    zero above). Within SDF_SECOND_SHEET_VERTEX * h of zero the children not visited are seeded
    too (grid.h, step 1): a second sheet of a sliver thinner than a cell may pass there (the
    dragon's of bench/RESULTS.md, "0.13.18")."""
    resolution = 256
    fine = np.array([128, 128, 128 + 4 * 16])  # a vertex of the 64 level on the +z axis
    h = grid_step(128)
    radius = np.float64(grid_coordinates(fine, resolution)[2]) + 0.1 * np.float64(h)

    def ball(points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points.astype(np.float64), axis=1) - radius

    vertex = fine // 2  # in the 128 level's indices
    below = {tuple(vertex - o) for o in CORNER_OFFSET if o[2] == 1}

    def visited_below() -> set:
        level = build_grid(ball, resolution).levels[1]
        return below & {tuple(c) for c in level.cells.tolist()}

    assert visited_below() == below
    monkeypatch.setattr(grid_module, "SDF_SECOND_SHEET_VERTEX", np.float32(0))
    assert not visited_below()


def test_each_vertex_is_evaluated_once_and_even_ones_are_copied() -> None:
    seen: list[np.ndarray] = []

    def recording(points: np.ndarray) -> np.ndarray:
        assert points.dtype == np.float32
        seen.append(points)
        return sphere(points)

    grid = build_grid(recording, 256)
    points = np.concatenate(seen)
    assert len(points) == grid.points_evaluated == len(np.unique(points, axis=0))
    for finer, coarser in zip(grid.levels[:-1], grid.levels[1:]):
        even = (finer.vertices % 2 == 0).all(axis=1)
        index, found = coarser.find(finer.vertices[even] // 2)
        assert found.all()
        np.testing.assert_array_equal(finer.values[even], coarser.values[index])
        # The odd vertices were evaluated at this level's coordinates, in f32.
        odd = finer.vertices[~even][:50]
        np.testing.assert_array_equal(
            finer.values[~even][:50], sphere(grid.coordinates(odd << finer.level)).astype(np.float32))
    assert grid.finest.values.dtype == np.float32


@pytest.mark.parametrize("resolution,udf", [(128, False), (66, False), (128, True), (32, False)])
def test_the_coarsest_level_is_evaluated_where_its_probe_keeps_cells(resolution: int, udf: bool) -> None:
    """coarsest_values (grid.h, evaluate_coarsest_level): the probe's vertices and the child
    vertices of the probe cells the keep rule keeps hold the field, each evaluated once; the others
    lie in dropped probe cells and hold the mean of their probe neighbours, beyond the probe's
    threshold on their side of zero; every cell the surface crosses has its corners evaluated. At
    66 the coarsest level has 33 cells and the probe's last cells reach past it (kept); at 32 the
    coarsest level is the finest and is evaluated whole."""
    seen: list[np.ndarray] = []

    def field(points: np.ndarray) -> np.ndarray:
        seen.append(points)
        d = sphere(points)
        return np.abs(d) if udf else d

    level = refinement_levels(resolution)
    n = cells_at_level(resolution, level)
    side = n + 1
    values, kept, evaluated = coarsest_values(field, resolution, level, udf)
    assert evaluated == sum(len(p) for p in seen)
    axis = np.arange(side)
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    truth = field(grid_coordinates(vertices << level, resolution)).astype(np.float32)
    m = cells_at_level(resolution, level + 1)
    assert kept.shape == (m ** 3,)
    if level == 0:
        assert kept.all() and evaluated == side ** 3
        np.testing.assert_array_equal(values, truth)
        return
    exact = (vertices % 2 == 0).all(axis=1)
    for cell in np.argwhere(kept.reshape(m, m, m))[:, ::-1]:  # (x, y, z) of each kept cell
        lo = 2 * cell
        exact[(vertices >= lo).all(axis=1) & (vertices <= lo + 2).all(axis=1)] = True
    np.testing.assert_array_equal(values[exact], truth[exact])
    assert evaluated == exact.sum() < side ** 3 // 2
    threshold = keep_threshold(udf, grid_step(resolution) * np.float32(1 << (level + 1)))
    odd = vertices[~exact] % 2 == 1
    neighbours = []
    for offset in CORNER_OFFSET:
        w = vertices[~exact] + np.where(odd, 2 * offset - 1, 0)
        neighbours.append(truth[(w[:, 2] * side + w[:, 1]) * side + w[:, 0]])
    neighbours = np.stack(neighbours, axis=1)
    filled = values[~exact]
    assert ((filled >= neighbours.min(axis=1)) & (filled <= neighbours.max(axis=1))).all()
    assert ((neighbours > threshold).all(axis=1) | (neighbours < -threshold).all(axis=1)).all()
    np.testing.assert_allclose(filled, neighbours.astype(np.float64).mean(axis=1), rtol=1e-6)
    cube = truth.reshape(side, side, side)
    cell_values = np.stack([cube[o[2]:n + o[2], o[1]:n + o[1], o[0]:n + o[0]] for o in CORNER_OFFSET],
                           axis=-1).reshape(-1, 8)  # cells in raster order
    negative = cell_values < 0
    meshed = (udf_cell_is_near(cell_values, grid_step(resolution) * np.float32(1 << level)) if udf
              else negative.any(axis=1) & ~negative.all(axis=1))
    assert meshed.any()
    i = np.nonzero(meshed)[0]
    for o in CORNER_OFFSET:
        x, y, z = i % n + o[0], i // n % n + o[1], i // (n * n) + o[2]
        assert exact[(z * side + y) * side + x].all()


def test_gradients_only_at_corners_of_near_cells() -> None:
    grid = build_grid(lambda p: np.abs(sphere(p)), 64, lambda p: np.ones((len(p), 3)))
    fine = grid.finest
    near = udf_cell_is_near(fine.corner_values(), grid.step)
    assert grid.gradients is not None
    has_gradient = ~np.isnan(grid.gradients[:, 0])
    assert has_gradient.sum() == grid.gradients_evaluated == len(np.unique(fine.corners[near]))
    assert has_gradient[fine.corners[near]].all()
