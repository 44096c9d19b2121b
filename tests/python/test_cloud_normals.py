"""A point cloud's oriented normals (cloud_normals) and the sides a UDF's signed start takes from them."""

from __future__ import annotations

import numpy as np
import pytest
from nfencode import config
from nfencode.cloud_normals import oriented_normals
from nfencode.sampling import SurfaceSampler, build_pool


def on_sphere(n: int, rng: np.random.Generator, centre=(0.0, 0.0, 0.0), radius: float = 0.5) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return np.asarray(centre) + radius * d / np.linalg.norm(d, axis=1, keepdims=True)


def on_torus(n: int, rng: np.random.Generator, major: float = 0.6, minor: float = 0.2) -> np.ndarray:
    u, v = rng.uniform(0, 2 * np.pi, (2, n))
    ring = np.stack([np.cos(u), np.sin(u), np.zeros(n)], axis=1)
    return major * ring + minor * (np.cos(v)[:, None] * ring + np.sin(v)[:, None] * np.array([0, 0, 1.0]))


def test_normals_of_closed_clouds_point_out_of_each_piece() -> None:
    rng = np.random.default_rng(1)
    a, b = on_sphere(3000, rng, (-0.5, 0, 0), 0.3), on_sphere(2000, rng, (0.5, 0.1, 0), 0.25)
    normals, _, edge, agreement = oriented_normals(np.concatenate([a, b]), 16)
    assert edge.mean() < 0.002  # random sampling: a few points whose neighbours happen to lie aside
    assert agreement > 0.99
    outward = np.concatenate([a - (-0.5, 0, 0), b - (0.5, 0.1, 0)])
    cosines = np.einsum("ij,ij->i", normals, outward / np.linalg.norm(outward, axis=1, keepdims=True))
    assert np.all(cosines > 0.9)
    # Not star-shaped about its centroid (the hole): still outward from the tube everywhere.
    t = on_torus(6000, rng)
    normals, _, _, agreement = oriented_normals(t, 16)
    ring = t * np.array([1, 1, 0]) / np.linalg.norm(t[:, :2], axis=1, keepdims=True) * 0.6
    tube = (t - ring) / np.linalg.norm(t - ring, axis=1, keepdims=True)
    assert agreement > 0.99 and np.all(np.einsum("ij,ij->i", normals, tube) > 0.9)


def test_a_sheet_is_oriented_one_way_and_a_volume_curve_or_clump_is_no_surface() -> None:
    rng = np.random.default_rng(2)
    sheet = np.column_stack([rng.uniform(-0.5, 0.5, (4000, 2)), np.zeros(4000)])
    sheet[:, 2] = 0.05 * np.sin(4 * sheet[:, 0])  # a gentle wave
    normals, flat, edge, agreement = oriented_normals(sheet, 16)
    assert flat.all() and agreement > 0.99 and abs(np.sign(normals[:, 2]).sum()) == len(sheet)
    # Its edge points lie on its rim (and at the corners), but for a stray or two of the sampling.
    rim = 0.5 - np.abs(sheet[:, :2]).max(axis=1)
    assert edge.sum() >= 4 and np.mean(rim[edge] < 0.05) > 0.8
    line = np.column_stack([np.linspace(-1, 1, 500), 1e-3 * rng.normal(size=(500, 2))])  # a noisy curve
    clumps = np.repeat(rng.uniform(-1, 1, (5, 3)), 40, axis=0)
    for cloud in (rng.uniform(-0.5, 0.5, (4000, 3)), line, clumps, clumps[:2], clumps[:1]):
        normals, flat, _, _ = oriented_normals(cloud, 16)
        assert np.isfinite(normals).all() and flat.mean() < config.CLOUD_MIN_FLAT_SHARE


def test_sides_from_a_cloud_inside_outside_and_past_a_sheets_edge() -> None:
    rng = np.random.default_rng(3)
    ball = SurfaceSampler(on_sphere(4000, rng), None)
    flat, edge, agreement = ball.orient_cloud_normals()
    assert flat > 0.99 and edge < 0.002 and agreement > 0.99
    points = np.array([[0.4, 0, 0], [0, 0.6, 0], [0.0, 0.0, 0.0], [0.95, 0, 0], [0, 0, -0.9]])
    distances, sides = ball.unsigned_distances_and_sides(points)
    assert sides.tolist() == [-1, 1, -1, 1, 1]
    np.testing.assert_array_equal(distances, ball.distances(points, signed=False))
    # A flat sheet: opposite sides above and below it, +1 on both sides past its edge.
    sheet = SurfaceSampler(np.column_stack([rng.uniform(-0.5, 0.5, (3000, 2)), np.zeros(3000)]), None)
    sheet.orient_cloud_normals()
    _, sides = sheet.unsigned_distances_and_sides(np.array([[0.1, 0.2, 0.05], [0.1, 0.2, -0.05]]))
    assert sorted(sides.tolist()) == [-1, 1]
    _, sides = sheet.unsigned_distances_and_sides(np.array([[0.8, 0.1, 0.05], [0.8, 0.1, -0.05], [0, -0.8, -0.1]]))
    assert sides.tolist() == [1, 1, 1]


def test_the_udf_pool_of_a_cloud_has_sides_where_its_normals_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 5_000)
    rng = np.random.default_rng(4)
    pool = build_pool(SurfaceSampler(on_sphere(3000, rng), None), "udf", rng)
    assert pool.sides is not None and "oriented normals" in pool.sides_note
    radius = np.linalg.norm(pool.points, axis=1)
    assert np.all(pool.sides[radius < 0.45] == -1.0) and np.all(pool.sides[radius > 0.55] == 1.0)
    volume = build_pool(SurfaceSampler(rng.uniform(-0.5, 0.5, (3000, 3)), None), "udf", rng)
    assert volume.sides is None and volume.sides_note.startswith("no signed start: the cloud is no surface")
    # A single view of a plate before a wall: edges everywhere, nothing behind them to take a side from.
    wall = np.column_stack([rng.uniform(-0.8, 0.8, (4000, 2)), np.full(4000, -0.3)])
    plate = np.column_stack([rng.uniform(-0.3, 0.3, (1000, 2)), np.full(1000, 0.2)])
    view = build_pool(SurfaceSampler(np.concatenate([wall, plate]), None), "udf", rng)
    assert view.sides is None and "open like a single-view scan" in view.sides_note
