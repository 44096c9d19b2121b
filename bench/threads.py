#!/usr/bin/env python3
"""How the CPU path scales with threads: `nfc-decode --device cpu --threads T` per file, resolution
and thread count, medians over --runs interleaved runs of the field and mesh stages (--stats), the
process's wall time and its CPU time (user + system, from the kernel's accounting of the child).

Prints one markdown table; "field speed-up" is the field stage's time at the first thread count
over its time at each count. A speed-up well under the thread count says how much of the stage
runs on one thread (bench/RESULTS.md, "What the second core gives the CPU path").

    .venv/bin/python bench/threads.py bench/out/keep/bunny_w32.nfc --resolutions 256 512 --threads 1 2
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def decode(path: Path, resolution: int, threads: int, out: str) -> dict[str, float]:
    """One run: {field, mesh} ms from --stats, the process's wall and CPU seconds."""
    before = os.times()
    t0 = time.perf_counter()
    text = subprocess.run([str(NFC_DECODE), str(path), "-o", out, "--device", "cpu", "--resolution",
                           str(resolution), "--threads", str(threads), "--stats"],
                          check=True, capture_output=True, text=True).stdout
    wall = time.perf_counter() - t0
    after = os.times()
    run = {m[1]: float(m[2]) for m in re.finditer(r"^(field|mesh)\s+([0-9.]+) ms", text, re.M)}
    run["wall"] = wall
    run["cpu"] = (after.children_user - before.children_user) + (after.children_system -
                                                                 before.children_system)
    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--resolutions", nargs="+", type=int, default=[256, 512])
    parser.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    if not NFC_DECODE.exists():
        raise SystemExit(f"{NFC_DECODE} is missing: build the C++ tree first (scripts/setup.sh)")
    print("| file | res | threads | field ms | mesh ms | process wall s | process CPU s | field speed-up |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        out = f"{tmp}/out.ply"
        for path in args.files:
            for resolution in args.resolutions:
                runs: dict[int, list[dict[str, float]]] = {t: [] for t in args.threads}
                for _ in range(args.runs):
                    for t in args.threads:
                        runs[t].append(decode(path, resolution, t, out))
                median = {t: {k: statistics.median(r[k] for r in runs[t]) for k in runs[t][0]}
                          for t in args.threads}
                first = median[args.threads[0]]["field"]
                for t in args.threads:
                    m = median[t]
                    print(f"| {path.name} | {resolution} | {t} | {m['field']:.1f} | {m['mesh']:.1f} | "
                          f"{m['wall']:.3f} | {m['cpu']:.3f} | {first / m['field']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
