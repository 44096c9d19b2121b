"""The unit-ball frame of shared/docs/metrics.md: AABB centre at the origin, largest vertex norm 1."""

from __future__ import annotations

import numpy as np


def unit_ball_frame(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """(center, scale): the axis-aligned bounding box centre and the largest norm of the centred
    vertices, so that (vertices - center) / scale lies in the unit ball with one vertex on its sphere."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    center = 0.5 * (v.min(axis=0) + v.max(axis=0))
    scale = float(np.linalg.norm(v - center, axis=1).max())
    return center, scale


# How far (in frame scales) a frame's center may lie from the origin before the file stores the
# frame in 64 bits (FORMAT.md `fram`): beyond it an f32 coordinate's step, |center| * 2^-23,
# exceeds 2^-20 of the scale (about 1/500 of a cell at resolution 1024), and positions emitted in
# f32 original coordinates, or the center rounded to f32, would move the shape by that much.
FRAME64_DISTANCE = 8.0


def needs_frame64(center: np.ndarray, scale: float) -> bool:
    """Whether the frame (center, scale) must be kept in 64 bits: geo-referenced data, e.g. LiDAR
    in UTM metres, lies 10^5..10^7 scales from its origin, where f32 positions snap to centimetres."""
    return float(np.max(np.abs(np.asarray(center, dtype=np.float64)))) > FRAME64_DISTANCE * scale


def to_unit(x: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    return (np.asarray(x, dtype=np.float64) - np.asarray(center, dtype=np.float64)) / scale


def from_unit(u: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    return np.asarray(u, dtype=np.float64) * scale + np.asarray(center, dtype=np.float64)
