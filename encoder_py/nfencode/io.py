"""Reading shapes (PLY, OBJ, OFF, glTF/GLB, each optionally gzip-compressed; aligned range scans
listed in a scanalyze .conf) and writing results.

Loading validates what the encoder relies on and reports anything else as a one-line InputError:
missing or unreadable files, unknown extensions, empty shapes, non-finite coordinates, meshes whose
faces all have zero area, and shapes whose points all coincide.
"""

from __future__ import annotations

import gzip
import io
import os
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import plyfile
import trimesh
from scipy.spatial.transform import Rotation

from .errors import InputError

MESH_EXTENSIONS = (".ply", ".obj", ".off", ".gltf", ".glb")
SCAN_ALIGNMENT_EXTENSION = ".conf"
POINT_EXTENSIONS = (".ply", ".obj")


@dataclass
class Shape:
    """A point cloud (faces None) or a triangle mesh, in the file's own coordinates."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray | None  # (F, 3) int64
    colors: np.ndarray | None  # (N, 3) uint8
    name: str

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None and len(self.faces) > 0


def split_extension(path: str | os.PathLike[str]) -> tuple[str, bool]:
    """('.ply', True) for 'bunny.ply.gz': the format extension (lower case) and whether gzipped."""
    name = Path(path).name.lower()
    gzipped = name.endswith(".gz")
    if gzipped:
        name = name[:-3]
    return Path(name).suffix, gzipped


def _read_bytes(path: Path, gzipped: bool) -> bytes:
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a shape file")
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror or e})") from None
    if not raw:
        raise InputError(f"{path}: file is empty")
    if gzipped:
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError, zlib.error) as e:
            raise InputError(f"{path}: not a valid gzip file ({e})") from None
        if not raw:
            raise InputError(f"{path}: file is empty after gzip decompression")
    return raw


def _fan_triangulate(polygons: list[np.ndarray] | np.ndarray) -> np.ndarray:
    """Triangles (F, 3) from polygons given as index lists; n-gons become fans around vertex 0."""
    polygon_list = [np.asarray(p) for p in polygons]
    sizes = {len(p) for p in polygon_list}
    if len(sizes) == 1:  # the common case, vectorised: all faces have the same number of corners
        corners = np.stack(polygon_list).astype(np.int64)
        if corners.shape[1] < 3:
            raise InputError(f"faces with {corners.shape[1]} vertices (at least 3 needed)")
        fans = [corners[:, [0, k, k + 1]] for k in range(1, corners.shape[1] - 1)]
        return np.stack(fans, axis=1).reshape(-1, 3)
    triangles = []
    for p in polygon_list:
        if len(p) < 3:
            raise InputError(f"a face with {len(p)} vertices (at least 3 needed)")
        for k in range(1, len(p) - 1):
            triangles.append((p[0], p[k], p[k + 1]))
    return np.asarray(triangles, dtype=np.int64).reshape(-1, 3)


def _ply_colors(vertex: plyfile.PlyElement) -> np.ndarray | None:
    names = vertex.data.dtype.names or ()
    for channels in (("red", "green", "blue"), ("r", "g", "b"), ("diffuse_red", "diffuse_green", "diffuse_blue")):
        if all(c in names for c in channels):
            rgb = np.stack([np.asarray(vertex[c], dtype=np.float64) for c in channels], axis=1)
            if np.issubdtype(vertex.data.dtype[channels[0]], np.floating) and rgb.size and rgb.max() <= 1.0:
                rgb = rgb * 255.0
            return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return None


def _load_ply(raw: bytes) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    with warnings.catch_warnings():  # plyfile warns about empty list rows (e.g. range_grid of raw scans)
        warnings.simplefilter("ignore")
        ply = plyfile.PlyData.read(io.BytesIO(raw))
    names = [e.name for e in ply.elements]
    if "vertex" not in names:
        raise InputError("PLY file has no 'vertex' element")
    vertex = ply["vertex"]
    props = vertex.data.dtype.names or ()
    if not all(c in props for c in "xyz"):
        raise InputError("PLY vertices lack x, y or z")
    vertices = np.stack([np.asarray(vertex[c], dtype=np.float64) for c in "xyz"], axis=1)
    faces = None
    if "face" in names and ply["face"].count > 0:
        face = ply["face"]
        fprops = face.data.dtype.names or ()
        key = "vertex_indices" if "vertex_indices" in fprops else "vertex_index" if "vertex_index" in fprops else None
        if key is None:
            raise InputError("PLY faces lack a 'vertex_indices' list")
        faces = _fan_triangulate(face[key])
    return vertices, faces, _ply_colors(vertex)


def _load_trimesh(raw: bytes, ext: str, path: Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    resolver = trimesh.resolvers.FilePathResolver(str(path.parent)) if ext == ".gltf" else None
    loaded = trimesh.load(
        io.BytesIO(raw), file_type=ext[1:], process=False, maintain_order=True, resolver=resolver
    )
    if isinstance(loaded, trimesh.Scene):
        geometries = list(loaded.geometry.values())
        if not geometries:
            return np.zeros((0, 3)), None, None
        if all(isinstance(g, trimesh.Trimesh) for g in geometries):
            loaded = loaded.to_mesh()  # applies the scene graph transforms
        elif all(isinstance(g, trimesh.PointCloud) for g in geometries):
            clouds = [g for g in loaded.dump() if isinstance(g, trimesh.PointCloud)]  # transforms applied
            loaded = trimesh.PointCloud(np.concatenate([np.asarray(g.vertices) for g in clouds]))
        else:
            raise InputError("scene mixes meshes with other geometry")
    if isinstance(loaded, trimesh.PointCloud):
        vertices = np.asarray(loaded.vertices, dtype=np.float64).reshape(-1, 3)
        colors = loaded.colors if loaded.colors is not None and len(loaded.colors) == len(vertices) else None
        return vertices, None, None if colors is None else np.asarray(colors)[:, :3].astype(np.uint8)
    if not isinstance(loaded, trimesh.Trimesh):
        raise InputError(f"unsupported geometry type {type(loaded).__name__}")
    vertices = np.asarray(loaded.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(loaded.faces, dtype=np.int64) if len(loaded.faces) else None
    visual = loaded.visual
    colors = None
    if isinstance(visual, trimesh.visual.ColorVisuals) and visual.kind == "vertex":
        colors = np.asarray(visual.vertex_colors)[:, :3].astype(np.uint8)
    return vertices, faces, colors


def _validate(path: Path, shape: Shape) -> Shape:
    v = shape.vertices
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise InputError(f"{path}: contains no vertices")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise InputError(f"{path}: {int(bad.sum())} of {len(v)} vertices have non-finite coordinates (NaN or inf)")
    extent = float(np.ptp(v, axis=0).max())
    if extent == 0.0:
        raise InputError(f"{path}: all {len(v)} points are identical")
    if shape.faces is not None:
        f = shape.faces
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise InputError(f"{path}: a face refers to a vertex that does not exist")
        if len(f) == 0:
            shape.faces = None
        else:
            tri = v[f]
            doubled_area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
            # Relative to the shape's size so that rounding noise on a flat mesh still counts as zero.
            if not (doubled_area > 1e-12 * extent * extent).any():
                raise InputError(f"{path}: degenerate mesh, all {len(f)} faces have zero area")
    if shape.colors is not None and shape.colors.shape != (len(v), 3):
        shape.colors = None
    return shape


def _rigid_transform(words: list[str]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(translation, unit quaternion) from `tx ty tz qx qy qz qw`, Nones if malformed."""
    try:
        values = np.array(words, dtype=np.float64)
    except ValueError:
        return None, None
    if values.shape != (7,) or not np.isfinite(values).all() or not np.linalg.norm(values[3:]) > 0:
        return None, None
    return values[:3], values[3:] / np.linalg.norm(values[3:])


def load_aligned_scans(path: str | os.PathLike[str]) -> Shape:
    """The range scans listed in a scanalyze alignment file (Stanford's `bun.conf`), each moved into
    the common frame, merged into one point cloud.

    Each `bmesh FILE tx ty tz qx qy qz qw` line names a scan beside the .conf (FILE or FILE.gz) and
    its rigid transform: p -> conj(q) p q + t, i.e. the rotation of the conjugate of the unit
    quaternion (vector part first) applied to p, then the translation. Checked on the bunny: every
    scan lands within 0.6 mm (median nearest-vertex distance) of the zippered bun_zipper.ply, while
    q itself, or t applied before the rotation, leaves most scans 1-30 cm off.
    """
    path = Path(path)
    gzipped = split_extension(path)[1]
    raw = _read_bytes(path, gzipped)
    clouds = []
    for number, line in enumerate(raw.decode("utf-8", errors="replace").splitlines(), 1):
        words = line.split()
        if not words or words[0] != "bmesh":
            continue  # camera and other directives place nothing
        t, q = _rigid_transform(words[2:])
        if t is None or q is None:
            raise InputError(f"{path}:{number}: expected `bmesh FILE tx ty tz qx qy qz qw`")
        scan = path.parent / words[1]
        if not scan.exists() and scan.with_name(scan.name + ".gz").exists():
            scan = scan.with_name(scan.name + ".gz")
        points = load_shape(scan).vertices
        clouds.append(Rotation.from_quat(q).inv().apply(points) + t)
    if not clouds:
        raise InputError(f"{path}: lists no scans (no `bmesh` lines)")
    name = Path(path.name[:-3] if gzipped else path.name).stem
    return _validate(path, Shape(vertices=np.concatenate(clouds), faces=None, colors=None, name=name))


def load_shape(path: str | os.PathLike[str]) -> Shape:
    """Load a point cloud or triangle mesh (or aligned range scans, see load_aligned_scans). Raises
    InputError with a one-line message."""
    path = Path(path)
    ext, gzipped = split_extension(path)
    if ext == SCAN_ALIGNMENT_EXTENSION:
        return load_aligned_scans(path)
    if ext not in MESH_EXTENSIONS:
        supported = ", ".join(MESH_EXTENSIONS + (SCAN_ALIGNMENT_EXTENSION,))
        raise InputError(f"{path}: unknown extension '{ext or path.suffix}' (supported: {supported}, each optionally .gz)")
    raw = _read_bytes(path, gzipped)
    try:
        if ext == ".ply":
            vertices, faces, colors = _load_ply(raw)
        else:
            vertices, faces, colors = _load_trimesh(raw, ext, path)
    except InputError as e:
        raise InputError(f"{path}: {e.message}") from None
    except Exception as e:  # parsers raise anything on malformed files; report it in one line
        detail = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise InputError(f"{path}: cannot parse as {ext[1:].upper()} ({detail})") from None
    name = Path(path.name[:-3] if gzipped else path.name).stem
    return _validate(path, Shape(vertices=vertices, faces=faces, colors=colors, name=name))


def _check_output(path: Path, allowed: tuple[str, ...]) -> str:
    ext = path.suffix.lower()
    if ext not in allowed:
        raise InputError(f"{path}: unsupported output extension '{ext}' (use {' or '.join(allowed)})")
    return ext


def save_mesh(
    path: str | os.PathLike[str], vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None
) -> None:
    """Write a triangle mesh as binary little-endian PLY or as OBJ, with optional vertex normals."""
    path = Path(path)
    ext = _check_output(path, (".ply", ".obj"))
    vertices = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float32).reshape(-1, 3)
    if ext == ".ply":
        fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
        if normals is not None:
            fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
        vdata = np.empty(len(vertices), dtype=fields)
        vdata["x"], vdata["y"], vdata["z"] = vertices.T
        if normals is not None:
            vdata["nx"], vdata["ny"], vdata["nz"] = normals.T
        fdata = np.empty(len(faces), dtype=[("vertex_indices", "u1"), ("i0", "<i4"), ("i1", "<i4"), ("i2", "<i4")])
        fdata["vertex_indices"] = 3
        fdata["i0"], fdata["i1"], fdata["i2"] = faces.T
        header = [
            "ply",
            "format binary_little_endian 1.0",
            "comment written by nfencode",
            f"element vertex {len(vertices)}",
            *[f"property float {name}" for name, _ in fields],
            f"element face {len(faces)}",
            "property list uchar int vertex_indices",
            "end_header",
        ]
        with open(path, "wb") as out:
            out.write(("\n".join(header) + "\n").encode("ascii"))
            out.write(vdata.tobytes())
            out.write(fdata.tobytes())
        return
    with open(path, "w", encoding="ascii") as out:
        out.write("# written by nfencode\n")
        np.savetxt(out, vertices, fmt="v %.9g %.9g %.9g")
        one_based = faces + 1
        if normals is not None:
            np.savetxt(out, normals, fmt="vn %.6g %.6g %.6g")
            np.savetxt(out, np.repeat(one_based, 2, axis=1), fmt="f %d//%d %d//%d %d//%d")
        else:
            np.savetxt(out, one_based, fmt="f %d %d %d")


def save_points(path: str | os.PathLike[str], points: np.ndarray) -> None:
    """Write a point cloud as binary PLY (vertex element only) or as OBJ `v` lines."""
    path = Path(path)
    ext = _check_output(path, POINT_EXTENSIONS)
    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    if ext == ".ply":
        vdata = np.empty(len(points), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4")])
        vdata["x"], vdata["y"], vdata["z"] = points.T
        plyfile.PlyData([plyfile.PlyElement.describe(vdata, "vertex")], text=False, byte_order="<").write(str(path))
        return
    with open(path, "w", encoding="ascii") as out:
        out.write("# written by nfencode\n")
        np.savetxt(out, points, fmt="v %.9g %.9g %.9g")
