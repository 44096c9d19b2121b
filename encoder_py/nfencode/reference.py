"""Numpy reference decoder: dequantize, evaluate the field (FORMAT.md, "Evaluation"), extract a mesh.

This module must not import torch: it is the oracle the C++ decoder and the golden vectors are
checked against, and it is what `nfc decode` runs. Extraction follows libnfdecode/src/extract.h:
sparse coarse-to-fine evaluation near the surface, then marching cubes on the finest cells that
contain the zero level set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
from skimage.measure import marching_cubes

from .bitstream import (
    FIELD_SDF,
    OUTPUT_ABS,
    OUTPUT_IDENTITY,
    OUTPUT_SIGMOID,
    NetworkBlock,
    NfcFile,
    positional_frequencies,
)
from .errors import InputError, NfcError

MIN_RESOLUTION = 8
MAX_RESOLUTION = 512  # the final level is meshed from a dense (cropped) array
COARSEST_RESOLUTION = 16
# A cell is refined when min |f| over its corners <= LIPSCHITZ_MARGIN * h * sqrt(3) / 2: a surface point
# in the cell is within h*sqrt(3)/2 of a corner, and the margin covers gradient norms above 1.
LIPSCHITZ_MARGIN = 2.0
NORMAL_STEP_CELLS = 0.5  # central-difference step of the normals, in fine cells (as libnfdecode)
EVALUATION_BATCH = 16384  # points per batch: bounds the (batch, width) activations in memory

UDF_NOT_MESHABLE = (
    "UDF meshing is not implemented yet (MeshUDF extractor planned); use `nfc info` or evaluate the field"
)

FieldFn = Callable[[np.ndarray], np.ndarray]

# Corner offsets of a cell, in the bit order (dx, dy, dz) = bits (2, 1, 0) of the corner number.
_CORNERS = np.array([[(c >> 2) & 1, (c >> 1) & 1, c & 1] for c in range(8)], dtype=np.int64)


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
    faces: np.ndarray  # (F, 3) int64, counter-clockwise seen from outside (positive field)
    normals: np.ndarray  # (V, 3) float32, unit length, towards positive field
    points_evaluated: int  # field evaluations of the coarse-to-fine grid (normals not counted)


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


def positional_encoding(frequencies: np.ndarray, unit_points: np.ndarray) -> np.ndarray:
    """FORMAT.md step 2: [u, sin(f_k u), cos(f_k u) per k], with f32 products f_k * u_j whose sine
    and cosine are taken accurately (in f64) and rounded to f32."""
    u = np.asarray(unit_points, dtype=np.float32).reshape(-1, 3)
    products = frequencies[None, :, None] * u[:, None, :]  # (N, L, 3), f32 * f32 -> f32
    angles = products.astype(np.float64)
    per_frequency = np.concatenate([np.sin(angles), np.cos(angles)], axis=2).astype(np.float32)
    return np.concatenate([u, per_frequency.reshape(len(u), -1)], axis=1)


def evaluate(net: DecodedNetwork, unit_points: np.ndarray) -> np.ndarray:
    """Field values at points of the unit frame: (N,) for one output, (N, out) otherwise.
    Layers accumulate in f64 from the f32 weights and the f32 encoding."""
    points = np.asarray(unit_points, dtype=np.float32).reshape(-1, 3)
    weights = [w.astype(np.float64) for w in net.weights]
    biases = [b.astype(np.float64) for b in net.biases]
    omega0 = float(net.omega0)
    outputs = []
    for start in range(0, len(points), EVALUATION_BATCH):
        h = positional_encoding(net.frequencies, points[start : start + EVALUATION_BATCH]).astype(np.float64)
        for w, b in zip(weights[:-1], biases[:-1]):
            h = np.sin(omega0 * (h @ w.T + b))
        outputs.append(h @ weights[-1].T + biases[-1])
    y = np.concatenate(outputs) if outputs else np.zeros((0, len(biases[-1])))
    if net.output == OUTPUT_ABS:
        y = np.abs(y)
    elif net.output == OUTPUT_SIGMOID:
        y = 1.0 / (1.0 + np.exp(-y))
    elif net.output != OUTPUT_IDENTITY:
        raise NfcError(f"unknown output activation {net.output}")
    return y[:, 0] if y.shape[1] == 1 else y


def coarse_resolution(resolution: int) -> int:
    """Halve while the result stays even-derived and at least COARSEST_RESOLUTION (256 -> 16)."""
    r = resolution
    while r % 2 == 0 and r // 2 >= COARSEST_RESOLUTION:
        r //= 2
    return r


def grid_coordinates(indices: np.ndarray, resolution: int) -> np.ndarray:
    """Unit-frame positions -1 + 2 i / N of grid vertex indices, computed in f32 exactly as
    libnfdecode does (-1.0f + float(i) * (2.0f / float(N))), so both evaluate the same points."""
    step = np.float32(2.0) / np.float32(resolution)
    return np.float32(-1.0) + indices.astype(np.float32) * step


def _keys(indices: np.ndarray, resolution: int) -> np.ndarray:
    n = resolution + 1
    return (indices[..., 0] * n + indices[..., 1]) * n + indices[..., 2]


def _lookup(keys: np.ndarray, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    """values at `query` keys; every query key must be in the sorted `keys`."""
    return values[np.searchsorted(keys, query)]


def _evaluate_level(
    field_fn: FieldFn, cells: np.ndarray, resolution: int, previous: tuple[np.ndarray, np.ndarray] | None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Values at the deduplicated corners of `cells` (sorted keys, values) and the number of new
    evaluations. Corners with all-even indices coincide with the previous level's vertices and are
    looked up instead of evaluated."""
    corners = (cells[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 3)
    keys, first = np.unique(_keys(corners, resolution), return_index=True)
    vertex_indices = corners[first]
    values = np.empty(len(keys), dtype=np.float64)
    if previous is None:
        known = np.zeros(len(keys), dtype=bool)
    else:
        known = (vertex_indices % 2 == 0).all(axis=1)
        values[known] = _lookup(*previous, _keys(vertex_indices[known] // 2, resolution // 2))
    new = ~known
    values[new] = field_fn(grid_coordinates(vertex_indices[new], resolution))
    return keys, values, int(new.sum())


def _central_difference_normals(field_fn: FieldFn, points: np.ndarray, eps: float, fallback: np.ndarray) -> np.ndarray:
    """Normalised central-difference gradients; `fallback` (unit vectors) where the gradient vanishes."""
    offsets = np.eye(3) * eps
    stacked = np.concatenate([points + o for o in offsets] + [points - o for o in offsets])
    values = np.asarray(field_fn(stacked.astype(np.float32)), dtype=np.float64).reshape(6, len(points))
    gradient = (values[:3] - values[3:]).T / (2.0 * eps)
    norm = np.linalg.norm(gradient, axis=1, keepdims=True)
    return np.where(norm > 0, gradient / np.maximum(norm, 1e-300), fallback)


def extract_mesh_from_field(
    field_fn: FieldFn, resolution: int = 256, truncation: float = 0.1
) -> ExtractedMesh:
    """Zero level set of a signed field (negative inside) over [-1, 1]^3, in the unit frame.

    Coarse-to-fine: every vertex of the coarse grid is evaluated; at each level a cell is kept when
    its corners change sign or come within LIPSCHITZ_MARGIN * h * sqrt(3) / 2 of zero, and only the
    corners of the kept cells' children are evaluated at the next level. Marching cubes then runs on
    the finest cells whose corners change sign. Normals are the normalised central-difference
    gradient (step NORMAL_STEP_CELLS fine cells), pointing towards positive values.
    """
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise InputError(f"resolution {resolution} outside {MIN_RESOLUTION}..{MAX_RESOLUTION}")
    r = coarse_resolution(resolution)
    axis = np.arange(r, dtype=np.int64)
    cells = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    keys, values, evaluated = _evaluate_level(field_fn, cells, r, None)
    while True:
        corner_values = _lookup(keys, values, _keys(cells[:, None, :] + _CORNERS[None, :, :], r))
        sign_change = (corner_values.min(axis=1) < 0) & (corner_values.max(axis=1) >= 0)
        if r == resolution:
            break
        h = 2.0 / r
        near = np.abs(corner_values).min(axis=1) <= LIPSCHITZ_MARGIN * h * math.sqrt(3.0) / 2.0
        kept = cells[sign_change | near]
        cells = (2 * kept[:, None, :] + _CORNERS[None, :, :]).reshape(-1, 3)
        r *= 2
        keys, values, new = _evaluate_level(field_fn, cells, r, (keys, values))
        evaluated += new

    active = cells[sign_change]
    if len(active) == 0:
        empty = np.zeros((0, 3), dtype=np.float32)
        return ExtractedMesh(empty, np.zeros((0, 3), dtype=np.int64), empty, evaluated)

    # Dense array over the bounding box of the active cells; vertices not evaluated stay at
    # +truncation and the mask keeps marching cubes to the active cells.
    lo = active.min(axis=0)
    shape = tuple(int(s) for s in active.max(axis=0) - lo + 2)
    volume = np.full(shape, np.float32(truncation), dtype=np.float32)
    local = _indices_from_keys(keys, r) - lo
    inside_box = ((local >= 0) & (local < np.array(shape))).all(axis=1)
    local = local[inside_box]
    volume[local[:, 0], local[:, 1], local[:, 2]] = values[inside_box]
    mask = np.zeros(shape, dtype=bool)
    # skimage's Lewiner marching cubes tests the mask at a cell's far corner (x+1, y+1, z+1);
    # tests/python/test_reference.py would see holes or stray faces if that ever changed.
    far = active - lo + 1
    mask[far[:, 0], far[:, 1], far[:, 2]] = True
    h = 2.0 / resolution
    # Default gradient direction: triangles come out counter-clockwise seen from the positive side.
    verts, faces, grid_normals, _ = marching_cubes(volume, level=0.0, spacing=(h, h, h), mask=mask)
    unit = verts.astype(np.float64) + (-1.0 + h * lo)
    # skimage's normals point to decreasing values (inside); the gradient is better, they are the fallback.
    normals = _central_difference_normals(field_fn, unit, NORMAL_STEP_CELLS * h, -grid_normals)
    return ExtractedMesh(unit.astype(np.float32), faces.astype(np.int64), normals.astype(np.float32), evaluated)


def _indices_from_keys(keys: np.ndarray, resolution: int) -> np.ndarray:
    n = resolution + 1
    return np.stack([keys // (n * n), (keys // n) % n, keys % n], axis=1)


def field_function(file: NfcFile) -> FieldFn:
    """The geometry field of a file as a function of unit-frame points."""
    net = dequantize(file.geometry.network)
    return lambda points: evaluate(net, points)


def extract_mesh(file: NfcFile, resolution: int = 256) -> ExtractedMesh:
    """Mesh of an SDF file in the original coordinates (x = u * scale + center, in f32)."""
    g = file.geometry
    if g.field_type != FIELD_SDF:
        raise NfcError(UDF_NOT_MESHABLE)
    mesh = extract_mesh_from_field(field_function(file), resolution, g.truncation)
    positions = mesh.vertices * np.float32(g.scale) + np.asarray(g.center, dtype=np.float32)
    return mesh._replace(vertices=positions.astype(np.float32))


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
