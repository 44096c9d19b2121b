"""Ground-truth distance pool: training points and their (truncated) distances, built once.

All coordinates are in the unit-ball frame. A pool holds `POOL_EPOCHS` epochs' worth of the paper's
three kinds of points, uniform in [-1, 1]³, on the surface (distance 0) and on the surface plus
N(0, σ); each epoch draws its 20% / 40% / 40% mix from it (`draw_epoch`). A separate, smaller set of
the same mix is held out for validation.

Distances: meshes get the exact point-to-triangle distance (libigl's AABB tree), signed for SDF by
the fast generalized winding number, which tolerates the small holes of real scans; point clouds get
the nearest-neighbour distance (UDF only). Beyond 2·d* the exact value is never needed (the loss
clamps at d*), so queries are bounded there, which makes far uniform points ~5x cheaper.

A UDF also gets each point's *side* (±1): which side of the nearest surface it lies on. A mesh's by
its faces' orientation, which open surfaces have too (libigl's pseudonormal test; +1 where the
nearest surface point is on a free edge), when the faces are consistently oriented or can be made so
(`oriented_share`, `SurfaceSampler.orient_consistently`); a cloud's by the normal of its nearest
point, once the cloud's normals are estimated and consistently oriented (cloud_normals; +1 where
the offset runs along the surface rather than away from it, as past the edge of an open sheet).
Training starts from the field signed by it (train.fit).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import igl
import numpy as np
from scipy.spatial import cKDTree

from . import config
from .cloud_normals import oriented_normals
from .errors import InputError

FAR = 2.0 * config.MAX_TRUNCATION
"""Distance stored for points farther than the query bound (only its sign and |d| > d* matter)."""

CLOUD_FAR_SAMPLE = 20_000
"""Points of the coarse subsample that gives a cloud's sides beyond FAR (about; every n // this-th)."""

ON_BOUNDARY = 1e-9
"""How near (unit frame) a closest point must be to a free edge to count as on it: float64 rounding of
libigl's closest points, which land on the edge itself."""


@dataclass
class DistancePool:
    """Training samples, the three kinds stored one after the other, plus a held-out validation set.

    points (n, 3) float32 in the unit frame; distances (n,) float32 with |d| clamped to at most FAR;
    sides (n,) float32 ±1 for a UDF with sides (SurfaceSampler.unsigned_distances_and_sides), else None.
    """

    points: np.ndarray
    distances: np.ndarray
    counts: tuple[int, int, int]  # uniform, surface, near
    validation_points: np.ndarray
    validation_distances: np.ndarray
    sides: np.ndarray | None = None
    sides_note: str = ""  # a UDF: whether and how its sides were taken, for the log


class SurfaceSampler:
    """Distance queries against the input geometry: a triangle mesh, or a point cloud if faces is None."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray | None) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = None if faces is None else np.ascontiguousarray(faces, dtype=np.int64)
        self.normals: np.ndarray | None = None  # a cloud's, once orient_cloud_normals ran: 0 where
        # the neighbourhood is not flat, so that no side is taken from it
        self._coarse: cKDTree | None = None  # every so many of a cloud's points, for far sides
        self._coarse_index = np.zeros(0, np.int64)
        if self.faces is not None:
            a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
            areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
            total = float(areas.sum())
            if not np.isfinite(total) or total <= 0.0:
                raise InputError("the mesh has zero surface area")
            self._area_cdf = np.cumsum(areas) / total
            self._tree = None
        else:
            self._tree = cKDTree(self.vertices)

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None

    def surface_points(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n points uniformly distributed on the surface (area-weighted), or drawn from the cloud."""
        if self.faces is None:
            return self.vertices[rng.integers(0, len(self.vertices), n)]
        tri = np.searchsorted(self._area_cdf, rng.random(n) * self._area_cdf[-1], side="right")
        tri = np.minimum(tri, len(self.faces) - 1)
        r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
        a, b, c = (self.vertices[self.faces[tri, i]] for i in range(3))
        return (1.0 - r1)[:, None] * a + (r1 * (1.0 - r2))[:, None] * b + (r1 * r2)[:, None] * c

    def winding_numbers(self, points: np.ndarray) -> np.ndarray:
        """Fast generalized winding number of the mesh at each point (≈1 inside, ≈0 outside)."""
        assert self.faces is not None
        return igl.fast_winding_number(self.vertices, self.faces, np.ascontiguousarray(points, np.float64))

    def distances(self, points: np.ndarray, signed: bool) -> np.ndarray:
        """Distance to the surface, |d| clamped to FAR; negative inside when `signed` (meshes only)."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        if self.faces is None:
            assert not signed, "point clouds have no inside"
            d, _ = self._tree.query(points, distance_upper_bound=FAR)  # type: ignore[union-attr]
            return np.minimum(d, FAR)
        kind = igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER if signed else igl.SIGNED_DISTANCE_TYPE_UNSIGNED
        d, *_ = igl.signed_distance(points, self.vertices, self.faces, sign_type=kind, lower_bound=-FAR, upper_bound=FAR)
        # libigl returns NaN where the bound pruned the search: those points are farther than d*
        # (measured: pruned points lie > 1.8·d* away), so only their sign is still needed.
        far = np.isnan(d)
        if far.any():
            if signed:
                inside = self.winding_numbers(points[far]) > 0.5
                d[far] = np.where(inside, -FAR, FAR)
            else:
                d[far] = FAR
        return np.clip(d, -FAR, FAR)

    def unsigned_distances_and_sides(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`distances(points, signed=False)` (the same values), and ±1 (float32): the side of the
        surface each point lies on. A mesh's by the faces' orientation (libigl's pseudonormal test:
        the angle-weighted normal of the nearest feature), +1 where the nearest surface point lies on
        the mesh's free boundary: beyond a free edge the sheet does not go on, and a side there would
        make the signed start continue it (bench/RESULTS.md). A cloud's by its nearest point's
        oriented normal (orient_cloud_normals), -1 only where the offset from that point leans
        against the normal by more than config.CLOUD_SIDE_COSINE of its length: an offset along the
        surface is what points past the edge of an open sheet have; beyond FAR, the nearest of a
        coarse subsample of the cloud decides (a far point's side does not depend on finer detail,
        and an unbounded query of the whole cloud made loot's pool ~40 s slower). Meshes: one
        unbounded query, since far points need a side too. 0 counts as +1."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        if self.faces is None:
            assert self.normals is not None and self._coarse is not None, "orient_cloud_normals first"
            d, nearest = self._tree.query(points, distance_upper_bound=FAR, workers=-1)  # type: ignore[union-attr]
            far = nearest == len(self.vertices)  # nothing within the bound
            _, coarse = self._coarse.query(points[far], workers=-1)
            nearest[far] = self._coarse_index[coarse]
            offset = points - self.vertices[nearest]
            along = np.einsum("ij,ij->i", offset, self.normals[nearest])
            reach = np.where(far, np.linalg.norm(offset, axis=1), d)
            # A point whose neighbourhood is not flat has a zero normal: no side from it (+1).
            side = np.where(along < -config.CLOUD_SIDE_COSINE * reach, -1.0, 1.0).astype(np.float32)
            return np.minimum(d, FAR), side
        d, face, closest, *_ = igl.signed_distance(points, self.vertices, self.faces,
                                                   sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)
        side = np.where(d < 0.0, -1.0, 1.0).astype(np.float32)
        side[self._on_free_boundary(face, closest)] = 1.0
        return np.minimum(np.abs(d), FAR), side

    def _on_free_boundary(self, face: np.ndarray, closest: np.ndarray) -> np.ndarray:
        """Whether each point `closest` of face `face` lies on a free edge or a free vertex (an end of
        one) of the mesh, to within float64 rounding."""
        assert self.faces is not None
        faces, vertices = self.faces, self.vertices
        free_edge = edge_table(faces).free  # (F, 3): face f's edge from corner k to k + 1
        free_vertex = np.zeros(len(vertices), bool)
        for k in range(3):
            free_vertex[faces[free_edge[:, k], k]] = free_vertex[faces[free_edge[:, k], (k + 1) % 3]] = True
        on = np.zeros(len(face), bool)
        for k in range(3):
            at = free_edge[face, k]
            a, b = vertices[faces[face[at], k]], vertices[faces[face[at], (k + 1) % 3]]
            ab, ac = b - a, closest[at] - a
            t = np.clip(np.einsum("ij,ij->i", ac, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
            on[at] |= np.linalg.norm(ac - t[:, None] * ab, axis=1) <= ON_BOUNDARY
            corner = faces[face, k]
            at = free_vertex[corner]
            on[at] |= np.linalg.norm(closest[at] - vertices[corner[at]], axis=1) <= ON_BOUNDARY
        return on

    def near_points(self, n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
        return self.surface_points(n, rng) + rng.normal(0.0, sigma, (n, 3))

    def orient_cloud_normals(self) -> tuple[float, float, float]:
        """A cloud's consistently oriented normals (cloud_normals), kept for its sides, but none
        (zero) where the neighbourhood is not flat, which then gives no side; returns the shares
        of its points that are flat and that are edge points, and of clearly related flat
        neighbours whose normals agree."""
        assert self.faces is None
        normals, flat, edge, agreement = oriented_normals(self.vertices, config.CLOUD_NORMAL_NEIGHBOURS, self._tree)
        self.normals = np.where(flat[:, None], normals, 0.0)
        self._coarse_index = np.arange(0, len(self.vertices), max(1, len(self.vertices) // CLOUD_FAR_SAMPLE))
        self._coarse = cKDTree(self.vertices[self._coarse_index])
        return float(flat.mean()), float(edge.mean()), agreement

    def flip_orientation(self) -> None:
        assert self.faces is not None
        self.faces = np.ascontiguousarray(self.faces[:, ::-1])

    def orient_consistently(self) -> None:
        """Reorients faces so that neighbours agree (libigl's BFS over each edge-connected patch), each
        patch keeping the orientation most of its faces had. Distances do not depend on orientation;
        sides do."""
        assert self.faces is not None
        before = self.faces
        after, patch = igl.bfs_orient(before)
        kept = np.zeros(len(before), bool)  # whether face f's orientation is unchanged
        for k in range(3):
            kept |= (after[:, 0] == before[:, k]) & (after[:, 1] == before[:, (k + 1) % 3])
        votes = np.bincount(patch, weights=np.where(kept, -1.0, 1.0))
        back = votes[patch] > 0  # most of the patch was turned: turn it all back
        after[back] = after[back][:, ::-1]
        self.faces = np.ascontiguousarray(after)


class EdgeTable(NamedTuple):
    """A mesh's edges: `edge[f, k]` the index of face f's edge from corner k to k + 1, `uses` how many
    faces use each edge, `forward[f, k]` whether face f runs along it from its lower vertex index."""

    edge: np.ndarray
    uses: np.ndarray
    forward: np.ndarray

    @property
    def free(self) -> np.ndarray:
        """(F, 3): whether face f's edge k belongs to no other face (the mesh's free boundary)."""
        return self.uses[self.edge] == 1


def edge_table(faces: np.ndarray) -> EdgeTable:
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2)  # (F, 3, 2): corner k -> k + 1
    _, edge, uses = np.unique(np.sort(directed, axis=2).reshape(-1, 2), axis=0, return_inverse=True,
                              return_counts=True)
    return EdgeTable(edge.reshape(-1, 3), uses, directed[..., 0] < directed[..., 1])


def oriented_share(faces: np.ndarray) -> float:
    """Of the edges that exactly two faces share, the share the two traverse in opposite directions
    (consistently oriented neighbours); 0 when no edge is shared."""
    table = edge_table(faces)
    balance = np.zeros(len(table.uses), np.int64)  # +1 per use from the lower vertex, -1 from the upper
    np.add.at(balance, table.edge.reshape(-1), np.where(table.forward, 1, -1).reshape(-1))
    shared = table.uses == 2
    return float((balance[shared] == 0).mean()) if shared.any() else 0.0


class FieldChoice(NamedTuple):
    field: str  # "sdf" or "udf"
    reason: str  # one line: why, for the log


def resolve_field(sampler: SurfaceSampler, requested: str, rng: np.random.Generator, width: int) -> FieldChoice:
    """Turn `--field auto|sdf|udf` into "sdf" or "udf", with the reason; orient a mesh so its inside
    is negative.

    Point clouds are always UDF. For meshes one probe of winding numbers near the surface serves both
    decisions: a mesh wound inside-out (w ≈ -1 inside) is flipped, whatever the request (so that a
    UDF's signed start has the same sides, and draws the same numbers afterwards, whether `auto`
    chose it or the user asked for it: one seed, one file), and `auto` picks SDF when at most
    config.AUTO_SDF_MAX_AMBIGUOUS of the probe is ambiguous (config.AMBIGUOUS_WINDING), i.e. the mesh
    encloses an inside despite small holes or folds, unless it has holes and the network is at least
    config.AUTO_UDF_WIDTH_WITH_HOLES wide (a `width` network's fit is then better than the caps an SDF
    puts over the holes).
    """
    if requested not in ("auto", "sdf", "udf"):
        raise InputError(f"unknown field type {requested!r} (use sdf, udf or auto)")
    if not sampler.is_mesh:
        if requested == "sdf":
            raise InputError("a point cloud has no inside: it can only be encoded as a UDF (--field udf)")
        return FieldChoice("udf", "a point cloud has no inside")
    w = sampler.winding_numbers(sampler.near_points(config.AUTO_PROBE_POINTS, config.AUTO_PROBE_SIGMA, rng))
    if np.sum(w < -0.5) > np.sum(w > 0.5):
        sampler.flip_orientation()
    if requested != "auto":
        return FieldChoice(requested, "requested")
    low, high = config.AMBIGUOUS_WINDING
    ambiguous = float(np.mean((np.abs(w) > low) & (np.abs(w) < high)))
    measured = f"{ambiguous:.2%} of the probe points near the surface have an ambiguous winding number"
    if ambiguous > config.AUTO_SDF_MAX_AMBIGUOUS:
        return FieldChoice("udf", f"{measured}: more than {config.AUTO_SDF_MAX_AMBIGUOUS:.0%}, open")
    if ambiguous >= config.AUTO_HOLES_MIN_AMBIGUOUS and width >= config.AUTO_UDF_WIDTH_WITH_HOLES:
        return FieldChoice("udf", f"{measured}: encloses an inside but has holes, which an SDF would cap; "
                                  f"at width {width} (>= {config.AUTO_UDF_WIDTH_WITH_HOLES}) a UDF measures better")
    return FieldChoice("sdf", f"{measured}: at most {config.AUTO_SDF_MAX_AMBIGUOUS:.0%}, encloses an inside")


def epoch_counts(scale: float) -> tuple[int, int, int]:
    """(uniform, surface, near) sample counts of `scale` epochs: the paper's 20% / 40% / 40%."""
    surface = int(round(config.SURFACE_POINTS_PER_EPOCH * scale))
    return int(round(surface * config.UNIFORM_PER_SURFACE)), surface, int(round(surface * config.NEAR_PER_SURFACE))


def _samples(
    sampler: SurfaceSampler, field: str, counts: tuple[int, int, int], rng: np.random.Generator, sided: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Points, distances, and with `sided` (a UDF of an oriented mesh) their sides."""
    n_uniform, n_surface, n_near = counts
    uniform = rng.uniform(-1.0, 1.0, (n_uniform, 3))
    surface = sampler.surface_points(n_surface, rng)
    near = sampler.near_points(n_near, config.NEAR_SURFACE_SIGMA[field], rng)
    off_surface = np.concatenate([uniform, near])
    if sided:
        queried, side = sampler.unsigned_distances_and_sides(off_surface)
    else:
        queried, side = sampler.distances(off_surface, signed=field == "sdf"), None
    points = np.concatenate([uniform, surface, near]).astype(np.float32)
    distances = np.concatenate([queried[:n_uniform], np.zeros(n_surface), queried[n_uniform:]]).astype(np.float32)
    # On the surface itself the side does not matter.
    sides = None if side is None else np.concatenate([side[:n_uniform], np.ones(n_surface, np.float32), side[n_uniform:]])
    return points, distances, sides


def build_pool(
    sampler: SurfaceSampler, field: str, rng: np.random.Generator, pool_epochs: float = config.POOL_EPOCHS
) -> DistancePool:
    """Sample and compute the ground truth once: `pool_epochs` epochs of training data + validation."""
    if field not in ("sdf", "udf") or (field == "sdf" and not sampler.is_mesh):
        raise ValueError(f"cannot build a {field!r} pool for this input")
    counts = epoch_counts(pool_epochs)
    sided, note = _orient_for_sides(sampler) if field == "udf" else (False, "")
    points, distances, sides = _samples(sampler, field, counts, rng, sided)
    validation_points, validation_distances, _ = _samples(sampler, field, epoch_counts(config.VALIDATION_FRACTION), rng)
    return DistancePool(points, distances, counts, validation_points, validation_distances, sides, note)


def _orient_for_sides(sampler: SurfaceSampler) -> tuple[bool, str]:
    """Whether a UDF pool of this input takes sides (DistancePool.sides; a mesh's faces reoriented
    first where they disagree, a cloud's normals estimated), and what was done, for the log."""
    if sampler.faces is None:
        flat, edge, agreement = sampler.orient_cloud_normals()
        if flat < config.CLOUD_MIN_FLAT_SHARE:
            return False, f"no signed start: the cloud is no surface ({flat:.0%} of its points lie flat)"
        if edge > config.CLOUD_MAX_EDGE_SHARE:
            return False, (f"no signed start: the cloud is open like a single-view scan "
                           f"({edge:.2%} of its points on an edge)")
        if agreement < config.UDF_SIGNED_MIN_ORIENTED:
            return False, f"no signed start: the cloud's normals do not agree ({agreement:.0%} of neighbours)"
        return True, f"signed start from the cloud's oriented normals ({agreement:.1%} of neighbours agree)"
    share = oriented_share(sampler.faces)
    if share >= config.UDF_SIGNED_MIN_ORIENTED:
        return True, "signed start from the faces' orientation"
    sampler.orient_consistently()
    if oriented_share(sampler.faces) < config.UDF_SIGNED_MIN_ORIENTED:
        return False, f"no signed start: the faces have no orientation ({share:.0%} of shared edges agree)"
    return True, f"signed start from the faces reoriented by patch ({share:.0%} of shared edges agreed)"


def draw_epoch(pool: DistancePool, rng: np.random.Generator) -> np.ndarray:
    """Shuffled pool indices of one epoch: the 20/40/40 mix, each kind drawn with replacement."""
    offsets = np.cumsum((0,) + pool.counts[:-1])
    parts = [off + rng.integers(0, n, want) for off, n, want in zip(offsets, pool.counts, epoch_counts(1.0))]
    return rng.permutation(np.concatenate(parts))
