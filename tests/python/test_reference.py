"""The numpy reference decoder: dequantization, the normative evaluation, coarse-to-fine meshing."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from typing import Callable

import numpy as np
import pytest
from conftest import COS_BLOB_LEVEL, cos_blob, cos_blob_file, random_color_file, random_file

from nfencode.bitstream import (
    FIELD_UDF,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    OUTPUT_SIGMOID,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    read_nfc,
    write_nfc,
)
from nfencode.errors import NfcError
from nfencode.reference import (
    DecodedNetwork,
    color_bytes,
    decode_points,
    dequantize,
    evaluate,
    evaluate_color,
    evaluate_gradient,
    extract_mesh,
    extract_unit_mesh,
    extract_mesh_from_field,
    field_function,
    sample_points,
    shape_ball_bound,
)


def explicit_field(net: NetworkBlock, u: tuple[float, float, float], output: int = 0) -> float:
    """FORMAT.md "Evaluation" written out scalar by scalar, independently of reference.py: the
    network's `output`-th value."""
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
    y = sum(wi * hi for wi, hi in zip(w[output], h)) + b[output]
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


# ---- gradients ----------------------------------------------------------------------------------


def finite_differences(net: DecodedNetwork, points: np.ndarray, eps: float = 2.0**-7) -> np.ndarray:
    """Richardson-extrapolated central differences (error O(eps^4)) on points of a 2^-16 lattice,
    so that p +- eps is exact in f32 (the evaluator takes f32 points). The f32 rounding of the
    encoding limits them to ~1e-5 of the gradient's scale."""

    def central(step: float) -> np.ndarray:
        columns = []
        for axis in range(3):
            offset = np.eye(3)[axis] * step
            plus = evaluate(net, (points + offset).astype(np.float32))
            minus = evaluate(net, (points - offset).astype(np.float32))
            columns.append((plus - minus) / (2 * step))
        return np.stack(columns, axis=-1)

    return (4 * central(eps / 2) - central(eps)) / 3


@pytest.mark.parametrize("output", [OUTPUT_IDENTITY, OUTPUT_ABS, OUTPUT_SIGMOID])
def test_gradient_matches_finite_differences(output: int) -> None:
    block = random_file(num_frequencies=3, widths=(8, 6, 1)).geometry.network
    net = dequantize(dataclasses.replace(block, output=output, omega0=3.0))
    points = np.round(np.random.default_rng(2).uniform(-1, 1, (300, 3)) * 2**16) / 2**16
    values, gradients = evaluate_gradient(net, points)
    np.testing.assert_array_equal(values, evaluate(net, points))  # the same forward pass
    assert gradients.shape == (300, 3)
    expected = finite_differences(net, points)
    if output == OUTPUT_ABS:  # |y| has a kink at y = 0: compare away from it
        pre = evaluate(dequantize(dataclasses.replace(block, output=OUTPUT_IDENTITY, omega0=3.0)), points)
        smooth = np.abs(pre) > 2 * 2.0**-7 * np.abs(gradients).sum(axis=1)  # no sign change in the stencil
        assert smooth.mean() > 0.7
        gradients, expected = gradients[smooth], expected[smooth]
    scale = np.abs(expected).max()
    assert scale > 1e-3
    np.testing.assert_allclose(gradients, expected, atol=1e-4 * scale)


def test_gradient_of_several_outputs_and_of_a_known_field() -> None:
    net = dequantize(random_file(num_frequencies=1, widths=(4, 3)).geometry.network)
    values, gradients = evaluate_gradient(net, np.zeros((5, 3)))
    assert values.shape == (5, 3) and gradients.shape == (5, 3, 3)
    # cos_blob = c - sum cos(u_i): its gradient is sin(u_i), up to the f32 weights.
    blob = dequantize(cos_blob_file().geometry.network)
    u = np.random.default_rng(3).uniform(-1, 1, (100, 3))
    _, g = evaluate_gradient(blob, u)
    np.testing.assert_allclose(g, np.sin(u.astype(np.float32).astype(np.float64)), atol=1e-6)


# ---- SDF extraction -----------------------------------------------------------------------------


def edge_uses(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges (E, 2) of a triangle list and how many triangles use each."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)


def closed_and_consistently_wound(faces: np.ndarray) -> bool:
    """Every undirected edge is shared by exactly two triangles, which run it in opposite directions."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    if len(np.unique(directed, axis=0)) != len(directed):
        return False  # a directed edge used twice: inconsistent winding or non-manifold
    return bool((edge_uses(faces)[1] == 2).all())


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    t = vertices[faces].astype(np.float64)
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)


def surface_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    t = vertices[faces].astype(np.float64)
    return float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum())


def counting(fn: Callable[[np.ndarray], np.ndarray]) -> tuple[Callable[[np.ndarray], np.ndarray], dict[str, int]]:
    calls = {"points": 0}

    def wrapped(points: np.ndarray) -> np.ndarray:
        calls["points"] += len(points)
        return fn(points)

    return wrapped, calls


def sphere_distance(center: tuple[float, float, float], radius: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda p: np.linalg.norm(p.astype(np.float64) - np.array(center), axis=1) - radius


@pytest.mark.parametrize(
    "radius,center,resolution,volume_tolerance,evaluated_fraction,normal_dot",
    [
        (0.6, (0.1, 0.05, -0.05), 64, 0.01, 0.31, 0.99),  # coarse level 32: 13% of the grid
        (0.6, (0.1, 0.05, -0.05), 100, 0.005, 0.25, 0.99),  # not a power of two: last cells past u = 1
        # Smaller than a coarse cell (2/32): found only thanks to the Lipschitz margin. Two cells
        # across: grid differences give the normals only roughly.
        (0.03, (0.31, -0.27, 0.44), 128, 0.25, 0.02, 0.95),
    ],
)
def test_sphere_mesh(
    radius: float, center: tuple[float, float, float], resolution: int, volume_tolerance: float,
    evaluated_fraction: float, normal_dot: float,
) -> None:
    c = np.array(center)
    field, calls = counting(sphere_distance(center, radius))
    mesh = extract_mesh_from_field(field, resolution)
    assert len(mesh.faces) > 50
    distance = np.linalg.norm(mesh.vertices - c, axis=1)
    assert np.abs(distance - radius).max() < 0.1 * (2.0 / resolution)  # a tenth of a cell
    assert closed_and_consistently_wound(mesh.faces)
    volume = signed_volume(mesh.vertices, mesh.faces)  # positive: counter-clockwise seen from outside
    assert volume == pytest.approx(4 / 3 * math.pi * radius**3, rel=volume_tolerance)
    outward = (mesh.vertices - c) / distance[:, None]
    assert np.einsum("ij,ij->i", mesh.normals, outward).min() > normal_dot
    # Sparse, and the normals cost no evaluation.
    assert mesh.points_evaluated < evaluated_fraction * (resolution + 1) ** 3
    assert calls["points"] == mesh.points_evaluated and mesh.gradients_evaluated == 0
    assert 0 < mesh.active_cells <= len(mesh.faces)


def test_field_without_surface_gives_an_empty_mesh() -> None:
    mesh = extract_mesh_from_field(lambda p: np.full(len(p), 0.5), 32)
    assert mesh.vertices.shape == (0, 3) and mesh.faces.shape == (0, 3) and mesh.active_cells == 0
    no_near_cell = extract_mesh_from_field(lambda p: np.full(len(p), 0.5), 32, udf_gradient=np.ones_like)
    assert no_near_cell.faces.shape == (0, 3) and no_near_cell.gradients_evaluated == 0
    flat = extract_mesh_from_field(lambda p: np.zeros(len(p)), 16, udf_gradient=np.zeros_like)  # no orientation
    assert flat.faces.shape == (0, 3) and flat.gradients_evaluated == 17**3
    with pytest.raises(NfcError):
        extract_mesh_from_field(lambda p: np.ones(len(p)), 7)  # below NFD_MIN_RESOLUTION
    with pytest.raises(NfcError):
        extract_mesh_from_field(lambda p: np.ones(len(p)), 1025)  # above NFD_MAX_RESOLUTION
    assert len(extract_mesh_from_field(lambda p: np.full(len(p), 0.5), 1024).faces) == 0


def test_a_surface_beyond_the_shapes_ball_is_not_extracted() -> None:
    """FORMAT.md "The shape's ball": a blob that a network puts in a corner of [-1, 1]^3, 1.5 and
    more from the origin (beyond 1 + 2 d* = 1.2), lies outside every shape an encoder writes; the
    grid reads it as d* and nothing is extracted there. The network itself still has it."""
    f = cos_blob_file(blob_center=1.2)
    net = dequantize(f.geometry.network)
    corner = np.array([[1.0, 1.0, 1.0]])
    assert evaluate(net, corner)[0] == pytest.approx(cos_blob(corner, 1.2)[0], abs=1e-6)
    assert evaluate(net, corner)[0] < 0
    assert len(extract_mesh_from_field(lambda p: evaluate(net, p), 64).faces) > 0  # unbounded
    assert len(extract_mesh(f, 64).faces) == 0
    assert field_function(f)(corner)[0] == np.float32(f.geometry.truncation)


def test_the_shapes_ball_bound_keeps_values_inside_it_and_nans() -> None:
    """Radius 1 + 2 * 0.1: on the sphere itself a value stays; beyond it, below 0.1, it is raised."""
    points = np.array([[1.2, 0, 0], [1.21, 0, 0], [0.7, 0.7, 0.72], [0.7, 0.7, 0.6], [2, 0, 0]],
                      dtype=np.float32)
    values = np.array([-1, -1, 0.05, 0.05, np.nan], dtype=np.float32)
    bounded = shape_ball_bound(values, points, 0.1)
    np.testing.assert_array_equal(bounded[:4], np.float32([-1, 0.1, 0.1, 0.05]))
    assert np.isnan(bounded[4])


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
    assert closed_and_consistently_wound(mesh.faces)
    assert signed_volume(unit, mesh.faces) > 0
    gradient = np.sin(unit)  # grad of c - sum cos u
    gradient /= np.linalg.norm(gradient, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", mesh.normals, gradient).min() > 0.999


# ---- UDF extraction -----------------------------------------------------------------------------


def test_udf_file_meshes_the_same_vertices_as_its_sdf() -> None:
    """|f| meshed by the UDF mesher (analytic network gradients, pseudo-signs) finds the surface of
    f: the same crossed edges at the same t = |f_a| / (|f_a| + |f_b|) = f_a / (f_a - f_b)."""
    sdf = cos_blob_file()
    g = sdf.geometry
    udf = dataclasses.replace(sdf, geometry=dataclasses.replace(
        g, field_type=FIELD_UDF, network=dataclasses.replace(g.network, output=OUTPUT_ABS)))
    signed, unsigned = extract_mesh(sdf, 48), extract_mesh(read_nfc(write_nfc(udf)), 48)
    assert len(unsigned.faces) == len(signed.faces) and unsigned.active_cells == signed.active_cells
    np.testing.assert_array_equal(np.unique(unsigned.vertices, axis=0), np.unique(signed.vertices, axis=0))
    assert (edge_uses(unsigned.faces)[1] == 2).all()  # closed, no hole, no double sheet
    assert unsigned.gradients_evaluated > 0


def sphere_udf(center: np.ndarray, radius: float) -> tuple[Callable, Callable]:
    def field(p: np.ndarray) -> np.ndarray:
        return np.abs(np.linalg.norm(p.astype(np.float64) - center, axis=1) - radius)

    def gradient(p: np.ndarray) -> np.ndarray:
        d = p.astype(np.float64) - center
        r = np.linalg.norm(d, axis=1, keepdims=True)
        return np.sign(r - radius) * d / r

    return field, gradient


def disk_udf(center: np.ndarray, radius: float) -> tuple[Callable, Callable]:
    """Distance to the flat disk of `radius` around `center` in the plane z = center z: an open
    surface whose boundary is its rim."""

    def closest(p: np.ndarray) -> np.ndarray:
        q = p.astype(np.float64) - center
        rho = np.linalg.norm(q[:, :2], axis=1, keepdims=True)
        on_disk = q[:, :2] * np.minimum(1.0, radius / np.maximum(rho, 1e-300))
        return center + np.concatenate([on_disk, np.zeros((len(p), 1))], axis=1)

    def field(p: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p.astype(np.float64) - closest(p), axis=1)

    def gradient(p: np.ndarray) -> np.ndarray:
        d = p.astype(np.float64) - closest(p)
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    return field, gradient


def test_udf_sphere_is_closed_and_on_the_surface() -> None:
    c, radius, resolution = np.array([0.07, -0.04, 0.11]), 0.55, 64
    field, gradient = sphere_udf(c, radius)
    mesh = extract_mesh_from_field(field, resolution, udf_gradient=gradient)
    assert len(mesh.faces) > 1000
    assert (edge_uses(mesh.faces)[1] == 2).all()  # no boundary edge, no double sheet
    distance = np.linalg.norm(mesh.vertices - c, axis=1)
    assert np.abs(distance - radius).max() < 0.1 * (2.0 / resolution)
    radial = (mesh.vertices - c) / distance[:, None]
    assert np.abs(np.einsum("ij,ij->i", mesh.normals, radial)).min() > 0.99
    area = surface_area(mesh.vertices, mesh.faces)
    assert area == pytest.approx(4 * math.pi * radius**2, rel=0.01)


def test_udf_disk_ends_only_at_its_rim() -> None:
    """An open surface: the face filter removes what the pseudo-signs would put past the rim, and
    leaves no hole inside it."""
    c, radius, resolution = np.array([0.03, -0.05, 0.0123]), 0.5, 64
    h = 2.0 / resolution
    field, gradient = disk_udf(c, radius)
    mesh = extract_mesh_from_field(field, resolution, udf_gradient=gradient)
    edges, uses = edge_uses(mesh.faces)
    assert uses.max() == 2
    rho = np.linalg.norm(mesh.vertices[:, :2] - c[:2], axis=1)
    boundary_vertices = np.unique(edges[uses == 1])
    assert len(boundary_vertices) > 2 * math.pi * radius / h  # the rim is a boundary all round
    assert np.abs(rho[boundary_vertices] - radius).max() < 2 * h
    inner = rho < radius - 2 * h
    assert np.abs(mesh.vertices[inner, 2] - c[2]).max() < 1e-6  # exact V-shaped crossings
    assert np.abs(mesh.normals[inner, 2]).min() > 0.999
    assert rho.max() < radius + 2 * h
    area = surface_area(mesh.vertices, mesh.faces)
    assert area == pytest.approx(math.pi * radius**2, rel=4 * h / radius)


def test_udf_mesher_needs_gradients_only_on_near_cells() -> None:
    field, gradient = sphere_udf(np.zeros(3), 0.5)
    counted, calls = counting(gradient)
    mesh = extract_mesh_from_field(field, 64, udf_gradient=counted)
    assert calls["points"] == mesh.gradients_evaluated
    # The corners of the near cells: a band about one cell thick around the sphere.
    shell_vertices = 4 * math.pi * 0.5**2 / (2 / 64) ** 2
    assert shell_vertices < mesh.gradients_evaluated < 6 * shell_vertices


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


# ---------------------------------------------------------------------------------------------
# Colour (FORMAT.md 1.1, `colr`)


def colored_blob() -> NfcFile:
    f = cos_blob_file()
    f.color = random_color_file().color
    return read_nfc(write_nfc(f))


def test_evaluate_color_matches_the_explicit_formula() -> None:
    f = read_nfc(write_nfc(random_color_file()))
    assert f.color is not None
    net = f.color.network
    rng = np.random.default_rng(2)
    points = np.concatenate([rng.uniform(-1, 1, (15, 3)), [[1, 1, 1], [-1, -1, -1], [0, 0, 0]]])
    colors = evaluate_color(dequantize(net), points)
    assert colors.shape == (len(points), 3) and colors.min() >= 0.0 and colors.max() <= 1.0
    expected = [[explicit_field(net, tuple(p), k) for k in range(3)] for p in points]
    assert np.abs(colors - np.array(expected)).max() <= 1e-6
    assert colors.std(axis=0).min() > 1e-3  # the random network really varies


def test_evaluate_color_rejects_a_geometry_network() -> None:
    with pytest.raises(NfcError):
        evaluate_color(dequantize(random_file().geometry.network), np.zeros((2, 3)))


def test_color_bytes_rounds_half_up_and_saturates() -> None:
    c = np.array([[0.0, 1.0, 0.5], [0.5 / 255, 0.4999 / 255, 254.5 / 255], [1 - 1e-12, 1e-12, 254.49 / 255]])
    np.testing.assert_array_equal(color_bytes(c), [[0, 255, 128], [1, 0, 255], [255, 0, 254]])
    assert color_bytes(c).dtype == np.uint8


def test_mesh_colours_are_evaluated_at_the_extractors_unit_vertices() -> None:
    f = colored_blob()
    assert f.color is not None
    unit = extract_unit_mesh(f, 32)
    mesh = extract_mesh(f, 32)
    np.testing.assert_array_equal(mesh.faces, unit.faces)
    assert mesh.colors is not None and mesh.colors.shape == (len(mesh.vertices), 3)
    np.testing.assert_array_equal(mesh.colors, evaluate_color(dequantize(f.color.network), unit.vertices))
    g = f.geometry
    np.testing.assert_array_equal(mesh.vertices, (unit.vertices * np.float32(g.scale)
                                                  + np.asarray(g.center, dtype=np.float32)).astype(np.float32))
    assert extract_mesh(f, 32, color=False).colors is None
    assert extract_mesh(cos_blob_file(), 32).colors is None  # no colr chunk


def test_decoded_points_carry_the_colour_of_their_unit_position() -> None:
    f = colored_blob()
    assert f.color is not None
    unit = extract_unit_mesh(f, 32)
    points, colors = decode_points(f, unit, 500, seed=4)
    assert points.dtype == np.float32 and points.shape == (500, 3) and colors is not None
    u = sample_points(unit.vertices, unit.faces, 500, seed=4).astype(np.float32)
    np.testing.assert_array_equal(colors, evaluate_color(dequantize(f.color.network), u))
    g = f.geometry
    assert np.abs((points - np.asarray(g.center)) / g.scale - u).max() < 1e-6
    assert decode_points(cos_blob_file(), unit, 10)[1] is None
