#!/usr/bin/env python3
"""Rate control (issue 10, item 5): `nfc encode --target-bytes B` on real shapes, for budgets from
800 to 20,000 bytes. Prints per shape and budget the file's bytes (which must never exceed B), the
width and bits chosen, the encodes it took and the time (fast preset, seed 0, geometry only).
With --target-cds, `nfc encode --target-cd C` instead: per shape and target the encoder's estimate
of the written file's CD, the CD of libnfdecode's decode of it (nfc-decode at 256 on the CPU path,
then `nfc eval`, seed 0), bytes, width, encodes and time.

    .venv/bin/python bench/rate_control.py --shapes bunny armadillo --budgets 800 1500 3000 6000 12000 20000
    .venv/bin/python bench/rate_control.py --shapes bunny armadillo --target-cds 0.012 0.01 0.009
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


NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def decoded_cd(shape: Path, nfc: Path) -> float:
    """CD of libnfdecode's mesh of `nfc` (resolution 256, CPU path) to the shape, by `nfc eval`."""
    mesh = nfc.with_suffix(".ply")
    subprocess.run([str(NFC_DECODE), str(nfc), "-o", str(mesh), "--resolution", "256", "--device", "cpu"],
                   check=True, capture_output=True)
    run = subprocess.run([sys.executable, "-m", "nfencode.cli", "eval", str(shape), str(mesh), "--json"],
                         check=True, capture_output=True, text=True)
    return float(json.loads(run.stdout)["chamfer_distance"])


def encode_to(name: str, out: Path, target: list[str]) -> tuple[dict | str, float]:
    """`nfc encode` of shape `name` into `out` with a target option (fast preset, seed 0, geometry
    only): its --json report, or its error message, and the seconds it took."""
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "nfencode.cli", "encode", str(DATA / SHAPES[name]), "-o",
                          str(out), *target, "--quiet", "--json", "--no-color"],
                         capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        return run.stderr.strip(), seconds
    return json.loads(run.stdout.strip().splitlines()[-1]), seconds


def distortion_targets(shapes: list[str], targets: list[float]) -> None:
    print("| shape | target CD | estimated CD | nfc-decode CD | bytes | width | encodes | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for name in shapes:
            for target in targets:
                out = Path(tmp) / f"{name}_{target}.nfc"
                r, seconds = encode_to(name, out, ["--target-cd", str(target)])
                if isinstance(r, str):
                    print(f"| {name} | {target} | error: {r} | | | | | |", flush=True)
                    continue
                measured = decoded_cd(DATA / SHAPES[name], out)
                worst = max(worst, measured / target)
                tried = ", ".join(f"w{a['width']} {a['cd']:.5f}" for a in r["attempts"])
                print(f"| {name} | {target} | {r['estimated_cd']:.6f} | {measured:.6f} | {r['bytes']} | "
                      f"{r['width']} | {len(r['attempts'])} ({tried}) | {seconds:.0f} |", flush=True)
    print(f"\nlargest nfc-decode CD / target: {worst:.4f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="+", default=["bunny", "armadillo"], choices=sorted(SHAPES))
    ap.add_argument("--budgets", nargs="+", type=int, default=[800, 1500, 3000, 6000, 12000, 20000])
    ap.add_argument("--target-cds", nargs="+", type=float, default=None,
                    help="run --target-cd with these targets instead of the byte budgets")
    args = ap.parse_args()
    if args.target_cds:
        distortion_targets(args.shapes, args.target_cds)
        return
    print("| shape | target B | bytes | used | width | bits | encodes | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.shapes:
            for budget in args.budgets:
                out = Path(tmp) / f"{name}_{budget}.nfc"
                r, seconds = encode_to(name, out, ["--target-bytes", str(budget)])
                if isinstance(r, str):
                    print(f"| {name} | {budget} | error: {r} | | | | | |", flush=True)
                    continue
                assert r["bytes"] == out.stat().st_size
                worst = max(worst, r["bytes"] / budget)
                print(f"| {name} | {budget} | {r['bytes']} | {100 * r['bytes'] / budget:.1f}% | {r['width']} | "
                      f"{r['bits']} | {len(r['attempts'])} | {seconds:.0f} |", flush=True)
    print(f"\nlargest bytes / target: {worst:.4f} (must be <= 1)")


if __name__ == "__main__":
    main()
