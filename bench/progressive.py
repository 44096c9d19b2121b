#!/usr/bin/env python3
"""Progressive decode benchmark: nfc-decode --levels against the one-shot decode, per device.

Per file and device, the median over --runs of: the time to each ladder level from the moment the
.nfc bytes are given to the library (the context already created, --stats=json), the summary's
split (asset creation, extraction creation), and the one-shot decode at the final resolution
(parse + field + mesh from --stats), with the ratio progressive / one-shot.

    python3 bench/progressive.py /work/main/bench/out/nfc/bunny_fast_w32.nfc --levels 32,64,128,256
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def progressive(path: Path, levels: str, device: str) -> tuple[dict[int, float], dict]:
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run([str(NFC_DECODE), str(path), "-o", f"{tmp}/out.ply", "--levels", levels,
                              "--device", device, "--stats=json"],
                             check=True, capture_output=True, text=True).stdout
    objects = [json.loads(line) for line in out.splitlines()]
    return {o["resolution"]: o["elapsed_ms"] for o in objects[:-1]}, objects[-1]


def one_shot(path: Path, resolution: int, device: str) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run([str(NFC_DECODE), str(path), "-o", f"{tmp}/out.ply", "--resolution",
                              str(resolution), "--device", device, "--stats"],
                             check=True, capture_output=True, text=True).stdout
    ms = {m[1]: float(m[2]) for m in re.finditer(r"^(parse|field|mesh)\s+([0-9.]+) ms", out, re.M)}
    return ms["parse"] + ms["field"] + ms["mesh"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--levels", default="32,64,128,256")
    ap.add_argument("--devices", nargs="+", default=["vulkan", "cpu"])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    levels = [int(r) for r in args.levels.split(",")]
    print("| file | device | " + " | ".join(f"to {r} ms" for r in levels) +
          " | asset ms | prepare ms | one-shot ms | progressive / one-shot |")
    print("|" + "---|" * (len(levels) + 6))
    for path in args.files:
        for device in args.devices:
            runs = [progressive(path, args.levels, device) for _ in range(args.runs)]
            shots = [one_shot(path, levels[-1], device) for _ in range(args.runs)]
            to = [statistics.median(r[0][res] for r in runs) for res in levels]
            asset = statistics.median(r[1]["asset_ms"] for r in runs)
            prepare = statistics.median(r[1]["prepare_ms"] for r in runs)
            shot = statistics.median(shots)
            print(f"| {path.name} | {device} | " + " | ".join(f"{t:.1f}" for t in to) +
                  f" | {asset:.1f} | {prepare:.1f} | {shot:.1f} | {to[-1] / shot:.3f} |")


if __name__ == "__main__":
    main()
