#!/usr/bin/env python3
"""Progressive decode benchmark: nfc-decode --levels against the one-shot decode, per device.

Per file and device, medians over --runs interleaved runs of:
  * the wall time to each ladder level from the moment the .nfc bytes are given to the library
    (the context created before, as an engine's would be: --stats=json's elapsed_ms);
  * the full progressive decode (every level meshed) against the same decode meshing only the
    final level (--levels R: the one-shot's work through the same steps) in process CPU time,
    which a busy machine does not inflate, and in wall time;
  * the one-shot nfd_mesh_extract (parse + field + mesh of --stats) in wall time;
  * the same two ratios run by run (each run's ladder over the final-only and one-shot runs made
    right after it), as median [first quartile, third quartile]: on a shared 2-core machine the
    decode times drift by 20% within minutes, and paired ratios cancel most of that drift.

With --core K every run is pinned to CPU core K (all its threads on that core: the work without
the second core's share of the parallel loops, or its noise): the CPU ratio of the ladder's own cost.

With --bandwidth R (e.g. 256KB/s) the progressive runs feed the file through nfd_stream in
--stream-chunk pieces paced at R (nfc-decode --stream-chunk --bandwidth): the times then count from
the first byte fed, and two more columns give when the geometry chunk had arrived and the first
level's time after it.

    python3 bench/progressive.py bench/out/nfc/bunny_fast_w32.nfc --levels 32,64,128,256
    python3 bench/progressive.py bench/out/nfc/bunny_fast_w32.nfc --bandwidth 256KB/s
    python3 bench/progressive.py bench/out/nfc/bunny_fast_w32.nfc --devices cpu --core 1 --runs 7
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def decode(args: list[str], cores: set[int] | None) -> str:
    """nfc-decode's stdout, pinned to `cores` if given."""
    pin = (lambda: os.sched_setaffinity(0, cores)) if cores else None
    return subprocess.run([str(NFC_DECODE), *args], check=True, capture_output=True, text=True,
                          preexec_fn=pin).stdout


def progressive(path: Path, levels: str, device: str, feed: list[str],
                cores: set[int] | None) -> tuple[dict[int, float], dict]:
    with tempfile.TemporaryDirectory() as tmp:
        out = decode([str(path), "-o", f"{tmp}/out.ply", "--levels", levels, "--device", device,
                      "--stats=json", *feed], cores)
    objects = [json.loads(line) for line in out.splitlines()]
    return {o["resolution"]: o["elapsed_ms"] for o in objects[:-1]}, objects[-1]


def one_shot(path: Path, resolution: int, device: str, cores: set[int] | None) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        out = decode([str(path), "-o", f"{tmp}/out.ply", "--resolution", str(resolution),
                      "--device", device, "--stats"], cores)
    ms = {m[1]: float(m[2]) for m in re.finditer(r"^(parse|field|mesh)\s+([0-9.]+) ms", out, re.M)}
    return ms["parse"] + ms["field"] + ms["mesh"]


def spread(ratios: list[float]) -> str:
    """Median [first quartile, third quartile] of per-run ratios."""
    if len(ratios) < 2:
        return f"{ratios[0]:.3f}"
    q1, q2, q3 = statistics.quantiles(ratios, n=4, method="inclusive")
    return f"{q2:.3f} [{q1:.3f}, {q3:.3f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--levels", default="32,64,128,256")
    ap.add_argument("--devices", nargs="+", default=["vulkan", "cpu"])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--bandwidth", help="stream the progressive runs at this rate, e.g. 256KB/s")
    ap.add_argument("--stream-chunk", type=int, default=1024, help="bytes per piece with --bandwidth")
    ap.add_argument("--core", type=int, help="pin every run to this CPU core")
    args = ap.parse_args()
    cores = {args.core} if args.core is not None else None
    feed = ["--stream-chunk", str(args.stream_chunk), "--bandwidth", args.bandwidth] if args.bandwidth else []
    levels = [int(r) for r in args.levels.split(",")]
    final = str(levels[-1])
    print("| file | device | " + " | ".join(f"to {r} ms" for r in levels) +
          " | extraction create ms | CPU ms: all levels / final only | wall ms: all levels /"
          " final only / one-shot | paired CPU ratio | paired wall ratio |" +
          (" geometry arrived ms | first level after it ms |" if feed else ""))
    print("|" + "---|" * (len(levels) + 7 + (2 if feed else 0)))
    med = statistics.median
    for path in args.files:
        for device in args.devices:
            full, last, shots = [], [], []
            for _ in range(args.runs):
                full.append(progressive(path, args.levels, device, feed, cores))
                last.append(progressive(path, final, device, feed, cores)[1])
                shots.append(one_shot(path, levels[-1], device, cores))
            to = [med(r[0][res] for r in full) for res in levels]
            create = med(r[1]["prepare_ms"] for r in full)
            cpu_full, cpu_last = med(r[1]["cpu_ms"] for r in full), med(r["cpu_ms"] for r in last)
            wall_last, shot = med(r["elapsed_ms"] for r in last), med(shots)
            print(f"| {path.name} | {device} | " + " | ".join(f"{t:.1f}" for t in to) +
                  f" | {create:.1f} | {cpu_full:.0f} / {cpu_last:.0f} = {cpu_full / cpu_last:.3f}"
                  f" | {to[-1]:.0f} / {wall_last:.0f} / {shot:.0f} = {to[-1] / shot:.3f}"
                  f" | {spread([f[1]['cpu_ms'] / l['cpu_ms'] for f, l in zip(full, last)])}"
                  f" | {spread([f[0][levels[-1]] / s for f, s in zip(full, shots)])} |" +
                  (f" {med(r[1]['geometry_ms'] for r in full):.1f} |"
                   f" {med(r[0][levels[0]] - r[1]['geometry_ms'] for r in full):.1f} |" if feed else ""))


if __name__ == "__main__":
    main()
