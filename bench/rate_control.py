#!/usr/bin/env python3
"""Rate control (issue 10, item 5): `nfc encode --target-bytes B` on real shapes, for budgets from
800 to 20,000 bytes. Prints per shape and budget the file's bytes (which must never exceed B), the
width and bits chosen, the encodes it took and the time (fast preset, seed 0, geometry only).
With --target-cds, `nfc encode --target-cd C` instead: per shape and target the encoder's estimate
of the written file's CD, the CD of libnfdecode's decode of it (nfc-decode at 256 on the CPU path,
then `nfc eval`, seed 0), bytes, width, encodes and time.

    .venv/bin/python bench/rate_control.py --shapes bunny armadillo --budgets 800 1500 3000 6000 12000 20000
    .venv/bin/python bench/rate_control.py --shapes bunny armadillo --target-cds 0.012 0.01 0.009

With --color the shapes keep their colours and B bounds the whole file (geometry share, then the
widest colour network that fits): per shape and budget the bytes, both networks' widths and bits,
the encodes, and the colour PSNR and CD (metrics.md) of libnfdecode's decode to as many points as
the input has (nfc-decode --points N at 256 on the CPU path, then `nfc eval`).

    .venv/bin/python bench/rate_control.py --color --shapes loot --budgets 2000 5000 8000 12000 16000
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
    "loot": "colored/loot_vox10_1200.ply.gz",
    "egyptian_mask": "colored/egyptian_mask_vox10.ply.gz",
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


def decoded_points_quality(shape: Path, nfc: Path) -> tuple[float, float]:
    """(colour PSNR, CD) of libnfdecode's decode of `nfc` to as many points as `shape` has
    (resolution 256, CPU path), by `nfc eval`."""
    from nfencode.io import load_shape

    points = nfc.with_suffix(".ply")
    subprocess.run([str(NFC_DECODE), str(nfc), "-o", str(points), "--points", str(len(load_shape(shape).vertices)),
                    "--resolution", "256", "--device", "cpu"], check=True, capture_output=True)
    run = subprocess.run([sys.executable, "-m", "nfencode.cli", "eval", str(shape), str(points), "--json"],
                         check=True, capture_output=True, text=True)
    report = json.loads(run.stdout)
    return float(report["color_psnr"]), float(report["chamfer_distance"])


def encode_to(name: str, out: Path, target: list[str], color: bool = False) -> tuple[dict | str, float]:
    """`nfc encode` of shape `name` into `out` with a target option (fast preset, seed 0; geometry
    only unless `color`): its --json report, or its error message, and the seconds it took."""
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "nfencode.cli", "encode", str(DATA / SHAPES[name]), "-o",
                          str(out), *target, "--quiet", "--json", *([] if color else ["--no-color"])],
                         capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        return run.stderr.strip(), seconds
    return json.loads(run.stdout.strip().splitlines()[-1]), seconds


def target_runs(shapes: list[str], targets: list, option: str, columns: int, color: bool = False):  # type: ignore[no-untyped-def]
    """`nfc encode` of each shape at each target of `option` (--target-bytes or --target-cd): yields
    (shape, target, file, report, seconds) while the file exists; an encode that fails prints its
    table row, the error spanning the row's `columns` cells, and is skipped."""
    with tempfile.TemporaryDirectory() as tmp:
        for name in shapes:
            for target in targets:
                out = Path(tmp) / f"{name}_{target}.nfc"
                r, seconds = encode_to(name, out, [option, str(target)], color)
                if isinstance(r, str):
                    print(f"| {name} | {target} | error: {r} |" + " |" * (columns - 3), flush=True)
                    continue
                yield name, target, out, r, seconds


def distortion_targets(shapes: list[str], targets: list[float]) -> None:
    print("| shape | target CD | estimated CD | nfc-decode CD | bytes | width | encodes | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    for name, target, out, r, seconds in target_runs(shapes, targets, "--target-cd", 8):
        measured = decoded_cd(DATA / SHAPES[name], out)
        worst = max(worst, measured / target)
        tried = ", ".join(f"w{a['width']} {a['cd']:.5f}" for a in r["attempts"])
        print(f"| {name} | {target} | {r['estimated_cd']:.6f} | {measured:.6f} | {r['bytes']} | "
              f"{r['width']} | {len(r['attempts'])} ({tried}) | {seconds:.0f} |", flush=True)
    print(f"\nlargest nfc-decode CD / target: {worst:.4f}")


def byte_budgets(shapes: list[str], budgets: list[int]) -> None:
    print("| shape | target B | bytes | used | width | bits | encodes | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    for name, budget, out, r, seconds in target_runs(shapes, budgets, "--target-bytes", 8):
        assert r["bytes"] == out.stat().st_size
        worst = max(worst, r["bytes"] / budget)
        print(f"| {name} | {budget} | {r['bytes']} | {100 * r['bytes'] / budget:.1f}% | {r['width']} | "
              f"{r['bits']} | {len(r['attempts'])} | {seconds:.0f} |", flush=True)
    print(f"\nlargest bytes / target: {worst:.4f} (must be <= 1)")


def colour_budgets(shapes: list[str], budgets: list[int]) -> None:
    print("| shape | target B | bytes | used | geometry width, bits | colour width, bits | encodes (geometry + colour) "
          "| PSNR dB | CD | s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    worst = 0.0
    for name, budget, out, r, seconds in target_runs(shapes, budgets, "--target-bytes", 10, color=True):
        assert r["bytes"] == out.stat().st_size and r["color"]
        worst = max(worst, r["bytes"] / budget)
        psnr, cd = decoded_points_quality(DATA / SHAPES[name], out)
        print(f"| {name} | {budget} | {r['bytes']} | {100 * r['bytes'] / budget:.1f}% | {r['width']}, {r['bits']} "
              f"| {r['color_width']}, {r['color_bits']} | {len(r['attempts'])} + {len(r['color_attempts'])} "
              f"| {psnr:.2f} | {cd:.6f} | {seconds:.0f} |", flush=True)
    print(f"\nlargest bytes / target: {worst:.4f} (must be <= 1)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="+", default=["bunny", "armadillo"], choices=sorted(SHAPES))
    ap.add_argument("--budgets", nargs="+", type=int, default=[800, 1500, 3000, 6000, 12000, 20000])
    ap.add_argument("--target-cds", nargs="+", type=float, default=None,
                    help="run --target-cd with these targets instead of the byte budgets")
    ap.add_argument("--color", action="store_true",
                    help="keep the shapes' colours: B bounds the whole file (geometry and colour)")
    args = ap.parse_args()
    if args.color:
        colour_budgets(args.shapes, args.budgets)
        return
    if args.target_cds:
        distortion_targets(args.shapes, args.target_cds)
        return
    byte_budgets(args.shapes, args.budgets)


if __name__ == "__main__":
    main()
