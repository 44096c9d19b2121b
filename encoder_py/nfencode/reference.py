"""Numpy reference decoder: dequantize, evaluate the field and its gradient (FORMAT.md,
"Evaluation"), extract a mesh, and colour it (or points on it) when the file has a `colr` chunk.

This module must not import torch: it is the oracle the C++ decoder and the golden vectors are
checked against, and it is what `nfc decode` runs. Extraction runs libnfdecode's algorithm step for
step (grid.h, extract.h): the same levels and schedules (grid), the same generated table
(mc_tables), the same welding, vertex order and normals (mesh_sdf, mesh_udf), in f32 where C++
computes in f32, so that both produce the same topology. Only the network is evaluated in f64 (and
rounded to f32 on the grid); C++ accumulates in f32, ~1e-7 away.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .bitstream import (
    COLOR_CHANNELS,
    FIELD_SDF,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    OUTPUT_SIGMOID,
    GeometryChunk,
    NetworkBlock,
    NfcFile,
    positional_frequencies,
)
from .errors import InputError, NfcError
from .grid import FieldFn, GradientFn, build_grid
from .mesh_sdf import mesh_sdf
from .mesh_udf import mesh_udf

EVALUATION_BATCH = 16384  # points per batch: bounds the (batch, width, 3) activations in memory


@dataclass
class DecodedNetwork:
    """Dequantized network: f32 weights w = f32(q) * step, and the f32 encoding frequencies."""

    frequencies: np.ndarray  # (L,) float32
    omega0: np.float32
    output: int
    weights: list[np.ndarray]  # per layer (out, in) float32
    biases: list[np.ndarray]  # per layer (out,) float32


class ExtractedMesh(NamedTuple):
    vertices: np.ndarray  # (V, 3) float32
    faces: np.ndarray  # (F, 3) int64; SDF: counter-clockwise seen from outside (positive field)
    normals: np.ndarray  # (V, 3) float32, unit length; SDF: towards positive field
    points_evaluated: int  # field value evaluations of the coarse-to-fine grid
    gradients_evaluated: int  # value + gradient evaluations (UDF meshing)
    active_cells: int  # finest cells that emitted a triangle
    colors: np.ndarray | None = None  # (V, 3) float64 in [0, 1] when the file's colour was evaluated


def dequantize(block: NetworkBlock) -> DecodedNetwork:
    weights, biases = [], []
    for (w_levels, b_levels), (w_step, b_step) in zip(block.levels, block.steps):
        weights.append(np.asarray(w_levels).astype(np.float32) * np.float32(w_step))
        biases.append(np.asarray(b_levels).astype(np.float32) * np.float32(b_step))
    return DecodedNetwork(
        frequencies=positional_frequencies(block.num_frequencies, block.frequency_base),
        omega0=np.float32(block.omega0),
        output=block.output,
        weights=weights,
        biases=biases,
    )


def _sines_and_cosines(frequencies: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos (N, L, 3) of the f32 products f_k * u_j, taken accurately (in f64) and rounded
    to f32 (FORMAT.md step 2)."""
    angles = (frequencies[None, :, None] * u[:, None, :]).astype(np.float64)  # f32 * f32 -> f32
    return np.sin(angles).astype(np.float32), np.cos(angles).astype(np.float32)


def _encode(u: np.ndarray, sines: np.ndarray, cosines: np.ndarray) -> np.ndarray:
    return np.concatenate([u, np.concatenate([sines, cosines], axis=2).reshape(len(u), -1)], axis=1)


def positional_encoding(frequencies: np.ndarray, unit_points: np.ndarray) -> np.ndarray:
    """FORMAT.md step 2: [u, sin(f_k u), cos(f_k u) per k], (N, 3 + 6L) float32."""
    u = np.asarray(unit_points, dtype=np.float32).reshape(-1, 3)
    return _encode(u, *_sines_and_cosines(frequencies, u))


def _first_layer_derivatives(
    weights: np.ndarray, frequencies: np.ndarray, sines: np.ndarray, cosines: np.ndarray
) -> np.ndarray:
    """d(first pre-activation) / du, (N, 3, width): along u_j only u_j and its own sines and cosines
    change (d sin(f u_j) = f cos(f u_j), d cos(f u_j) = -f sin(f u_j))."""
    f = frequencies.astype(np.float64)[None, :]
    k = np.arange(len(frequencies))
    per_axis = []
    for j in range(3):
        columns = np.concatenate([[j], 3 + 6 * k + j, 6 + 6 * k + j])
        derivatives = np.concatenate([np.ones((len(sines), 1)), f * cosines[:, :, j], -f * sines[:, :, j]], axis=1)
        per_axis.append(derivatives @ weights[:, columns].T)
    return np.stack(per_axis, axis=1)


def _forward(net: DecodedNetwork, u: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Outputs (N, out) of one batch of f32 points and, with `gradient`, their derivatives
    (N, out, 3) by forward mode. Layers accumulate in f64 from the f32 weights and the f32 encoding."""
    omega0 = float(net.omega0)
    weights = [w.astype(np.float64) for w in net.weights]
    sines, cosines = _sines_and_cosines(net.frequencies, u)
    h = _encode(u, sines, cosines).astype(np.float64)
    dh = _first_layer_derivatives(weights[0], net.frequencies, sines, cosines) if gradient else None
    for layer, (w, b) in enumerate(zip(weights, net.biases)):
        z = h @ w.T + b.astype(np.float64)
        if dh is not None and layer > 0:
            dh = (dh.reshape(-1, w.shape[1]) @ w.T).reshape(len(u), 3, w.shape[0])
        if layer + 1 == len(weights):
            h = z
            break
        h = np.sin(omega0 * z)
        if dh is not None:
            dh = (omega0 * np.cos(omega0 * z))[:, None, :] * dh
    if net.output == OUTPUT_ABS:
        slope = np.where(h >= 0, 1.0, -1.0)  # sign(0) = +1, as libnfdecode
        h = np.abs(h)
    elif net.output == OUTPUT_SIGMOID:
        h = 1.0 / (1.0 + np.exp(-h))
        slope = h * (1.0 - h)
    elif net.output == OUTPUT_IDENTITY:
        slope = np.ones_like(h)
    else:
        raise NfcError(f"unknown output activation {net.output}")
    return h, None if dh is None else (slope[:, None, :] * dh).transpose(0, 2, 1)


def _batched(net: DecodedNetwork, unit_points: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(unit_points, dtype=np.float32).reshape(-1, 3)
    outputs = len(net.biases[-1])
    values, gradients = [np.zeros((0, outputs))], [np.zeros((0, outputs, 3))]
    for start in range(0, len(points), EVALUATION_BATCH):
        y, dy = _forward(net, points[start : start + EVALUATION_BATCH], gradient)
        values.append(y)
        if dy is not None:
            gradients.append(dy)
    y, dy = np.concatenate(values), np.concatenate(gradients)
    return (y[:, 0], dy[:, 0]) if outputs == 1 else (y, dy)


def evaluate(net: DecodedNetwork, unit_points: np.ndarray) -> np.ndarray:
    """Field values at points of the unit frame: (N,) for one output, (N, out) otherwise."""
    return _batched(net, unit_points, gradient=False)[0]


def evaluate_gradient(net: DecodedNetwork, unit_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values (as `evaluate`, bit for bit) and analytic gradients d value / d unit coordinate,
    (N, 3) for one output, (N, out, 3) otherwise: forward mode through the encoding, the sine layers
    and the output activation (abs: sign(y) dy with sign(0) = +1; sigmoid: s (1 - s) dy)."""
    return _batched(net, unit_points, gradient=True)


def evaluate_color(net: DecodedNetwork, unit_points: np.ndarray) -> np.ndarray:
    """Colours (N, 3) in [0, 1] of a colour network (sigmoid, 3 outputs) at unit-frame points."""
    if net.output != OUTPUT_SIGMOID or len(net.biases[-1]) != COLOR_CHANNELS:
        raise NfcError("not a colour network (sigmoid with 3 outputs)")
    return evaluate(net, unit_points).reshape(-1, COLOR_CHANNELS)


def color_bytes(colors: np.ndarray) -> np.ndarray:
    """8-bit colour of FORMAT.md: min(255, floor(255 c + 0.5)) per channel, (N, 3) uint8."""
    return np.minimum(255.0, np.floor(255.0 * np.asarray(colors, dtype=np.float64) + 0.5)).astype(np.uint8)


def shape_ball_bound(values: np.ndarray, unit_points: np.ndarray, truncation: float) -> np.ndarray:
    """Grid values as decoders read them (FORMAT.md, "The shape's ball"; network.h, ShapeBall): an
    encoder puts the shape inside the unit ball, so at points with x*x + y*y + z*z > (1 + 2 d*)^2
    (f32, in that order) a value below d* is raised to d* and no surface is extracted there. A NaN
    stays NaN."""
    floor = np.float32(truncation)
    radius = np.float32(1.0) + np.float32(2.0) * floor
    u = np.asarray(unit_points, dtype=np.float32)
    beyond = (u[:, 0] * u[:, 0] + u[:, 1] * u[:, 1]) + u[:, 2] * u[:, 2] > radius * radius
    values = np.asarray(values, dtype=np.float32)  # as the grid holds them
    return np.where(beyond & (values < floor), floor, values)


def field_function(file: NfcFile) -> FieldFn:
    """The geometry field of a file as its grid reads it (shape_ball_bound), a function of
    unit-frame points."""
    net = dequantize(file.geometry.network)
    truncation = file.geometry.truncation
    return lambda points: shape_ball_bound(evaluate(net, points), points, truncation)


def gradient_function(file: NfcFile) -> GradientFn:
    """The gradient of the geometry field of a file at unit-frame points."""
    net = dequantize(file.geometry.network)
    return lambda points: evaluate_gradient(net, points)[1]


def extract_mesh_from_field(
    field_fn: FieldFn, resolution: int = 256, udf_gradient: GradientFn | None = None,
    band: bool = False, truncation: float = math.inf,
) -> ExtractedMesh:
    """The surface of a field over [-1, 1]^3, in the unit frame, as libnfdecode extracts it.

    Without `udf_gradient` the field is signed (negative inside) and its zero level set is meshed
    by marching cubes (mesh_sdf). With it the field is unsigned, `udf_gradient` is its gradient, and
    the pseudo-signed mesher (mesh_udf) runs. Either way the coarse-to-fine grid (grid.build_grid)
    evaluates the field only near the surface (an SDF's only where it crosses cells, unless `band`:
    nfd_mesh_options.sample_band). `truncation` is the field's d* (infinity: not truncated).
    """
    grid = build_grid(field_fn, resolution, udf_gradient, band, truncation)
    mesh = mesh_sdf(grid) if udf_gradient is None else mesh_udf(grid)
    return ExtractedMesh(mesh.vertices, mesh.faces, mesh.normals, grid.points_evaluated,
                         grid.gradients_evaluated, mesh.active_cells)


def extract_unit_mesh(file: NfcFile, resolution: int = 256, band: bool = False) -> ExtractedMesh:
    """Mesh of an SDF or UDF file in its unit frame, as the extractor produces it (no colours);
    `band` as for extract_mesh_from_field."""
    udf_gradient = None if file.geometry.field_type == FIELD_SDF else gradient_function(file)
    return extract_mesh_from_field(field_function(file), resolution, udf_gradient, band,
                                   file.geometry.truncation)


def frame_of(g: GeometryChunk) -> tuple[np.ndarray, float]:
    """(center, scale) of the unit frame the field was trained in, f64: the 64-bit frame where the
    file has one, else GEOM's f32 values."""
    if g.frame64 is not None:
        return np.asarray(g.frame64.center, dtype=np.float64), g.frame64.scale
    return np.asarray(g.center, dtype=np.float64), g.scale


def frame_offset(file: NfcFile) -> np.ndarray:
    """What emitted positions are relative to (FORMAT.md "Output positions"), f64: the 64-bit
    frame's center, or zero for a file without one."""
    g = file.geometry
    return np.asarray(g.frame64.center if g.frame64 is not None else (0.0, 0.0, 0.0), dtype=np.float64)


def emitted_positions(file: NfcFile, unit_points: np.ndarray) -> np.ndarray:
    """x = u * scale + c in f32 (FORMAT.md "Output positions"): c is GEOM's center, or zero for a
    file with a 64-bit frame, whose positions are relative to frame_offset(file)."""
    g = file.geometry
    u = np.asarray(unit_points, dtype=np.float32)
    center = np.zeros(3, np.float32) if g.frame64 is not None else np.asarray(g.center, dtype=np.float32)
    return (u * np.float32(g.scale) + center).astype(np.float32)


def _colors_at(file: NfcFile, unit_points: np.ndarray, color: bool) -> np.ndarray | None:
    if not color or file.color is None:
        return None
    return evaluate_color(dequantize(file.color.network), unit_points)


def extract_mesh(file: NfcFile, resolution: int = 256, color: bool = True, band: bool = False) -> ExtractedMesh:
    """Mesh of an SDF or UDF file in the original coordinates, relative to frame_offset(file) (as
    emitted_positions places them). With
    `color` and a colour chunk, `colors` holds the colour at each vertex, evaluated at the unit-frame
    vertex the extractor produced. `band` as for extract_mesh_from_field."""
    mesh = extract_unit_mesh(file, resolution, band)
    return mesh._replace(vertices=emitted_positions(file, mesh.vertices),
                         colors=_colors_at(file, mesh.vertices, color))


def decode_points(
    file: NfcFile, unit_mesh: ExtractedMesh, n: int, seed: int | np.random.Generator = 0, color: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """n points (f32, original frame relative to frame_offset(file)) uniformly on `unit_mesh`
    (extract_unit_mesh of `file`), and
    with `color` and a colour chunk their colours (n, 3) in [0, 1], evaluated at the f32 unit-frame
    points the positions are made from."""
    u = sample_points(unit_mesh.vertices, unit_mesh.faces, n, seed).astype(np.float32)
    return emitted_positions(file, u), _colors_at(file, u, color)


def sample_points(
    vertices: np.ndarray, faces: np.ndarray, n: int, seed: int | np.random.Generator = 0
) -> np.ndarray:
    """n points uniformly distributed over the mesh surface (area-weighted), deterministic in seed
    (an integer seed or a Generator to draw from)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    tri = v[f]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = float(areas.sum())
    if len(f) == 0 or not total > 0.0:
        raise InputError("cannot sample points on a mesh without surface area")
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(f), size=n, p=areas / total)
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    a, b, c = tri[chosen, 0], tri[chosen, 1], tri[chosen, 2]
    return (1.0 - r1)[:, None] * a + (r1 * (1.0 - r2))[:, None] * b + (r1 * r2)[:, None] * c
