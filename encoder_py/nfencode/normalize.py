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


def to_unit(x: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    return (np.asarray(x, dtype=np.float64) - np.asarray(center, dtype=np.float64)) / scale


def from_unit(u: np.ndarray, center: np.ndarray, scale: float) -> np.ndarray:
    return np.asarray(u, dtype=np.float64) * scale + np.asarray(center, dtype=np.float64)
