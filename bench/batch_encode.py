"""Encoding throughput: shapes per hour of `nfc encode-batch`, and batched vs one-by-one training.

    # library: `nfc encode-batch` on real shapes (../shared/data), then the resumed rerun
    python bench/batch_encode.py library --workers 2 [--width 32] [--out out/bench_batch]
    # trainer: one-by-one `compress` vs `batch_train.compress_many` (K shapes per model)
    python bench/batch_encode.py trainer --device cuda --shapes 32 --group 32 [--width 32] [--epochs N]

`library` prints shapes per hour and the rerun's time; `trainer` prints shapes per minute of both
trainers and their validation losses. The trainer mode uses synthetic meshes (trimesh primitives
with random scales), so it runs anywhere, the GPU machine included.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA_CANDIDATES = [ROOT.parent / "shared" / "data", ROOT / "shared" / "data", Path("/work/shared/data")]
LIBRARY = [  # small-to-medium real meshes, SDF and UDF
    "stanford/bun_zipper_res2.ply.gz", "stanford/bun_zipper_res3.ply.gz", "misc/spot.obj.gz",
    "misc/suzanne.obj.gz", "misc/igea_tris.ply.gz", "garments/Pants1.obj.gz",
    "garments/TShirtNoCoat.obj.gz", "misc/nefertiti-lowres.obj.gz",
]


def data_dir() -> Path:
    for d in DATA_CANDIDATES:
        if d.is_dir():
            return d
    sys.exit("shared data not found (looked in: " + ", ".join(map(str, DATA_CANDIDATES)) + ")")


def nfc(*args: str) -> tuple[int, float, str]:
    start = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "nfencode.cli", *args], capture_output=True, text=True, check=False)
    return p.returncode, time.perf_counter() - start, p.stdout


def library(args: argparse.Namespace) -> None:
    src = data_dir()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = out / "manifest.jsonl"
    manifest.write_text("".join(json.dumps({"path": str(src / p)}) + "\n" for p in LIBRARY[: args.shapes]))
    results = out / "nfc"
    if results.exists():
        for f in results.iterdir():
            f.unlink()
    common = ["--workers", str(args.workers), "--width", str(args.width), "--quiet"]
    code, first, log = nfc("encode-batch", str(manifest), "-o", str(results), *common)
    print(log.strip().splitlines()[-1])
    rows = [json.loads(line) for line in (results / "results.jsonl").read_text().splitlines()]
    ok = [r for r in rows if r["status"] == "ok"]
    code2, second, log2 = nfc("encode-batch", str(manifest), "-o", str(results), *common)
    print(log2.strip().splitlines()[-1])
    per_asset = sorted(r["seconds"] for r in ok)
    print(f"{len(ok)} shapes (W {args.width}, preset fast, {args.workers} workers) in {first:.1f} s wall "
          f"(process start and cluster start included): {3600 * len(ok) / first:.0f} shapes/hour; "
          f"per shape {per_asset[0]:.1f}-{per_asset[-1]:.1f} s; rerun {second:.1f} s "
          f"({100 * second / first:.1f}% of the first run); exit {code}, {code2}")
    decoder = Path(args.decoder)
    if decoder.exists():
        with tempfile.TemporaryDirectory() as tmp:
            bad = [r["output"] for r in ok if subprocess.run(
                [str(decoder), r["output"], "-o", f"{tmp}/x.glb", "--resolution", "64"], capture_output=True, check=False).returncode]
        print(f"nfc-decode: {len(ok) - len(bad)} of {len(ok)} files decode" + (f"; failed: {bad}" if bad else ""))


def synthetic_shapes(n: int, seed: int = 0) -> list:
    import numpy as np
    import trimesh
    from nfencode.io import Shape

    rng = np.random.default_rng(seed)
    makers = [lambda: trimesh.creation.icosphere(subdivisions=3), lambda: trimesh.creation.torus(0.6, 0.2),
              lambda: trimesh.creation.box(), lambda: trimesh.creation.capsule(height=1.0, radius=0.4),
              lambda: trimesh.creation.cylinder(radius=0.5, height=1.2, sections=48)]
    shapes = []
    for i in range(n):
        m = makers[i % len(makers)]()
        m.apply_scale(rng.uniform(0.5, 1.5, 3))
        shapes.append(Shape(np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64), None, f"s{i}"))
    return shapes


def trainer(args: argparse.Namespace) -> None:
    import torch
    from nfencode.batch_train import compress_many
    from nfencode.encoder import EncodeConfig, compress

    shapes = synthetic_shapes(args.shapes)
    cfg = EncodeConfig(width=args.width, epochs=args.epochs, quiet=True, device=args.device, threads=args.threads)
    device = torch.device("cuda" if args.device == "cuda" or (args.device == "auto" and torch.cuda.is_available())
                          else "cpu")
    from nfencode.devices import cpu_threads

    name = torch.cuda.get_device_name() if device.type == "cuda" else f"CPU, {cpu_threads(args.threads)} threads"
    print(f"{len(shapes)} synthetic shapes, W {args.width}, epochs {args.epochs or 'preset'} (+QAT), {name}")
    compress(shapes[0], cfg)  # warm-up (CUDA context, kernels)
    n_one = min(len(shapes), args.one_by_one)
    start = time.perf_counter()
    alone = [compress(s, cfg) for s in shapes[:n_one]]
    t_one = time.perf_counter() - start
    start = time.perf_counter()
    together = []
    for i in range(0, len(shapes), args.group):
        together += compress_many(shapes[i: i + args.group], cfg)
    t_many = time.perf_counter() - start
    ratio = [b.final_loss / a.final_loss for a, b in zip(alone, together)]
    print(f"one-by-one: {n_one} shapes in {t_one:.1f} s = {60 * n_one / t_one:.1f} shapes/min")
    print(f"batched (groups of {args.group}): {len(shapes)} shapes in {t_many:.1f} s = "
          f"{60 * len(shapes) / t_many:.1f} shapes/min ({(len(shapes) / t_many) / (n_one / t_one):.1f}x)")
    print(f"validation loss batched / one-by-one over {len(ratio)} shapes: "
          f"min {min(ratio):.3f}, max {max(ratio):.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="mode", required=True)
    p = sub.add_parser("library")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--width", type=int, default=32)
    p.add_argument("--shapes", type=int, default=len(LIBRARY))
    p.add_argument("--out", default=str(ROOT / "out" / "bench_batch"))
    p.add_argument("--decoder", default=str(ROOT / "build" / "samples" / "nfc-decode"),
                   help="nfc-decode to check the files with (skipped when absent)")
    p = sub.add_parser("trainer")
    p.add_argument("--device", default="auto", choices=("auto", "cpu", "cuda"))
    p.add_argument("--shapes", type=int, default=8)
    p.add_argument("--group", type=int, default=8)
    p.add_argument("--one-by-one", type=int, default=8, help="shapes timed one by one (a prefix)")
    p.add_argument("--width", type=int, default=32)
    p.add_argument("--epochs", type=int, default=None)
    p.add_argument("--threads", type=int, default=None)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    (library if args.mode == "library" else trainer)(args)


if __name__ == "__main__":
    main()
