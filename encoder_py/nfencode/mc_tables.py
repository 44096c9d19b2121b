"""Marching-cubes tables, generated exactly as libnfdecode/src/mc_tables.cpp generates them.

Numbering (libnfdecode/src/mc_tables.h):
  corner c (0..7) sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) from the cell origin;
  edge e (0..11) runs along axis e // 4 from corner EDGE_CORNERS[e][0] (the lower one along that
    axis) to EDGE_CORNERS[e][1];
  case index: bit c is set when corner c is inside.

The triangle table is traced, not typed in: each cube face is walked counter-clockwise seen from
outside, every exit from the inside region is joined to the entry that closes it (ambiguous faces
separate their inside corners, whichever cube looks at them), the segments chain into loops, and
each loop is triangulated without chords along a cube face (which a neighbour could also draw),
then reversed so that triangles are counter-clockwise seen from outside.
"""

from __future__ import annotations

import numpy as np

CORNER_OFFSET = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)], dtype=np.int64)

EDGE_CORNERS = np.array(
    [
        [0, 1], [2, 3], [4, 5], [6, 7],  # along x: (y, z) = (0,0) (1,0) (0,1) (1,1)
        [0, 2], [1, 3], [4, 6], [5, 7],  # along y: (x, z) = (0,0) (1,0) (0,1) (1,1)
        [0, 4], [1, 5], [2, 6], [3, 7],  # along z: (x, y) = (0,0) (1,0) (0,1) (1,1)
    ],
    dtype=np.int64,
)
EDGE_AXIS = np.arange(12, dtype=np.int64) // 4

MAX_TRIANGLES_PER_CASE = 5


def _edge_between(c0: int, c1: int) -> int:
    for e, (a, b) in enumerate(EDGE_CORNERS.tolist()):
        if {a, b} == {c0, c1}:
            return e
    raise ValueError(f"corners {c0} and {c1} do not share a cube edge")


def _faces() -> list[list[int]]:
    """The four corners of each cube face, counter-clockwise seen from outside the cube."""
    faces = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3  # e_u x e_v = e_axis
        for side in (0, 1):
            ring = []
            for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):  # counter-clockwise seen from +e_axis
                xyz = [0, 0, 0]
                xyz[axis], xyz[u], xyz[v] = side, du, dv
                ring.append(xyz[0] | xyz[1] << 1 | xyz[2] << 2)
            faces.append(ring if side else ring[::-1])  # seen from -e_axis the cycle reverses
    return faces


def _share_face(a: int, b: int) -> bool:
    """Whether cube edges a and b lie on a common face: they share a corner, or are parallel and
    differ in exactly one of the two other coordinates."""
    if a // 4 == b // 4:
        return bin((a % 4) ^ (b % 4)).count("1") == 1
    return bool(set(EDGE_CORNERS[a].tolist()) & set(EDGE_CORNERS[b].tolist()))


def _triangulate(loop: list[int], i: int, j: int) -> list[tuple[int, int, int]] | None:
    """Triangles of loop[i..j] whose chords avoid cube faces (None if there is no such
    triangulation); the first candidate apex in loop order wins, as in mc_tables.cpp."""
    if j - i < 2:
        return []
    for k in range(i + 1, j):
        if k != i + 1 and _share_face(loop[i], loop[k]):
            continue
        if k != j - 1 and _share_face(loop[k], loop[j]):
            continue
        left = _triangulate(loop, i, k)
        right = None if left is None else _triangulate(loop, k, j)
        if left is not None and right is not None:
            return [(loop[i], loop[k], loop[j])] + left + right
    return None


def _case_triangles(index: int, faces: list[list[int]]) -> list[tuple[int, int, int]]:
    def inside(c: int) -> bool:
        return bool(index >> c & 1)

    following = [-1] * 12  # following[exit edge] = the entry edge that closes its segment
    for q in faces:
        for k in range(4):
            prev, here = q[(k + 3) % 4], q[k]
            if not inside(here) or inside(prev):
                continue  # only the first corner of each run of inside corners
            last = k
            while inside(q[(last + 1) % 4]):
                last = (last + 1) % 4
            following[_edge_between(q[last], q[(last + 1) % 4])] = _edge_between(prev, here)

    triangles: list[tuple[int, int, int]] = []
    visited = [False] * 12
    for start in range(12):
        if following[start] < 0 or visited[start]:
            continue
        loop = []
        e = start
        while not visited[e]:
            if following[e] < 0:
                raise ValueError(f"case {index}: open iso-contour loop")
            visited[e] = True
            loop.append(e)
            e = following[e]
        fan = _triangulate(loop, 0, len(loop) - 1)
        if fan is None:
            raise ValueError(f"case {index}: no triangulation without face diagonals")
        # The loop runs counter-clockwise around the inside seen from outside: reverse each triangle.
        triangles += [(a, c, b) for a, b, c in fan]
    if len(triangles) > MAX_TRIANGLES_PER_CASE:
        raise ValueError(f"case {index}: {len(triangles)} triangles")
    return triangles


def generate() -> tuple[np.ndarray, np.ndarray]:
    """(triangles, triangle_count): triangles[case] holds 3 * triangle_count[case] edge ids, then -1
    up to 15 entries."""
    faces = _faces()
    table = np.full((256, 3 * MAX_TRIANGLES_PER_CASE), -1, dtype=np.int64)
    count = np.zeros(256, dtype=np.int64)
    for index in range(256):
        edges = [e for triangle in _case_triangles(index, faces) for e in triangle]
        table[index, : len(edges)] = edges
        count[index] = len(edges) // 3
    return table, count


TRIANGLES, TRIANGLE_COUNT = generate()


def holds_triangle(triangles: np.ndarray, triangle_count: np.ndarray) -> np.ndarray:
    """(4096,) bool over 12-bit edge masks: whether the edges in the mask include all three edges of
    some triangle of the table (mc_tables.h, Tables::holds_triangle)."""
    masks = np.arange(4096, dtype=np.int64)
    holds = np.zeros(4096, dtype=bool)
    for index in range(256):
        for edges in triangles[index, : 3 * triangle_count[index]].reshape(-1, 3):
            triangle = int((1 << edges).sum())
            holds |= (masks & triangle) == triangle
    return holds


HOLDS_TRIANGLE = holds_triangle(TRIANGLES, TRIANGLE_COUNT)
