"""Geo-referenced shapes (FORMAT.md `fram`, 1.2): a point cloud 600 km from its origin keeps its
frame in 64 bits, and decodes with its frame error under 1 mm in every output of `nfc decode`."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import plyfile
import pytest

from conftest import SHARED_DATA
from nfencode import config
from nfencode.bitstream import NfcFile, read_nfc, write_nfc
from nfencode.cli import main
from nfencode.encoder import EncodeConfig, compress
from nfencode.io import Shape, load_shape
from nfencode.metrics import chamfer_distance
from nfencode.normalize import needs_frame64, unit_ball_frame
from nfencode.reference import decode_points, extract_mesh, extract_unit_mesh, frame_offset

MILK = SHARED_DATA / "colored" / "pcl_milk_color.ply.gz"  # a real scanned point cloud, 13,704 points
GEO_VECTOR = Path(__file__).resolve().parents[1] / "vectors" / "v1_2_bunny_scans_geo_udf_w16.nfc"
FAR = np.array([600123.456, 200654.321, 0.0])  # UTM-like metres
FRAME_TOLERANCE = 1e-3  # metres: 1 mm


def twin(f: NfcFile) -> NfcFile:
    """The same network framed at zero, without the 64-bit frame: its positions are the local
    u * scale that the geo file's are offset from."""
    g = dataclasses.replace(f.geometry, center=(0.0, 0.0, 0.0), frame64=None)
    return dataclasses.replace(f, geometry=g, minor=0)


@pytest.fixture(scope="module")
def milk() -> Shape:
    if not MILK.exists():
        pytest.skip("shared data not available")
    return dataclasses.replace(load_shape(MILK, colors="off"), faces=None)


def test_far_point_cloud_keeps_its_frame_in_64_bits(milk: Shape, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    tiny = EncodeConfig(field="udf", width=16, epochs=8, quiet=True)
    far = dataclasses.replace(milk, vertices=milk.vertices + FAR)
    data = compress(far, tiny).data
    f = read_nfc(data)
    assert (f.major, f.minor) == (1, 2)
    center, scale = unit_ball_frame(far.vertices)
    assert f.geometry.frame64 is not None
    assert f.geometry.frame64.center == tuple(center) and f.geometry.frame64.scale == scale  # exact f64
    assert f.geometry.center == tuple(float(np.float32(c)) for c in center)  # GEOM: the nearest f32
    # The decoded surface is where the input is, as well as the same encode near the origin's.
    mesh = extract_mesh(f, 96)
    placed = frame_offset(f) + mesh.vertices.astype(np.float64)
    cd_far = chamfer_distance(far, Shape(placed, mesh.faces, None, "decoded"), 20_000, 0)
    near_file = read_nfc(compress(milk, tiny).data)
    assert near_file.minor == 0 and near_file.geometry.frame64 is None  # milk is centred near its origin
    near = extract_mesh(near_file, 96)
    cd_near = chamfer_distance(milk, Shape(near.vertices.astype(np.float64), near.faces, None, "decoded"), 20_000, 0)
    assert cd_far < 1.25 * cd_near + 1e-3, (cd_far, cd_near)


def test_the_64_bit_frame_is_written_only_far_from_the_origin() -> None:
    assert not needs_frame64(np.array([0.5, -8.0, 1.0]), 1.0)  # 8 scales away: f32 is enough
    assert needs_frame64(np.array([0.5, -8.01, 1.0]), 1.0)
    assert needs_frame64(FAR, 50.0)  # a 100 m scan in UTM metres
    assert not needs_frame64(FAR, 1e5)  # a 200 km survey: f32 steps are 2^-20 of its size


def _read_ply_positions(path: Path) -> tuple[np.ndarray, str]:
    vertex = plyfile.PlyData.read(str(path))["vertex"]
    return np.stack([vertex[c] for c in "xyz"], axis=1), str(vertex.data.dtype["x"])


def test_nfc_decode_writes_positions_within_a_millimetre(tmp_path: Path) -> None:
    """Acceptance (Python side): mesh PLY, point PLY and OBJ hold offset + position in double."""
    f = read_nfc(GEO_VECTOR.read_bytes())
    offset = frame_offset(f)
    assert np.abs(offset).max() > 5e5
    local = extract_mesh(twin(f), 96).vertices.astype(np.float64)
    assert main(["decode", str(GEO_VECTOR), "-o", str(tmp_path / "m.ply"), "--resolution", "96"]) == 0
    written, dtype = _read_ply_positions(tmp_path / "m.ply")
    assert dtype == "float64"
    assert np.abs(written - (offset + local)).max() <= FRAME_TOLERANCE
    # f32 original coordinates would be off by up to 3 cm here: the test can fail.
    assert np.abs((offset + local).astype(np.float32).astype(np.float64) - (offset + local)).max() > 10 * FRAME_TOLERANCE

    assert main(["decode", str(GEO_VECTOR), "-o", str(tmp_path / "p.ply"), "--resolution", "96",
                 "--points", "3000", "--seed", "2"]) == 0
    points, _ = _read_ply_positions(tmp_path / "p.ply")
    expected, _ = decode_points(twin(f), extract_unit_mesh(f, 96), 3000, 2)
    assert np.abs(points - (offset + expected.astype(np.float64))).max() <= FRAME_TOLERANCE

    assert main(["decode", str(GEO_VECTOR), "-o", str(tmp_path / "m.obj"), "--resolution", "96"]) == 0
    rows = [line.split()[1:4] for line in (tmp_path / "m.obj").read_text().splitlines() if line.startswith("v ")]
    assert np.abs(np.array(rows, dtype=np.float64) - (offset + local)).max() <= FRAME_TOLERANCE


def test_geo_vector_rewrites_byte_identically() -> None:
    data = GEO_VECTOR.read_bytes()
    assert write_nfc(read_nfc(data)) == data
