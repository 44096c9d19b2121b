"""The golden vectors decode in Python exactly as they did when generated (tests/vectors/README.md);
the C++ suite checks its decoders against the same files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plyfile
import pytest

from nfencode.bitstream import read_nfc
from nfencode.reference import dequantize, evaluate, extract_mesh

VECTORS = Path(__file__).resolve().parents[1] / "vectors"
NAMES = sorted(p.stem for p in VECTORS.glob("v1_0_*.nfc"))
MESH_RESOLUTION = 64
POSITION_TOLERANCE = 1e-5  # unit frame (times the file's scale in its original frame), README.md
NORMAL_TOLERANCE = 1e-3


def test_vectors_exist() -> None:
    assert len(NAMES) >= 5, f"golden vectors missing in {VECTORS}"


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
