"""The marching-cubes table of the numpy reference: libnfdecode's generated table, entry for entry,
and the properties that make its meshes watertight."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nfencode.mc_tables import CORNER_OFFSET, EDGE_AXIS, EDGE_CORNERS, TRIANGLE_COUNT, TRIANGLES
from nfencode.reference import extract_mesh_from_field

SOURCES = Path(__file__).resolve().parents[2] / "libnfdecode" / "src"
DUMP_PROGRAM = """
#include <cstdio>
#include "mc_tables.h"
int main() {
    const nfd::mc::Tables& t = nfd::mc::tables();
    for (int c = 0; c < 256; ++c) {
        std::printf("%d", int(t.triangle_count[c]));
        for (int k = 0; k < 16; ++k) std::printf(" %d", int(t.triangles[c][k]));
        std::printf("\\n");
    }
}
"""


@pytest.mark.skipif(shutil.which("c++") is None, reason="no C++ compiler")
def test_table_is_the_cpp_table(tmp_path: Path) -> None:
    (tmp_path / "dump.cpp").write_text(DUMP_PROGRAM)
    subprocess.run(["c++", "-std=c++17", f"-I{SOURCES}", "dump.cpp", str(SOURCES / "mc_tables.cpp"), "-o", "dump"],
                   cwd=tmp_path, check=True)
    dump = subprocess.run([tmp_path / "dump"], capture_output=True, text=True, check=True).stdout
    rows = np.loadtxt(dump.splitlines(), dtype=np.int64)
    np.testing.assert_array_equal(rows[:, 0], TRIANGLE_COUNT)
    np.testing.assert_array_equal(rows[:, 1:16], TRIANGLES)
    assert (rows[:, 16] == -1).all()


def test_numbering_is_mc_tables_h() -> None:
    np.testing.assert_array_equal(CORNER_OFFSET[5], [1, 0, 1])  # corner c at (c & 1, c >> 1 & 1, c >> 2 & 1)
    for e, (a, b) in enumerate(EDGE_CORNERS):
        step = CORNER_OFFSET[b] - CORNER_OFFSET[a]
        assert step[EDGE_AXIS[e]] == 1 and step.sum() == 1  # from the lower corner along the axis
    others = [np.delete(CORNER_OFFSET[EDGE_CORNERS[e, 0]], EDGE_AXIS[e]) for e in range(12)]
    assert [int(o[0] + 2 * o[1]) for o in others] == [e % 4 for e in range(12)]


@pytest.mark.parametrize("case", range(256))
def test_every_case_uses_exactly_its_crossing_edges(case: int) -> None:
    inside = np.array([case >> c & 1 for c in range(8)], dtype=bool)
    crossing = {e for e, (a, b) in enumerate(EDGE_CORNERS) if inside[a] != inside[b]}
    n = TRIANGLE_COUNT[case]
    used = TRIANGLES[case, : 3 * n]
    assert set(used.tolist()) == crossing
    assert (TRIANGLES[case, 3 * n :] == -1).all()
    triangles = used.reshape(-1, 3)
    assert (triangles[:, 0] != triangles[:, 1]).all() and (triangles[:, 1] != triangles[:, 2]).all()
    # Counter-clockwise seen from outside: the normal of each triangle (vertices at the edge
    # midpoints) points from the inside ends of its edges to the outside ends.
    midpoint = (CORNER_OFFSET[EDGE_CORNERS[:, 0]] + CORNER_OFFSET[EDGE_CORNERS[:, 1]]) / 2.0
    for t in triangles:
        normal = np.cross(midpoint[t[1]] - midpoint[t[0]], midpoint[t[2]] - midpoint[t[0]])
        a, b = EDGE_CORNERS[t, 0], EDGE_CORNERS[t, 1]
        outward = np.where(inside[a][:, None], CORNER_OFFSET[b] - CORNER_OFFSET[a], CORNER_OFFSET[a] - CORNER_OFFSET[b])
        assert (outward @ normal).sum() > 0


@pytest.mark.parametrize("seed", range(6))
def test_random_labels_give_closed_consistently_wound_surfaces(seed: int) -> None:
    """Random inside/outside labels on a dense grid (resolution 24 < 32: a single level visited
    whole), outside on the domain boundary: every edge of the mesh is shared by exactly two triangles
    running it in opposite directions, whatever the ambiguous faces and cubes."""
    resolution = 24
    rng = np.random.default_rng(seed)
    magnitude = rng.uniform(0.1, 1.0, (resolution + 1,) * 3)
    sign = np.where(rng.random((resolution + 1,) * 3) < [0.3, 0.5, 0.7][seed % 3], -1.0, 1.0)
    sign[[0, -1], :, :] = sign[:, [0, -1], :] = sign[:, :, [0, -1]] = 1.0
    values = sign * magnitude

    def field(points: np.ndarray) -> np.ndarray:
        i = np.rint((points.astype(np.float64) + 1.0) * resolution / 2).astype(np.int64)
        return values[i[:, 0], i[:, 1], i[:, 2]]

    mesh = extract_mesh_from_field(field, resolution)
    faces = mesh.faces
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)  # no directed edge twice
    reverse = {tuple(e) for e in directed[:, ::-1].tolist()}
    assert {tuple(e) for e in directed.tolist()} == reverse  # each edge run both ways
    # One vertex per crossed grid edge, each used.
    crossed = sum(int(np.sum(np.diff(np.signbit(values), axis=a) != 0)) for a in range(3))
    assert len(mesh.vertices) == crossed == len(np.unique(faces))
