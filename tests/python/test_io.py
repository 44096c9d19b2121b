"""Shape loading (every supported format, plain and gzipped) and writing."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import plyfile
import pytest
import trimesh
from conftest import SHARED_DATA
from scipy.spatial import cKDTree

from nfencode.errors import InputError
from nfencode.io import load_shape, save_mesh, save_points

CUBE = trimesh.creation.box(extents=(2.0, 1.0, 0.5))


def gzip_copy(path: Path) -> Path:
    target = path.with_name(path.name + ".gz")
    target.write_bytes(gzip.compress(path.read_bytes()))
    return target


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "glb", "gltf"])
def test_mesh_formats_plain_and_gzipped(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"cube.{ext}"
    CUBE.export(path)
    for p in (path, gzip_copy(path)) if ext != "gltf" else (path,):  # .gltf refers to a side file
        shape = load_shape(p)
        assert shape.is_mesh and shape.name == "cube"
        assert shape.vertices.dtype == np.float64 and shape.faces is not None and shape.faces.dtype == np.int64
        assert len(shape.faces) == 12
        np.testing.assert_allclose(shape.vertices.min(axis=0), [-1.0, -0.5, -0.25])
        tri = shape.vertices[shape.faces]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
        assert area == pytest.approx(CUBE.area)


def test_quads_are_triangulated(tmp_path: Path) -> None:
    (tmp_path / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    (tmp_path / "quad.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    for name in ("quad.obj", "quad.ply"):
        shape = load_shape(tmp_path / name)
        assert shape.faces is not None and len(shape.faces) == 2


def test_point_clouds_keep_colours(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    data = np.empty(100, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    for c in "xyz":
        data[c] = rng.uniform(-1, 1, 100)
    for c in ("red", "green", "blue"):
        data[c] = rng.integers(0, 256, 100)
    for text in (True, False):
        path = tmp_path / f"cloud_{text}.ply"
        plyfile.PlyData([plyfile.PlyElement.describe(data, "vertex")], text=text).write(str(path))
        shape = load_shape(gzip_copy(path))
        assert not shape.is_mesh and shape.faces is None
        np.testing.assert_array_equal(shape.vertices[:, 0], data["x"])
        assert shape.colors is not None
        np.testing.assert_array_equal(shape.colors, np.stack([data["red"], data["green"], data["blue"]], axis=1))


def test_save_and_reload(tmp_path: Path) -> None:
    vertices = np.asarray(CUBE.vertices)
    faces = np.asarray(CUBE.faces)
    normals = np.asarray(CUBE.vertex_normals)
    for name in ("m.ply", "m.obj"):
        save_mesh(tmp_path / name, vertices, faces, normals)
        shape = load_shape(tmp_path / name)
        np.testing.assert_allclose(shape.vertices, vertices, atol=1e-6)
        np.testing.assert_array_equal(shape.faces, faces)
    save_mesh(tmp_path / "plain.obj", vertices, faces)
    assert len(load_shape(tmp_path / "plain.obj").faces) == 12
    points = np.random.default_rng(1).normal(size=(50, 3))
    for name in ("p.ply", "p.obj"):
        save_points(tmp_path / name, points)
        shape = load_shape(tmp_path / name)
        assert not shape.is_mesh
        np.testing.assert_allclose(shape.vertices, points, atol=1e-6)
    with pytest.raises(InputError):
        save_mesh(tmp_path / "m.stl", vertices, faces)
    with pytest.raises(InputError):
        save_points(tmp_path / "p.off", points)


def test_real_scans() -> None:
    bunny = SHARED_DATA / "stanford" / "bun_zipper_res4.ply.gz"
    scan = SHARED_DATA / "stanford" / "bunny_scans" / "chin.ply.gz"
    if not bunny.exists() or not scan.exists():
        pytest.skip("shared data not available")
    shape = load_shape(bunny)
    assert shape.is_mesh and shape.vertices.shape == (453, 3) and shape.faces.shape == (948, 3)
    assert shape.name == "bun_zipper_res4"
    points = load_shape(scan)  # range scan: vertices and a range_grid, no faces
    assert not points.is_mesh and len(points.vertices) == 37738


def test_aligned_scans_are_moved_by_their_transforms_and_merged(tmp_path: Path) -> None:
    points = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    save_points(tmp_path / "a.ply", points)
    gzip_copy(tmp_path / "a.ply").rename(tmp_path / "b.ply.gz")  # FILE.gz stands for FILE
    half = np.sqrt(0.5)
    (tmp_path / "scans.conf").write_text(
        "camera 0 0 -1  0 0 0 1\n"
        "bmesh a.ply 0 0 0 0 0 0 1\n"
        f"bmesh b.ply 10 20 30 0 0 {half} {half}\n"  # 90 degrees about z, then the translation
    )
    shape = load_shape(tmp_path / "scans.conf")
    assert not shape.is_mesh and shape.name == "scans"
    # The conjugate rotation: (1, 0, 0) -> (0, -1, 0) and (0, 2, 0) -> (2, 0, 0).
    np.testing.assert_allclose(shape.vertices, [[1, 0, 0], [0, 2, 0], [10, 19, 30], [12, 20, 30]], atol=1e-6)
    (tmp_path / "bad.conf").write_text("bmesh a.ply 0 0 zero 0 0 0 1\n")
    with pytest.raises(InputError, match="bad.conf:1"):
        load_shape(tmp_path / "bad.conf")
    (tmp_path / "empty.conf").write_text("camera 0 0 -1  0 0 0 1\n")
    with pytest.raises(InputError, match="no scans"):
        load_shape(tmp_path / "empty.conf")


def test_bunny_range_scans_align_with_the_zippered_bunny(tmp_path: Path) -> None:
    """Two of bun.conf's ten scans (those with the largest rotations; all ten take a minute to parse)
    land on bun_zipper.ply, which was zippered in the same frame."""
    conf = SHARED_DATA / "stanford" / "bunny_scans" / "bun.conf"
    if not conf.exists():
        pytest.skip("shared data not available")
    lines = [line.split() for line in conf.read_text().splitlines()]
    chosen = [["bmesh", str(conf.parent / w[1]), *w[2:]]
              for w in lines if w[:1] == ["bmesh"] and w[1] in ("chin.ply", "top2.ply")]
    (tmp_path / "two.conf").write_text("\n".join(" ".join(w) for w in chosen))
    cloud = load_shape(tmp_path / "two.conf")
    assert cloud.vertices.shape == (37_738 + 38_298, 3) and not cloud.is_mesh
    reference = load_shape(SHARED_DATA / "stanford" / "bun_zipper.ply.gz").vertices
    distance, _ = cKDTree(reference).query(cloud.vertices[::10])
    assert np.median(distance) < 1e-3  # metres; a wrong rotation convention leaves them 7-13 cm off
