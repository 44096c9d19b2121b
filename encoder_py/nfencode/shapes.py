"""Built-in demo shape, so the demo runs without any external data.

A bumpy torus: a closed genus-1 surface with detail at several scales, meshed from an analytic
implicit function with marching cubes. Usage: ``python -m nfencode.shapes OUT.ply [--resolution N]``.
"""

from __future__ import annotations

import argparse

import numpy as np
from skimage.measure import marching_cubes


def bumpy_torus_implicit(p: np.ndarray) -> np.ndarray:
    """Implicit function (negative inside) of a torus whose tube radius ripples along both angles."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    ring = np.sqrt(x * x + y * y)
    theta = np.arctan2(y, x)                      # around the ring
    phi = np.arctan2(z, ring - 0.6)               # around the tube
    tube = 0.22 + 0.035 * np.sin(5 * theta) * np.cos(3 * phi) + 0.01 * np.sin(17 * theta)
    return np.sqrt((ring - 0.6) ** 2 + z * z) - tube


def demo_shape(resolution: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (float64) and counter-clockwise faces (int64) of the demo mesh, about 1 unit wide."""
    axis = np.linspace(-1.0, 1.0, resolution + 1)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1)
    values = bumpy_torus_implicit(grid)
    spacing = (axis[1] - axis[0],) * 3
    verts, faces, _, _ = marching_cubes(values, level=0.0, spacing=spacing)
    verts = verts - 1.0
    # skimage's default gradient_direction already winds faces counter-clockwise from outside.
    return verts.astype(np.float64), faces.astype(np.int64)


def main() -> None:
    parser = argparse.ArgumentParser(description="Write the built-in demo shape (bumpy torus).")
    parser.add_argument("output", help="output .ply or .obj path")
    parser.add_argument("--resolution", type=int, default=160)
    args = parser.parse_args()
    from .io import save_mesh

    verts, faces = demo_shape(args.resolution)
    save_mesh(args.output, verts, faces)
    print(f"demo shape: {len(verts)} vertices, {len(faces)} triangles -> {args.output}")


if __name__ == "__main__":
    main()
