#!/usr/bin/env python3
"""Rate control (issue 10, item 5): `nfc encode --target-bytes B` on real shapes, for budgets from
800 to 20,000 bytes. Prints per shape and budget the file's bytes (which must never exceed B), the
width and bits chosen, the encodes it took and the time (fast preset, seed 0, geometry only).

    .venv/bin/python bench/rate_control.py --shapes bunny armadillo --budgets 800 1500 3000 6000 12000 20000
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
SHAPES = {
    "bunny": "stanford/bun_zipper.ply.gz",
    "armadillo": "stanford/armadillo_remeshed_odedstein.obj.gz",
    "tshirt": "garments/TShirtNoCoat.obj.gz",
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="+", default=["bunny", "armadillo"], choices=sorted(SHAPES))
    ap.add_argument("--budgets", nargs="+", type=int, default=[800, 1500, 3000, 6000, 12000, 20000])
    args = ap.parse_args()
    print("| shape | target B | bytes | used | width | bits | encodes | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.shapes:
            for budget in args.budgets:
                out = Path(tmp) / f"{name}_{budget}.nfc"
                start = time.perf_counter()
                run = subprocess.run([sys.executable, "-m", "nfencode.cli", "encode", str(DATA / SHAPES[name]),
                                      "-o", str(out), "--target-bytes", str(budget), "--quiet", "--json",
                                      "--no-color"], capture_output=True, text=True)
                seconds = time.perf_counter() - start
                if run.returncode != 0:
                    print(f"| {name} | {budget} | error: {run.stderr.strip()} | | | | | |", flush=True)
                    continue
                r = json.loads(run.stdout.strip().splitlines()[-1])
                assert r["bytes"] == out.stat().st_size
                worst = max(worst, r["bytes"] / budget)
                print(f"| {name} | {budget} | {r['bytes']} | {100 * r['bytes'] / budget:.1f}% | {r['width']} | "
                      f"{r['bits']} | {len(r['attempts'])} | {seconds:.0f} |", flush=True)
    print(f"\nlargest bytes / target: {worst:.4f} (must be <= 1)")


if __name__ == "__main__":
    main()
