"""Consistently oriented normals of a point cloud, for the sides of a UDF's signed start.

A cloud has no faces to say which side of the surface a point lies on, but a scanned surface is
smooth at the scale of a few neighbours: each point's normal is the least-variance direction of its
k nearest neighbours (PCA), and neighbouring normals are made to agree by propagating an orientation
along the minimum spanning tree of the k-nearest-neighbour graph weighted by 1 - |n_i . n_j|, so that
it crosses where neighbours are nearly parallel first and sharp creases last (Hoppe et al. 1992,
"Surface reconstruction from unorganized points"). Each connected piece starts from its point
farthest from its centroid, whose normal points away from the centroid (outward for a closed blob).

A normal means something only where the neighbourhood is flat: its least variance at most
FLATNESS times the middle one (a line, a clump of duplicates or a volume has no such direction).
`flat` marks those points, and `agreement` is the share of neighbour pairs of flat points with
clearly related normals (|n_i . n_j| > 0.5) whose orientations agree. Smooth scans reach ~1 on both;
a cloud that is no surface (noise, a volume, a curve) does not. `edge` marks the points whose
neighbours lie to one side: their centroid is off the point, along the surface, by more than
EDGE_SHIFT of their mean distance (where the sampled surface ends, or a stray point).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree


FLATNESS = 0.5
"""A neighbourhood is flat when its least variance is at most this share of the middle one: 97.7-99.8%
of the points of the bunny's scans, loot, the milk and office clouds (median 0.05-0.11)."""

EDGE_SHIFT = 0.7
"""A point is an edge point when its neighbours' centroid lies off it, along the surface, by more
than 0.7 of their mean distance (a half-disc gives ~0.64, so mostly corners, ends and strays; random
sampling of a closed surface: 0.04-0.08% of its points). Shares: the bunny's range scans 0.009%,
loot 0.004%, the egyptian mask 0.18%; PCL's single-view Kinect and stereo scenes 0.36-5.0%."""

TREE_NEIGHBOURS = 8
"""The orientation spreads over each point's nearest 8 of its PCA neighbours: enough to connect a
scan (the bunny's range scans: one piece), and half the sorting of the spanning tree over all 16
(1.5 s instead of 3 s on those 362k points, the same agreement)."""


class OrientedNormals(NamedTuple):
    normals: np.ndarray  # (n, 3) float64, unit
    flat: np.ndarray  # (n,) bool: the neighbourhood is flat, so the normal means something
    edge: np.ndarray  # (n,) bool: the point's neighbours lie to one side of it
    agreement: float  # share of clearly related neighbour pairs of flat points that agree


def oriented_normals(points: np.ndarray, neighbours: int, tree: cKDTree | None = None) -> OrientedNormals:
    """Unit normals of `points` (n, 3), consistently oriented over each connected piece of the
    k-nearest-neighbour graph (k = `neighbours`); `tree`: a KD-tree of `points` already built."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    n = len(points)
    k = min(neighbours, n - 1)
    if k < 1:  # one point: no neighbourhood, so nothing flat and no normal that means anything
        return OrientedNormals(np.zeros((n, 3)), np.zeros(n, bool), np.zeros(n, bool), 0.0)
    distances, nearest = (tree or cKDTree(points)).query(points, k + 1, workers=-1)
    distances, nearest = distances[:, 1:], nearest[:, 1:]
    around = points[nearest]
    centroid = around.mean(axis=1)
    around -= centroid[:, None, :]
    variances, vectors = np.linalg.eigh(np.matmul(around.transpose(0, 2, 1), around))
    del around
    normals = np.ascontiguousarray(vectors[:, :, 0])  # eigh sorts ascending: least variance first
    # The middle variance must be more than rounding of the largest: a curve or a clump has none.
    flat = (variances[:, 1] > 1e-6 * variances[:, 2]) & (variances[:, 0] <= FLATNESS * variances[:, 1])
    shift = centroid - points
    shift -= np.einsum("ij,ij->i", shift, normals)[:, None] * normals
    edge = np.linalg.norm(shift, axis=1) > EDGE_SHIFT * distances.mean(axis=1)

    rows, cols = np.repeat(np.arange(n), k), nearest.ravel()
    cosines = np.einsum("ij,ij->i", normals[rows], normals[cols])
    # The spanning tree over each point's nearest TREE_NEIGHBOURS; + a little, so that parallel
    # neighbours keep their edge (a zero weight is no edge).
    near = (np.arange(n * k) % k) < TREE_NEIGHBOURS
    graph = coo_matrix((1.0 - np.abs(cosines[near]) + 1e-6, (rows[near], cols[near])), shape=(n, n)).tocsr()
    flip = _flips_along(minimum_spanning_tree(graph.maximum(graph.T)), points, normals)
    normals[flip] *= -1.0
    cosines[flip[rows] != flip[cols]] *= -1.0  # the pairs with one end turned

    related = (np.abs(cosines) > 0.5) & flat[rows] & flat[cols]
    agreement = float((cosines[related] > 0.0).mean()) if related.any() else 0.0
    return OrientedNormals(normals, flat, edge, agreement)


def _flips_along(tree, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Which normals to turn so that each agrees with its parent in `tree` (a spanning forest, each
    edge stored once, read both ways), each piece's root pointing away from its centroid."""
    n = len(points)
    pieces, piece = connected_components(tree, directed=False)
    centroid = np.zeros((pieces, 3))
    np.add.at(centroid, piece, points)
    centroid /= np.bincount(piece, minlength=pieces)[:, None]
    reach = np.linalg.norm(points - centroid[piece], axis=1)
    order = np.lexsort((reach, piece))  # by piece, the farthest point last
    roots = order[np.r_[np.flatnonzero(np.diff(piece[order])), n - 1]]
    # One search for every piece: from an extra node n joined to each root.
    tree = tree.tocoo()
    rows, cols = np.r_[tree.row, np.full(pieces, n)], np.r_[tree.col, roots]
    whole = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n + 1,) * 2).tocsr()
    _, predecessors = breadth_first_order(whole, n, directed=False)
    parent = predecessors[:n].copy()
    parent[roots] = -1
    flip = np.zeros(n, bool)  # relative to the parent; for a root, absolute
    child = parent >= 0
    flip[child] = np.einsum("ij,ij->i", normals[child], normals[parent[child]]) < 0.0
    flip[roots] = np.einsum("ij,ij->i", normals[roots], points[roots] - centroid[piece[roots]]) < 0.0
    # XOR of the flips up to the root, by pointer jumping: after step s, `up` is 2^s levels higher.
    up = parent.copy()
    while (up >= 0).any():
        climbing = up >= 0
        flip[climbing] ^= flip[up[climbing]]
        up[climbing] = up[up[climbing]]
    return flip
