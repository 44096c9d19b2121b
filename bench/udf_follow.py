#!/usr/bin/env python3
"""UDF surface following against the band (issue 6 decode time and memory; issue 11, item 2).

For each UDF file and resolution, `nfc-decode --device cpu` twice: the default schedule (the UDF
levels follow the surface, 0.12) and `--sample-band` (the keep rule's band, every UDF decode
before 0.12). Prints a markdown table: field points and gradient points of each, whether the two
meshes hold the same triangles (vertex positions compared after sorting the triangles, so the
order of the cells does not matter), and the median wall and CPU milliseconds and peak RSS of
`runs` interleaved decodes (`--stats=json`'s elapsed_ms and cpu_ms; /usr/bin/time's maximum
resident set).

    .venv/bin/python bench/udf_follow.py bench/out/keep/bunny-udf_w32.nfc tests/vectors/*udf*.nfc \
        --resolutions 256 512 --runs 3
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
DECODER = ROOT / "build" / "samples" / "nfc-decode"


@dataclass
class Decode:
    points: int
    gradients: int
    elapsed_ms: float
    cpu_ms: float
    peak_mb: float


def decode(path: Path, resolution: int, band: bool, out: Path) -> Decode:
    """One decode to `out` (.ply), with its counts, times and peak memory."""
    command = ["/usr/bin/time", "-f", "peak_kb %M", str(DECODER), str(path), "-o", str(out),
               "--device", "cpu", "--levels", str(resolution), "--stats=json"]
    result = subprocess.run(command + (["--sample-band"] if band else []), capture_output=True,
                            text=True, check=True)
    lines = (result.stdout + result.stderr).splitlines()
    summary = next(json.loads(line) for line in lines if line.startswith('{"summary"'))
    peak_kb = next(int(line.split()[1]) for line in lines if line.startswith("peak_kb"))
    return Decode(summary["points_evaluated"], summary["gradients_evaluated"],
                  summary["elapsed_ms"], summary["cpu_ms"], peak_kb / 1024)


def triangles(path: Path) -> np.ndarray:
    """The mesh's triangles as rows of nine coordinates, sorted."""
    mesh = trimesh.load(path, process=False)
    rows = mesh.vertices[mesh.faces].reshape(len(mesh.faces), 9)
    return rows[np.lexsort(rows.T[::-1])]


def median(decodes: list[Decode], field: str) -> float:
    return statistics.median(getattr(d, field) for d in decodes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", type=Path, help="UDF .nfc files")
    parser.add_argument("--resolutions", nargs="+", type=int, default=[256, 512])
    parser.add_argument("--runs", type=int, default=3, help="decodes of each schedule, interleaved")
    args = parser.parse_args()
    print("| file | res | points: band → follow | ratio | gradients | same triangles | wall ms: "
          "band → follow | CPU ms: band → follow | peak MB: band → follow |")
    print("|---|---:|---:|---:|---:|---|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        band_ply, follow_ply = Path(tmp) / "band.ply", Path(tmp) / "follow.ply"
        for path in args.files:
            for resolution in args.resolutions:
                runs: dict[bool, list[Decode]] = {True: [], False: []}
                for _ in range(args.runs):
                    for band in (True, False):
                        out = band_ply if band else follow_ply
                        runs[band].append(decode(path, resolution, band, out))
                band, follow = runs[True], runs[False]
                same = np.array_equal(triangles(band_ply), triangles(follow_ply))
                print(f"| {path.name} | {resolution} | {band[0].points} → {follow[0].points} | "
                      f"{follow[0].points / band[0].points:.2f} | {follow[0].gradients} | "
                      f"{'yes' if same else 'NO'} | "
                      f"{median(band, 'elapsed_ms'):.0f} → {median(follow, 'elapsed_ms'):.0f} | "
                      f"{median(band, 'cpu_ms'):.0f} → {median(follow, 'cpu_ms'):.0f} | "
                      f"{median(band, 'peak_mb'):.0f} → {median(follow, 'peak_mb'):.0f} |",
                      flush=True)


if __name__ == "__main__":
    main()
