#!/usr/bin/env python3
"""How the CPU path scales with threads: `nfc-decode --device cpu --threads T` per file, resolution
and thread count, medians over --runs interleaved runs of the field and mesh stages (--stats), the
process's wall time and its CPU time (user + system, from the kernel's accounting of the child).

Prints one markdown table; "field speed-up" is the field stage's time at the first thread count
over its time at each count. A speed-up well under the thread count says how much of the stage
runs on one thread (bench/RESULTS.md, "What the second core gives the CPU path").

    .venv/bin/python bench/threads.py bench/out/keep/bunny_w32.nfc --resolutions 256 512 --threads 1 2

`--decoders A B` compares builds (e.g. a worktree of an older commit), their runs interleaved with
each other's; "field speed-up" is then against the first decoder at the first thread count.
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


def decode(decoder: Path, path: Path, resolution: int, threads: int, out: str) -> dict[str, float]:
    """One run: {field, mesh} ms from --stats, the process's wall and CPU seconds."""
    before = os.times()
    t0 = time.perf_counter()
    text = subprocess.run([str(decoder), str(path), "-o", out, "--device", "cpu", "--resolution",
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
    parser.add_argument("--decoders", nargs="+", type=Path, default=[NFC_DECODE],
                        help="nfc-decode executables to compare (default: this tree's build)")
    args = parser.parse_args()
    for decoder in args.decoders:
        if not decoder.exists():
            raise SystemExit(f"{decoder} is missing: build the C++ tree first (scripts/setup.sh)")
    several = len(args.decoders) > 1
    print(("| decoder " if several else "") +
          "| file | res | threads | field ms | mesh ms | process wall s | process CPU s | field speed-up |")
    print(("|---" if several else "") + "|---|---:|---:|---:|---:|---:|---:|---:|")
    settings = [(d, t) for d in args.decoders for t in args.threads]
    with tempfile.TemporaryDirectory() as tmp:
        out = f"{tmp}/out.ply"
        for path in args.files:
            for resolution in args.resolutions:
                runs: dict[tuple[Path, int], list[dict[str, float]]] = {s: [] for s in settings}
                for _ in range(args.runs):
                    for decoder, t in settings:
                        runs[decoder, t].append(decode(decoder, path, resolution, t, out))
                median = {s: {k: statistics.median(r[k] for r in runs[s]) for k in runs[s][0]}
                          for s in settings}
                first = median[settings[0]]["field"]
                for decoder, t in settings:
                    m = median[decoder, t]
                    print((f"| {decoder} " if several else "") +
                          f"| {path.name} | {resolution} | {t} | {m['field']:.1f} | {m['mesh']:.1f} | "
                          f"{m['wall']:.3f} | {m['cpu']:.3f} | {first / m['field']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
