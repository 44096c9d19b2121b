"""Reading shapes (PLY, OBJ, OFF, glTF/GLB, each optionally gzip-compressed; aligned range scans
listed in a scanalyze .conf) and writing results.

Loading validates what the encoder relies on and reports anything else as a one-line InputError:
missing or unreadable files, unknown extensions, empty shapes, non-finite coordinates, meshes whose
faces all have zero area, and shapes whose points all coincide. Memory stays bounded by the input:
files (after gzip) above MAX_INPUT_BYTES, and PLY headers announcing more elements than the file's
bytes can hold, are refused before anything is allocated for them.
"""

from __future__ import annotations

import io
import os
import warnings
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import plyfile
import trimesh
from scipy.spatial.transform import Rotation

from .errors import InputError

MESH_EXTENSIONS = (".ply", ".obj", ".off", ".gltf", ".glb")
SCAN_ALIGNMENT_EXTENSION = ".conf"
POINT_EXTENSIONS = (".ply", ".obj")
Warn = Callable[[str], None]
COLOR_MODES = ("auto", "on", "off")  # load_shape's `colors`, EncodeConfig.color


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


MAX_INPUT_BYTES = 4 << 30  # a shape file's size after gzip: 4 GiB (~150 M binary PLY points)


def _gunzip(path: Path, raw: bytes) -> bytes:
    """gzip members decompressed up to MAX_INPUT_BYTES: a bomb stops at the limit."""
    out, data = [], raw
    total = 0
    try:
        while data:
            stream = zlib.decompressobj(16 + zlib.MAX_WBITS)
            out.append(stream.decompress(data, MAX_INPUT_BYTES - total + 1))
            total += len(out[-1])
            if total > MAX_INPUT_BYTES or stream.unconsumed_tail:
                raise InputError(f"{path}: decompresses to more than {MAX_INPUT_BYTES} bytes (the input limit)")
            if not stream.eof:
                raise InputError(f"{path}: not a valid gzip file (truncated)")
            data = stream.unused_data.lstrip(b"\0")  # concatenated members; zero padding
    except zlib.error as e:
        raise InputError(f"{path}: not a valid gzip file ({e})") from None
    return b"".join(out)


def _read_bytes(path: Path, gzipped: bool) -> bytes:
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a shape file")
    size = path.stat().st_size
    if size > MAX_INPUT_BYTES:
        raise InputError(f"{path}: {size} bytes, more than the input limit of {MAX_INPUT_BYTES}")
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror or e})") from None
    if not raw:
        raise InputError(f"{path}: file is empty")
    if gzipped:
        raw = _gunzip(path, raw)
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


class ColorProblem(NamedTuple):
    """Why an input's colours cannot be used (one line): the shape is then read without them."""

    message: str


Colors = np.ndarray | ColorProblem | None  # (N, 3) uint8, unusable, or none in the file


def _eight_bit(rgb: np.ndarray, integer: bool) -> np.ndarray | ColorProblem:
    """(N, 3) uint8 from colour values: integers are 0..255; floats are [0, 1] (scaled by 255) when
    none exceeds 1, else 0..255."""
    bad = ~np.isfinite(rgb).all(axis=1)
    if bad.any():
        return ColorProblem(f"{int(bad.sum())} of {len(rgb)} vertex colours are not finite (NaN or inf)")
    if rgb.size and rgb.min() < 0.0:
        return ColorProblem(f"negative vertex colour values (down to {rgb.min():g})")
    if not integer and rgb.size and rgb.max() <= 1.0:
        rgb = rgb * 255.0
    if rgb.size and rgb.max() > 255.0:
        return ColorProblem(f"vertex colour values up to {rgb.max():g}, beyond 255")
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _ply_colors(vertex: plyfile.PlyElement) -> Colors:
    names = vertex.data.dtype.names or ()
    for channels in (("red", "green", "blue"), ("r", "g", "b"), ("diffuse_red", "diffuse_green", "diffuse_blue")):
        present = [c for c in channels if c in names]
        if len(present) == 3:
            rgb = np.stack([np.asarray(vertex[c], dtype=np.float64) for c in channels], axis=1)
            return _eight_bit(rgb, not np.issubdtype(vertex.data.dtype[channels[0]], np.floating))
        if present and channels[0] != "r":  # single letters r/g/b alone are too common to mean colour
            missing = ", ".join(c for c in channels if c not in names)
            return ColorProblem(f"vertex colours lack {missing}")
    return None


def _obj_colors(raw: bytes, vertex_count: int) -> Colors:
    """`v x y z r g b` lines (r g b in [0, 1], or 0..255): trimesh clamps 0..255 values and reads NaN
    as 0, so the colours are parsed here, from the same `v` lines trimesh keeps in order."""
    rows = [line.split()[1:] for line in raw.decode("utf-8", errors="replace").splitlines()
            if line.startswith(("v ", "v\t"))]
    colored = sum(len(r) >= 6 for r in rows)
    if colored == 0:
        return None
    if colored != len(rows) or any(len(r) != 6 for r in rows):
        return ColorProblem(f"vertex colours on {colored} of {len(rows)} vertices (each `v` needs x y z r g b)")
    if len(rows) != vertex_count:
        return ColorProblem(f"{len(rows)} coloured vertices for {vertex_count} mesh vertices")
    try:
        rgb = np.array([r[3:6] for r in rows], dtype=np.float64)
    except ValueError:
        return ColorProblem("vertex colours that are not numbers")
    return _eight_bit(rgb, integer=False)


PLY_SIZES = {name: size for size, names in ((1, "char uchar int8 uint8"), (2, "short ushort int16 uint16"),
                                           (4, "int uint int32 uint32 float float32"), (8, "double float64"))
             for name in names.split()}


def _check_ply_counts(raw: bytes) -> None:
    """Refuses a PLY header whose elements need more bytes than follow it (each binary record at
    least its fixed fields and one byte per list count; each ASCII value at least two characters),
    so that a few bytes announcing 10^12 vertices cannot make the parser allocate for them."""
    end = raw.find(b"end_header")
    if end < 0:
        return  # not a PLY header: the parser says so
    lines = raw[:end].decode("ascii", errors="replace").splitlines()
    binary = any(line.split()[:2] in (["format", "binary_little_endian"], ["format", "binary_big_endian"])
                 for line in lines if line.strip())
    needed, count, record = 0, 0, 0
    for words in (line.split() for line in lines):
        if words[:1] == ["element"] and len(words) >= 3 and words[2].isdigit():
            needed += count * record
            count, record = int(words[2]), 0
        elif words[:1] == ["property"] and len(words) >= 3:
            kind = "list" if words[1] == "list" else words[1]
            record += 2 if not binary else PLY_SIZES.get(words[2], 1) if kind == "list" else PLY_SIZES.get(kind, 1)
    needed += count * record
    available = len(raw) - end
    if needed > available:
        raise InputError(f"PLY header announces elements of at least {needed} bytes, but only {available} follow it")


def _load_ply(raw: bytes) -> tuple[np.ndarray, np.ndarray | None, Colors]:
    _check_ply_counts(raw)
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


def _load_trimesh(raw: bytes, ext: str, path: Path) -> tuple[np.ndarray, np.ndarray | None, Colors]:
    """Meshes and clouds through trimesh: OBJ vertex colours parsed from the file (_obj_colors),
    glTF/GLB `COLOR_0` (float, normalized ubyte or ushort; RGB or RGBA) as trimesh converts it."""
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
    if ext == ".obj":
        return vertices, faces, _obj_colors(raw, len(vertices))
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
    return shape


def _usable_colors(path: Path, colors: Colors, vertex_count: int, mode: str, warn: Warn | None) -> np.ndarray | None:
    """The colours load_shape keeps: none with mode "off"; unusable ones are an InputError with mode
    "on" (colour was asked for) and a warning otherwise."""
    if mode == "off" or colors is None:
        return None
    if not isinstance(colors, ColorProblem) and colors.shape != (vertex_count, 3):
        colors = ColorProblem(f"{len(colors)} vertex colours for {vertex_count} vertices")
    if isinstance(colors, ColorProblem):
        if mode == "on":
            raise InputError(f"{path}: {colors.message}")
        if warn is not None:
            warn(f"{path}: {colors.message}; its colours are ignored")
        return None
    return colors


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


def load_shape(path: str | os.PathLike[str], colors: str = "auto", warn: Warn | None = None) -> Shape:
    """Load a point cloud or triangle mesh (or aligned range scans, see load_aligned_scans). Raises
    InputError with a one-line message.

    Per-vertex colours (PLY red/green/blue, OBJ `v x y z r g b`, glTF COLOR_0) come as 8-bit RGB.
    `colors`: "auto" keeps usable colours and reports unusable ones (NaN, missing channels, wrong
    count) to `warn`, one line, reading the shape without them; "on" makes them an InputError;
    "off" ignores colours."""
    path = Path(path)
    ext, gzipped = split_extension(path)
    if ext == SCAN_ALIGNMENT_EXTENSION:
        return load_aligned_scans(path)
    if ext not in MESH_EXTENSIONS:
        supported = ", ".join(MESH_EXTENSIONS + (SCAN_ALIGNMENT_EXTENSION,))
        raise InputError(f"{path}: unknown extension '{ext or path.suffix}' (supported: {supported}, each optionally .gz)")
    if colors not in COLOR_MODES:
        raise ValueError(f"unknown colour mode {colors!r}")
    raw = _read_bytes(path, gzipped)
    try:
        if ext == ".ply":
            vertices, faces, found = _load_ply(raw)
        else:
            vertices, faces, found = _load_trimesh(raw, ext, path)
    except InputError as e:
        raise InputError(f"{path}: {e.message}") from None
    except Exception as e:  # parsers raise anything on malformed files; report it in one line
        detail = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise InputError(f"{path}: cannot parse as {ext[1:].upper()} ({detail})") from None
    name = Path(path.name[:-3] if gzipped else path.name).stem
    shape = _validate(path, Shape(vertices=vertices, faces=faces, colors=None, name=name))
    shape.colors = _usable_colors(path, found, len(shape.vertices), colors, warn)
    return shape


def _check_output(path: Path, allowed: tuple[str, ...]) -> str:
    ext = path.suffix.lower()
    if ext not in allowed:
        raise InputError(f"{path}: unsupported output extension '{ext}' (use {' or '.join(allowed)})")
    return ext


PLY_TYPES = {"<f4": "float", "<f8": "double", "|u1": "uchar"}  # the columns written, by dtype
COLOR_NAMES = ("red", "green", "blue")


def placed_positions(positions: np.ndarray, offset: np.ndarray | None) -> np.ndarray:
    """f32 positions, or with a non-zero offset (a geo-referenced frame: FORMAT.md "Output
    positions") offset + position in f64, exact where f32 would snap it to a coarse grid."""
    positions = np.asarray(positions, dtype=np.float32).reshape(-1, 3)
    if offset is None or not np.any(np.asarray(offset) != 0.0):
        return positions
    return np.asarray(offset, dtype=np.float64) + positions.astype(np.float64)


def _vertex_table(
    vertices: np.ndarray, normals: np.ndarray | None, colors: np.ndarray | None
) -> np.ndarray:
    """PLY vertex records: x y z (float, or double for f64 vertices), then nx ny nz (float) and red
    green blue (uchar 0..255, or float when `colors` is floating point) where given."""
    columns = [(("x", "y", "z"), vertices, "<f8" if vertices.dtype == np.float64 else "<f4")]
    if normals is not None:
        columns.append((("nx", "ny", "nz"), np.asarray(normals, dtype=np.float32).reshape(-1, 3), "<f4"))
    if colors is not None:
        colors = np.asarray(colors).reshape(-1, 3)
        if len(colors) != len(vertices):
            raise ValueError(f"{len(colors)} colours for {len(vertices)} vertices")
        columns.append((COLOR_NAMES, colors, "<f4" if np.issubdtype(colors.dtype, np.floating) else "u1"))
    table = np.empty(len(vertices), dtype=[(name, kind) for names, _, kind in columns for name in names])
    for names, values, _ in columns:
        for k, name in enumerate(names):
            table[name] = values[:, k]
    return table


def save_mesh(
    path: str | os.PathLike[str],
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None = None,
    colors: np.ndarray | None = None,
    offset: np.ndarray | None = None,
) -> None:
    """Write a triangle mesh as binary little-endian PLY or as OBJ, with optional vertex normals and
    colours (uint8 RGB; PLY also takes float colours, written as float properties). The vertices
    are f32, relative to `offset` (placed_positions: double coordinates when it is non-zero)."""
    path = Path(path)
    ext = _check_output(path, (".ply", ".obj"))
    vertices = placed_positions(vertices, offset)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float32).reshape(-1, 3)
    if ext == ".ply":
        vdata = _vertex_table(vertices, normals, colors)
        fdata = np.empty(len(faces), dtype=[("vertex_indices", "u1"), ("i0", "<i4"), ("i1", "<i4"), ("i2", "<i4")])
        fdata["vertex_indices"] = 3
        fdata["i0"], fdata["i1"], fdata["i2"] = faces.T
        header = [
            "ply",
            "format binary_little_endian 1.0",
            "comment written by nfencode",
            f"element vertex {len(vertices)}",
            *[f"property {PLY_TYPES[vdata.dtype[name].str]} {name}" for name in vdata.dtype.names or ()],
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
        _write_obj_vertices(out, vertices, colors)
        one_based = faces + 1
        if normals is not None:
            np.savetxt(out, normals, fmt="vn %.6g %.6g %.6g")
            np.savetxt(out, np.repeat(one_based, 2, axis=1), fmt="f %d//%d %d//%d %d//%d")
        else:
            np.savetxt(out, one_based, fmt="f %d %d %d")


def _write_obj_vertices(out: io.TextIOBase, vertices: np.ndarray, colors: np.ndarray | None) -> None:
    """`v x y z`, or `v x y z r g b` with r g b in [0, 1] (the common vertex-colour extension);
    uint8 colours are divided by 255, float ones written as they are."""
    xyz = "%.17g %.17g %.17g" if vertices.dtype == np.float64 else "%.9g %.9g %.9g"  # round trip
    if colors is None:
        np.savetxt(out, vertices, fmt="v " + xyz)
    else:
        unit = np.asarray(colors, dtype=np.float64).reshape(-1, 3)
        if not np.issubdtype(np.asarray(colors).dtype, np.floating):
            unit = unit / 255.0
        np.savetxt(out, np.column_stack([vertices, unit]), fmt="v " + xyz + " %.6g %.6g %.6g")


def save_points(
    path: str | os.PathLike[str], points: np.ndarray, colors: np.ndarray | None = None,
    offset: np.ndarray | None = None,
) -> None:
    """Write a point cloud as binary PLY (vertex element only, uchar red/green/blue with `colors`,
    uint8 RGB) or as OBJ `v` lines; f32 points relative to `offset`, as save_mesh."""
    path = Path(path)
    ext = _check_output(path, POINT_EXTENSIONS)
    points = placed_positions(points, offset)
    if ext == ".ply":
        vdata = _vertex_table(points, None, None if colors is None else np.asarray(colors, dtype=np.uint8))
        plyfile.PlyData([plyfile.PlyElement.describe(vdata, "vertex")], text=False, byte_order="<").write(str(path))
        return
    with open(path, "w", encoding="ascii") as out:
        out.write("# written by nfencode\n")
        _write_obj_vertices(out, points, colors)
