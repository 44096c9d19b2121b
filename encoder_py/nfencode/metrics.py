"""Quality metrics exactly as shared/docs/metrics.md defines them.

Distances are measured in the ground truth's unit-ball frame (applied to both shapes). Meshes are
represented by area-weighted surface samples, point clouds by all their points or a uniform random
subset. CD is the sum of the two one-sided mean Euclidean nearest-neighbour distances.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from .bitstream import read_nfc
from .io import Shape
from .normalize import to_unit, unit_ball_frame
from .reference import extract_mesh, frame_offset, sample_points

DEFAULT_SAMPLES = 100_000


def shape_samples(shape: Shape, center: np.ndarray, scale: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """The point set that stands for `shape` in the metrics, in the frame (center, scale)."""
    vertices = to_unit(shape.vertices, center, scale)
    if shape.is_mesh:
        assert shape.faces is not None
        return sample_points(vertices, shape.faces, n, rng)
    if len(vertices) > n:
        return vertices[rng.choice(len(vertices), size=n, replace=False)]
    return vertices


def _generators(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Two independent streams: the ground truth's samples and the reconstruction's."""
    a, b = np.random.SeedSequence(seed).spawn(2)
    return np.random.default_rng(a), np.random.default_rng(b)


def chamfer_terms(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(mean over a of the distance to the nearest b, mean over b of the distance to the nearest a)."""
    a_to_b, _ = cKDTree(b).query(a, k=1)
    b_to_a, _ = cKDTree(a).query(b, k=1)
    return float(np.mean(a_to_b)), float(np.mean(b_to_a))


def chamfer_distance(gt: Shape, rec: Shape, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """CD(gt, rec) in the ground truth's unit-ball frame."""
    center, scale = unit_ball_frame(gt.vertices)
    rng_gt, rng_rec = _generators(seed)
    a = shape_samples(gt, center, scale, n_samples, rng_gt)
    b = shape_samples(rec, center, scale, n_samples, rng_rec)
    return sum(chamfer_terms(a, b))


def sampling_floor(gt: Shape, n_samples: int = DEFAULT_SAMPLES, seed: int = 0) -> float:
    """CD between two independent samplings of the ground truth: what a perfect codec would score.
    Zero for a point cloud that is used whole (no sampling)."""
    return chamfer_distance(gt, gt, n_samples, seed)


def _one_way_psnr(points: np.ndarray, colors: np.ndarray, other_points: np.ndarray, other_colors: np.ndarray) -> float:
    _, nearest = cKDTree(other_points).query(points, k=1)
    diff = colors.astype(np.float64) - other_colors[nearest].astype(np.float64)
    mse = float(np.mean(diff * diff))
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0**2 / mse)


def color_psnr_directions(gt_points: np.ndarray, gt_colors: np.ndarray, rec_points: np.ndarray,
                          rec_colors: np.ndarray) -> tuple[float, float]:
    """(PSNR(gt -> rec), PSNR(rec -> gt)), each over the nearest point's 8-bit RGB: the two terms of
    color_psnr, apart: which side of the matching a colouring loses (the encoder fits both)."""
    return (_one_way_psnr(gt_points, gt_colors, rec_points, rec_colors),
            _one_way_psnr(rec_points, rec_colors, gt_points, gt_colors))


def color_psnr(gt_points: np.ndarray, gt_colors: np.ndarray, rec_points: np.ndarray, rec_colors: np.ndarray) -> float:
    """Mean of PSNR(gt -> rec) and PSNR(rec -> gt), each over the nearest point's 8-bit RGB."""
    return 0.5 * sum(color_psnr_directions(gt_points, gt_colors, rec_points, rec_colors))


def shape_color_psnr(gt: Shape, rec: Shape) -> float | None:
    """Colour PSNR (metrics.md) between the vertices/points of two coloured shapes, in the ground
    truth's unit-ball frame; None unless both carry colours."""
    if gt.colors is None or rec.colors is None:
        return None
    center, scale = unit_ball_frame(gt.vertices)
    return color_psnr(to_unit(gt.vertices, center, scale), gt.colors, to_unit(rec.vertices, center, scale), rec.colors)


def file_chamfer_distance(gt: Shape, data: bytes, resolution: int, n_samples: int = DEFAULT_SAMPLES,
                          seed: int = 0) -> float:
    """CD(gt, the surface the reference decoder extracts from the .nfc bytes at `resolution`): what
    `nfc encode --target-cd` estimates a candidate by. Infinite when the field has no surface."""
    f = read_nfc(data)
    mesh = extract_mesh(f, resolution, color=False)
    if len(mesh.faces) == 0:
        return math.inf
    decoded = Shape(mesh.vertices + frame_offset(f), mesh.faces, None, "decoded")
    return chamfer_distance(gt, decoded, n_samples, seed)
