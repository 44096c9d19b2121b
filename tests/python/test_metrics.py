"""Metrics exactly as shared/docs/metrics.md defines them."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import SHARED, SHARED_DATA

from nfencode.io import Shape, load_shape
from nfencode.metrics import chamfer_distance, color_psnr, sampling_floor
from nfencode.normalize import from_unit, to_unit, unit_ball_frame


def cloud(points: np.ndarray) -> Shape:
    return Shape(vertices=np.asarray(points, dtype=np.float64), faces=None, colors=None, name="cloud")


def grid_cloud() -> np.ndarray:
    axis = np.linspace(0.0, 1.0, 11)
    return np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)


def sphere_mesh() -> Shape:
    m = trimesh.creation.icosphere(subdivisions=4, radius=2.0)
    return Shape(vertices=m.vertices + [1.0, 2.0, 3.0], faces=np.asarray(m.faces, dtype=np.int64), colors=None,
                 name="sphere")


def test_unit_ball_frame() -> None:
    v = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.5, 0.5, 6.0]])
    center, scale = unit_ball_frame(v)
    np.testing.assert_array_equal(center, [1.0, 2.0, 3.0])  # AABB centre, not the centroid
    assert scale == pytest.approx(max(np.linalg.norm(v - center, axis=1)))
    u = to_unit(v, center, scale)
    assert np.linalg.norm(u, axis=1).max() == pytest.approx(1.0)
    np.testing.assert_allclose(from_unit(u, center, scale), v)


def test_known_offset_gives_the_offset() -> None:
    a = grid_cloud()  # spacing 0.1; an offset of 0.01 keeps every nearest neighbour
    offset = np.array([0.006, 0.0, 0.008])
    _, scale = unit_ball_frame(a)
    assert scale == pytest.approx(math.sqrt(3) / 2)
    cd = chamfer_distance(cloud(a), cloud(a + offset))
    assert cd == pytest.approx(2 * 0.01 / scale, rel=1e-9)  # both one-sided means, not squared
    assert chamfer_distance(cloud(a), cloud(a)) == 0.0


def test_measured_in_the_ground_truth_frame() -> None:
    a, b = grid_cloud(), grid_cloud() * 1.02 + 0.003
    cd = chamfer_distance(cloud(a), cloud(b))
    assert cd > 0
    # A similarity transform applied to both shapes changes nothing...
    assert chamfer_distance(cloud(a * 7 - 4), cloud(b * 7 - 4)) == pytest.approx(cd, rel=1e-9)
    # ...but the frame is the ground truth's: swapping the roles changes the scale.
    _, sa = unit_ball_frame(a)
    _, sb = unit_ball_frame(b)
    assert chamfer_distance(cloud(b), cloud(a)) == pytest.approx(cd * sa / sb, rel=1e-9)


def test_mesh_against_itself_is_the_sampling_floor() -> None:
    s = sphere_mesh()
    floor = sampling_floor(s, 20_000, seed=4)
    assert chamfer_distance(s, s, 20_000, seed=4) == floor
    assert 0 < floor < 0.05
    # Growing the sphere (radius 1 in the unit frame) by 1% moves every point by 0.01.
    center, _ = unit_ball_frame(s.vertices)
    bigger = Shape((s.vertices - center) * 1.01 + center, s.faces, None, "bigger")
    assert floor + 0.005 < chamfer_distance(s, bigger, 20_000, seed=4) < floor + 0.02
    assert chamfer_distance(s, s, 20_000, seed=5) != floor  # the seed matters


def test_large_point_clouds_are_subsampled() -> None:
    a = np.random.default_rng(0).uniform(-1, 1, (5000, 3))
    assert sampling_floor(cloud(a), 5000) == 0.0  # used whole
    assert sampling_floor(cloud(a), 1000) > 0.0  # two random subsets of 1000


def test_floor_matches_the_shared_baselines() -> None:
    path = SHARED_DATA / "stanford" / "armadillo_remeshed_odedstein.obj.gz"
    floors = SHARED / "baselines" / "floors.csv"
    if not path.exists() or not floors.exists():
        pytest.skip("shared data not available")
    expected = {row["shape"]: float(row["cd_floor"]) for row in csv.DictReader(floors.open())}["armadillo"]
    assert sampling_floor(load_shape(path)) == pytest.approx(expected, rel=0.02)


def test_color_psnr() -> None:
    points = grid_cloud()
    colors = np.random.default_rng(0).integers(0, 246, (len(points), 3)).astype(np.uint8)
    assert color_psnr(points, colors, points, colors) == math.inf
    shifted = colors + np.uint8(5)
    assert color_psnr(points, colors, points + 0.001, shifted) == pytest.approx(10 * math.log10(255**2 / 25))
