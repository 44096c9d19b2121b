"""Per-vertex colours in, and out: PLY red/green/blue, OBJ `v x y z r g b`, glTF/GLB COLOR_0, and
what load_shape does with colours it cannot use."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import plyfile
import pytest

from nfencode.errors import InputError
from nfencode.io import load_shape, save_mesh, save_points

TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
RGB8 = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 128]], dtype=np.uint8)


def ply_cloud(path: Path, **channels: np.ndarray) -> Path:
    """A 3-point PLY cloud with the given extra vertex properties."""
    dtype = [("x", "f4"), ("y", "f4"), ("z", "f4")] + [(name, values.dtype.str) for name, values in channels.items()]
    data = np.empty(3, dtype=dtype)
    for k, c in enumerate("xyz"):
        data[c] = TRIANGLE[:, k]
    for name, values in channels.items():
        data[name] = values
    plyfile.PlyData([plyfile.PlyElement.describe(data, "vertex")]).write(str(path))
    return path


def loaded_colors(path: Path, mode: str = "auto") -> tuple[np.ndarray | None, list[str]]:
    warnings: list[str] = []
    shape = load_shape(path, colors=mode, warn=warnings.append)
    return shape.colors, warnings


@pytest.mark.parametrize("kind", ["u1", "f4_unit", "f4_255", "f8_unit"])
def test_ply_colours(tmp_path: Path, kind: str) -> None:
    if kind == "u1":
        values = RGB8
    elif kind == "f4_255":
        values = RGB8.astype(np.float32)
    else:
        values = (RGB8 / 255.0).astype(np.float32 if kind == "f4_unit" else np.float64)
    path = ply_cloud(tmp_path / "c.ply", red=values[:, 0], green=values[:, 1], blue=values[:, 2])
    colors, warnings = loaded_colors(path)
    assert warnings == []
    np.testing.assert_array_equal(colors, RGB8)
    assert loaded_colors(path, "off")[0] is None


@pytest.mark.parametrize(
    "channels,message",
    [
        ({"red": np.array([1, 2, 3], np.uint8), "green": np.array([1, 2, 3], np.uint8)}, "lack blue"),
        ({"red": np.array([0.1, np.nan, 0.3], np.float32), "green": np.zeros(3, np.float32),
          "blue": np.zeros(3, np.float32)}, "1 of 3 vertex colours are not finite"),
        ({"red": np.array([0.0, 300.0, 2.0], np.float32), "green": np.zeros(3, np.float32),
          "blue": np.zeros(3, np.float32)}, "beyond 255"),
        ({"red": np.array([-0.5, 0.0, 0.0], np.float32), "green": np.zeros(3, np.float32),
          "blue": np.zeros(3, np.float32)}, "negative"),
    ],
)
def test_bad_ply_colours_warn_or_fail(tmp_path: Path, channels: dict[str, np.ndarray], message: str) -> None:
    path = ply_cloud(tmp_path / "bad.ply", **channels)
    colors, warnings = loaded_colors(path)
    assert colors is None and len(warnings) == 1 and message in warnings[0] and "\n" not in warnings[0]
    assert "ignored" in warnings[0] and str(path) in warnings[0]
    with pytest.raises(InputError, match=message):
        load_shape(path, colors="on")
    assert loaded_colors(path, "off") == (None, [])


def write_obj(path: Path, rows: list[str]) -> Path:
    path.write_text("\n".join(rows + ["f 1 2 3"]) + "\n")
    return path


@pytest.mark.parametrize("scale", [1.0 / 255.0, 1.0])  # [0, 1] floats and 0..255 values
def test_obj_vertex_colours(tmp_path: Path, scale: float) -> None:
    rows = [f"v {p[0]} {p[1]} {p[2]} " + " ".join(f"{c * scale:.9g}" for c in rgb) for p, rgb in zip(TRIANGLE, RGB8)]
    colors, warnings = loaded_colors(write_obj(tmp_path / "c.obj", rows))
    assert warnings == []
    np.testing.assert_array_equal(colors, RGB8)


@pytest.mark.parametrize(
    "rows,message",
    [
        (["v 0 0 0 1 0 0", "v 1 0 0", "v 0 1 0 0 0 1"], "vertex colours on 2 of 3 vertices"),
        (["v 0 0 0 1 0 0", "v 1 0 0 0 1", "v 0 1 0 0 0 1"], "vertex colours on 2 of 3 vertices"),
        (["v 0 0 0 nan 0 0", "v 1 0 0 0 1 0", "v 0 1 0 0 0 1"], "not finite"),
    ],
)
def test_bad_obj_colours_warn_or_fail(tmp_path: Path, rows: list[str], message: str) -> None:
    path = write_obj(tmp_path / "bad.obj", rows)
    colors, warnings = loaded_colors(path)
    assert colors is None and len(warnings) == 1 and message in warnings[0]
    with pytest.raises(InputError, match=message):
        load_shape(path, colors="on")


def glb_triangle(colors: np.ndarray, component: int, kind: str) -> bytes:
    """A one-triangle GLB whose primitive has COLOR_0 of the given glTF componentType (5126 float,
    5121 unsigned byte, 5123 unsigned short; integers normalized) and type (VEC3 or VEC4)."""
    dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16}[component]
    views = [TRIANGLE.astype(np.float32).tobytes(), np.array([0, 1, 2], np.uint16).tobytes(),
             np.asarray(colors, dtype).tobytes()]
    padded = [v + b"\0" * (-len(v) % 4) for v in views]
    offsets = np.cumsum([0] + [len(v) for v in padded])
    color_accessor: dict = {"bufferView": 2, "componentType": component, "count": 3, "type": kind}
    if component != 5126:
        color_accessor["normalized"] = True
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 2}, "indices": 1}]}],
        "buffers": [{"byteLength": int(offsets[-1])}],
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[i]), "byteLength": len(views[i])} for i in range(3)],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0],
                       "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}, color_accessor],
    }
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary = b"".join(padded)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


@pytest.mark.parametrize(
    "component,kind,values",
    [
        (5126, "VEC3", RGB8 / 255.0),
        (5126, "VEC4", np.column_stack([RGB8 / 255.0, np.ones(3)])),
        (5121, "VEC3", RGB8),
        (5123, "VEC4", np.column_stack([RGB8.astype(np.uint32) * 257, np.full(3, 65535)])),
    ],
)
def test_gltf_color_0(tmp_path: Path, component: int, kind: str, values: np.ndarray) -> None:
    path = tmp_path / "c.glb"
    path.write_bytes(glb_triangle(values, component, kind))
    colors, warnings = loaded_colors(path)
    assert warnings == []
    np.testing.assert_array_equal(colors, RGB8)


def test_written_colours_read_back(tmp_path: Path) -> None:
    faces = np.array([[0, 1, 2]])
    for name in ("m.ply", "m.obj"):
        save_mesh(tmp_path / name, TRIANGLE, faces, None, RGB8)
        np.testing.assert_array_equal(loaded_colors(tmp_path / name)[0], RGB8)
    for name in ("p.ply", "p.obj"):
        save_points(tmp_path / name, TRIANGLE, RGB8)
        np.testing.assert_array_equal(loaded_colors(tmp_path / name)[0], RGB8)
    header = (tmp_path / "p.ply").read_bytes().split(b"end_header")[0].decode()
    assert "property uchar red" in header and "property uchar blue" in header
    save_mesh(tmp_path / "f.ply", TRIANGLE, faces, np.zeros((3, 3)), (RGB8 / 255.0).astype(np.float32))
    vertex = plyfile.PlyData.read(str(tmp_path / "f.ply"))["vertex"]
    assert vertex.data.dtype.names == ("x", "y", "z", "nx", "ny", "nz", "red", "green", "blue")
    np.testing.assert_allclose(vertex["green"], RGB8[:, 1] / 255.0, rtol=1e-7)
