"""The numpy reference decoder: dequantization, the normative evaluation, coarse-to-fine meshing."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import COS_BLOB_LEVEL, cos_blob, cos_blob_file, random_file

from nfencode.bitstream import (
    FIELD_UDF,
    OUTPUT_ABS,
    OUTPUT_SIGMOID,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    read_nfc,
    write_nfc,
)
from nfencode.errors import NfcError
from nfencode.reference import (
    coarse_resolution,
    dequantize,
    evaluate,
    extract_mesh,
    extract_mesh_from_field,
    field_function,
    sample_points,
)


def explicit_field(net: NetworkBlock, u: tuple[float, float, float]) -> float:
    """FORMAT.md "Evaluation" written out scalar by scalar, independently of reference.py."""
    f32 = np.float32
    freqs, a = [], math.pi
    for _ in range(net.num_frequencies):
        freqs.append(f32(a))
        a *= float(f32(net.frequency_base))
    uf = [f32(x) for x in u]
    h = [float(x) for x in uf]
    for fk in freqs:
        args = [float(fk * x) for x in uf]  # f32 products
        h += [float(f32(math.sin(t))) for t in args] + [float(f32(math.cos(t))) for t in args]
    layers = []
    for (wq, bq), (ws, bs) in zip(net.levels, net.steps):
        w = [[float(f32(q) * f32(ws)) for q in row] for row in wq]
        b = [float(f32(q) * f32(bs)) for q in bq]
        layers.append((w, b))
    omega0 = float(f32(net.omega0))
    for w, b in layers[:-1]:
        h = [math.sin(omega0 * (sum(wi * hi for wi, hi in zip(row, h)) + bo)) for row, bo in zip(w, b)]
    w, b = layers[-1]
    y = sum(wi * hi for wi, hi in zip(w[0], h)) + b[0]
    if net.output == OUTPUT_ABS:
        return abs(y)
    if net.output == OUTPUT_SIGMOID:
        return 1.0 / (1.0 + math.exp(-y))
    return y


@pytest.mark.parametrize("field_type", [0, 1])
def test_evaluate_matches_the_explicit_formula(field_type: int) -> None:
    f = read_nfc(write_nfc(random_file(field_type, num_frequencies=3, widths=(6, 5, 1))))
    net = f.geometry.network
    rng = np.random.default_rng(1)
    points = np.concatenate([rng.uniform(-1, 1, (20, 3)), [[1, 1, 1], [-1, -1, -1], [0, 0, 0]]])
    values = evaluate(dequantize(net), points)
    assert values.shape == (len(points),)
    expected = [explicit_field(net, tuple(p)) for p in points]
    np.testing.assert_allclose(values, expected, rtol=1e-12, atol=1e-12)
    if field_type == FIELD_UDF:
        assert (values >= 0).all()


def test_sigmoid_output_and_multiple_outputs() -> None:
    net = random_file(num_frequencies=1, widths=(4, 3)).geometry.network
    net.output = OUTPUT_SIGMOID
    values = evaluate(dequantize(net), np.zeros((5, 3)))
    assert values.shape == (5, 3) and ((values > 0) & (values < 1)).all()


def test_dequantize_is_one_f32_multiplication() -> None:
    net = random_file(bits=12).geometry.network
    decoded = dequantize(net)
    for (wq, bq), (ws, bs), w, b in zip(net.levels, net.steps, decoded.weights, decoded.biases):
        assert w.dtype == np.float32 and b.dtype == np.float32
        np.testing.assert_array_equal(w, wq.astype(np.float32) * np.float32(ws))
        np.testing.assert_array_equal(b, bq.astype(np.float32) * np.float32(bs))


def test_reference_does_not_import_torch() -> None:
    code = "import sys, nfencode.reference, nfencode.metrics, nfencode.cli; assert 'torch' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("resolution,coarse", [(256, 16), (512, 16), (100, 25), (48, 24), (24, 24), (8, 8)])
def test_coarse_resolution(resolution: int, coarse: int) -> None:
    assert coarse_resolution(resolution) == coarse


def edges_used_twice(faces: np.ndarray) -> bool:
    """Closed 2-manifold check: every undirected edge is shared by exactly two triangles, with
    opposite directions (consistent orientation)."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    as_tuples = {tuple(e) for e in directed.tolist()}
    if len(as_tuples) != len(directed):
        return False  # a directed edge used twice: inconsistent winding or non-manifold
    return all((b, a) in as_tuples for a, b in as_tuples)


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    t = vertices[faces].astype(np.float64)
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)


def counting(fn):
    calls = {"points": 0}

    def wrapped(points: np.ndarray) -> np.ndarray:
        calls["points"] += len(points)
        return fn(points)

    return wrapped, calls


@pytest.mark.parametrize(
    "radius,center,resolution,volume_tolerance",
    [
        (0.6, (0.1, 0.05, -0.05), 64, 0.01),
        # Smaller than a coarse cell (2/16): found only thanks to the Lipschitz margin.
        (0.03, (0.31, -0.27, 0.44), 128, 0.25),
    ],
)
def test_sphere_mesh(radius: float, center: tuple[float, float, float], resolution: int, volume_tolerance: float) -> None:
    c = np.array(center)

    def sphere(p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p.astype(np.float64) - c, axis=1) - radius

    field, calls = counting(sphere)
    mesh = extract_mesh_from_field(field, resolution, truncation=0.1)
    assert len(mesh.faces) > 50
    distance = np.linalg.norm(mesh.vertices - c, axis=1)
    assert np.abs(distance - radius).max() < 0.1 * (2.0 / resolution)  # a tenth of a cell
    assert edges_used_twice(mesh.faces)
    volume = signed_volume(mesh.vertices, mesh.faces)  # positive: counter-clockwise seen from outside
    assert volume == pytest.approx(4 / 3 * math.pi * radius**3, rel=volume_tolerance)
    outward = (mesh.vertices - c) / distance[:, None]
    assert np.einsum("ij,ij->i", mesh.normals, outward).min() > 0.99
    # Sparse: far fewer evaluations than the dense grid (the normals come on top of the count).
    assert mesh.points_evaluated < 0.3 * (resolution + 1) ** 3
    assert calls["points"] == mesh.points_evaluated + 6 * len(mesh.vertices)


def test_field_without_surface_gives_an_empty_mesh() -> None:
    mesh = extract_mesh_from_field(lambda p: np.full(len(p), 0.5), 32)
    assert mesh.vertices.shape == (0, 3) and mesh.faces.shape == (0, 3)
    with pytest.raises(NfcError):
        extract_mesh_from_field(lambda p: np.ones(len(p)), 4)  # below the minimum resolution


def test_extract_mesh_of_a_hand_built_file() -> None:
    """End to end: bytes -> parse -> dequantize -> evaluate -> coarse-to-fine marching cubes, on a
    network whose zero set is known analytically (conftest.cos_blob)."""
    center, scale = np.array([0.5, -1.0, 2.0]), 3.0
    f = read_nfc(write_nfc(cos_blob_file(tuple(center), scale)))
    field = field_function(f)
    grid = np.random.default_rng(0).uniform(-1, 1, (1000, 3))
    np.testing.assert_allclose(field(grid), cos_blob(grid), atol=1e-6)  # f32 weights

    mesh = extract_mesh(f, resolution=64)
    unit = (mesh.vertices.astype(np.float64) - center) / scale
    assert mesh.vertices.dtype == np.float32
    assert np.abs(cos_blob(unit)).max() < 2e-3
    radius = math.sqrt(2 * (3 - COS_BLOB_LEVEL))
    assert np.linalg.norm(unit, axis=1) == pytest.approx(radius, abs=0.02)
    assert edges_used_twice(mesh.faces)
    assert signed_volume(unit, mesh.faces) > 0
    gradient = np.sin(unit)  # grad of c - sum cos u
    gradient /= np.linalg.norm(gradient, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", mesh.normals, gradient).min() > 0.999


def test_udf_files_are_not_meshed_yet() -> None:
    f = random_file(FIELD_UDF)
    with pytest.raises(NfcError, match="UDF meshing is not implemented yet"):
        extract_mesh(f, 32)


def test_sample_points_is_uniform_by_area() -> None:
    # Two triangles, the second with 3x the area of the first.
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 5], [3, 0, 5], [0, 1, 5]], dtype=float)
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    points = sample_points(vertices, faces, 20_000, seed=3)
    on_second = np.isclose(points[:, 2], 5.0)
    assert on_second.mean() == pytest.approx(0.75, abs=0.02)
    first = points[~on_second]
    assert (first[:, 2] == 0).all()
    assert (first[:, 0] >= 0).all() and (first[:, 1] >= 0).all() and (first[:, :2].sum(axis=1) <= 1 + 1e-12).all()
    assert first[:, 0].mean() == pytest.approx(1 / 3, abs=0.02)  # centroid of a uniform triangle
    np.testing.assert_array_equal(points, sample_points(vertices, faces, 20_000, seed=3))
    with pytest.raises(NfcError):
        sample_points(vertices, np.zeros((0, 3), dtype=int), 10)


def test_geometry_chunk_is_exposed_for_info() -> None:
    f = cos_blob_file()
    assert isinstance(f, NfcFile) and isinstance(f.geometry, GeometryChunk)
    assert f.geometry.network.parameter_count == 3 * 3 + 3 + 3 + 1
