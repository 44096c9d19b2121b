"""The golden vectors decode in Python exactly as they did when generated (tests/vectors/README.md);
the C++ suite checks its decoders against the same files."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import plyfile
import pytest

from nfencode.bitstream import read_nfc
from nfencode.reference import dequantize, evaluate, evaluate_color, extract_mesh

VECTORS = Path(__file__).resolve().parents[1] / "vectors"
NAMES = sorted(p.stem for p in VECTORS.glob("v1_*.nfc"))
COLOR_NAMES = sorted(p.stem for p in VECTORS.glob("v1_1_*.nfc"))
GRID_NAMES = sorted(p.name.removesuffix(".grid128.txt") for p in VECTORS.glob("v1_*.grid128.txt"))
MESH_RESOLUTION = 64
_spec = importlib.util.spec_from_file_location("generate", VECTORS / "generate.py")
generate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(generate)  # the vectors' writer: grid_summary is the .grid128.txt text
POSITION_TOLERANCE = 1e-5  # unit frame (times the file's scale in its original frame), README.md
NORMAL_TOLERANCE = 1e-3


def test_vectors_exist() -> None:
    assert len(NAMES) >= 6 and COLOR_NAMES, f"golden vectors missing in {VECTORS}"
    assert len(GRID_NAMES) >= 4, f"grid summaries missing in {VECTORS}"


@pytest.mark.parametrize("name", NAMES)
def test_field_values_match(name: str) -> None:
    nfc = read_nfc((VECTORS / f"{name}.nfc").read_bytes())
    table = np.loadtxt(VECTORS / f"{name}.values.txt")
    values = evaluate(dequantize(nfc.geometry.network), table[:, :3].astype(np.float32))
    assert np.max(np.abs(values - table[:, 3])) <= 1e-9


def read_golden_mesh(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ply = plyfile.PlyData.read(str(path))
    vertex = ply["vertex"]
    positions = np.stack([vertex[c] for c in ("x", "y", "z")], axis=1)
    normals = np.stack([vertex[c] for c in ("nx", "ny", "nz")], axis=1)
    faces = np.stack(ply["face"]["vertex_indices"]).astype(np.int64).reshape(-1, 3)
    return positions, faces, normals


@pytest.mark.parametrize("name", NAMES)
def test_mesh_matches_exactly(name: str) -> None:
    """Same topology (faces, hence vertex order, identical), positions and normals within the
    tolerances of README.md."""
    nfc = read_nfc((VECTORS / f"{name}.nfc").read_bytes())
    positions, faces, normals = read_golden_mesh(VECTORS / f"{name}.mesh{MESH_RESOLUTION}.ply")
    mesh = extract_mesh(nfc, MESH_RESOLUTION)
    assert len(faces) > 5000
    np.testing.assert_array_equal(mesh.faces, faces)
    assert mesh.vertices.shape == positions.shape
    scale = nfc.geometry.scale
    assert np.abs(mesh.vertices - positions).max() <= POSITION_TOLERANCE * scale
    assert np.abs(mesh.normals - normals).max() <= NORMAL_TOLERANCE


@pytest.mark.parametrize("name", GRID_NAMES)
def test_grid_matches_its_summary(name: str) -> None:
    """The sparse grid at 128 (two levels that follow the surface) visits the cells and evaluates
    the points (and a UDF's gradients) it did when generated; the C++ suite checks its grid
    against the same file."""
    summary = (VECTORS / f"{name}.grid128.txt").read_text()
    assert generate.grid_summary((VECTORS / f"{name}.nfc").read_bytes()) == summary


@pytest.mark.parametrize("name", COLOR_NAMES)
def test_color_vector_is_1_1_and_reevaluates_to_its_colours(name: str) -> None:
    data = (VECTORS / f"{name}.nfc").read_bytes()
    nfc = read_nfc(data)
    assert (data[4], data[5], nfc.minor) == (1, 1, 1) and nfc.color is not None
    table = np.loadtxt(VECTORS / f"{name}.colours.txt")
    values = np.loadtxt(VECTORS / f"{name}.values.txt")
    np.testing.assert_array_equal(table[:, :3], values[:, :3])  # the same query points
    colors = evaluate_color(dequantize(nfc.color.network), table[:, :3].astype(np.float32))
    assert np.max(np.abs(colors - table[:, 3:])) <= 1e-9
    assert table[:, 3:].std(axis=0).min() > 0.05  # a real colour field, not a constant


@pytest.mark.parametrize("name", COLOR_NAMES)
def test_color_mesh_vertices_carry_the_reference_colours(name: str) -> None:
    nfc = read_nfc((VECTORS / f"{name}.nfc").read_bytes())
    vertex = plyfile.PlyData.read(str(VECTORS / f"{name}.mesh{MESH_RESOLUTION}.ply"))["vertex"]
    assert vertex.data.dtype.names == ("x", "y", "z", "nx", "ny", "nz", "red", "green", "blue")
    stored = np.stack([vertex[c] for c in ("red", "green", "blue")], axis=1)
    mesh = extract_mesh(nfc, MESH_RESOLUTION)
    assert mesh.colors is not None
    assert np.abs(mesh.colors - stored).max() <= 1e-7  # f32 storage of the f64 reference colour
