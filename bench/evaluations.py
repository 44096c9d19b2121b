#!/usr/bin/env python3
"""Where a decode's field evaluations go, per active finest cell (issue 11, item 2).

Per file and resolution R, three `nfc-decode --device cpu` runs of this tree's build:

  * `--resolution R --stats`: the active cells (finest cells that emit a triangle);
  * `--levels R --stats=json`: the one-shot decode's evaluations (values, every level) and, for a
    UDF, its gradients_evaluated: in a one-shot decode, the number of corners of the finest
    level's near cells (grid.h, udf_cell_is_near; GridBuilder::evaluate_udf_gradients), each of
    which needs a value and a gradient whatever the schedule;
  * `--levels R/4,R/2,R --stats=json`: the last level's own evaluations (a ladder evaluates the
    one-shot's values; each level reports its own), so "above" = all - finest.

    .venv/bin/python bench/evaluations.py bench/out/keep/bunny_w32.nfc \
        bench/out/nfc/bunny-udf_fast_L8_w32.nfc --resolutions 256 512

Prints one markdown table; the per-cell columns divide by the active cells.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def run(decoder: Path, path: Path, out: str, *args: str) -> str:
    return subprocess.run([str(decoder), str(path), "-o", out, "--device", "cpu", *args],
                          check=True, capture_output=True, text=True).stdout


def json_lines(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.startswith("{")]


def measure(decoder: Path, path: Path, resolution: int, out: str) -> dict:
    stats = run(decoder, path, out, "--resolution", str(resolution), "--stats")
    field = re.search(r"\((?:format [0-9.]+, )?(SDF|UDF)", stats)
    active = re.search(r"^mesh\s+[0-9.]+ ms\s+\((\d+) active cells", stats, re.M)
    if not field or not active:
        raise SystemExit(f"{path}: no field type or active cells in nfc-decode --stats")
    summary = json_lines(run(decoder, path, out, "--levels", str(resolution), "--stats=json"))[-1]
    ladder = ",".join(str(r) for r in (resolution // 4, resolution // 2, resolution))
    finest = json_lines(run(decoder, path, out, "--levels", ladder, "--stats=json"))[-2]
    return {"field": field[1], "active": int(active[1]), "all": summary["points_evaluated"],
            "finest": finest["points_evaluated"], "near_corners": summary["gradients_evaluated"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--resolutions", nargs="+", type=int, default=[256, 512])
    parser.add_argument("--decoder", type=Path, default=NFC_DECODE)
    args = parser.parse_args()
    if not args.decoder.exists():
        raise SystemExit(f"{args.decoder} is missing: build the C++ tree first (scripts/setup.sh)")
    if any(r < 64 for r in args.resolutions):
        raise SystemExit("resolutions below 64 have no level above the finest")
    print("| file | field | res | active cells | evaluations | per active cell | finest level's own "
          "| levels above | near-cell corners (UDF) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "mesh.ply")
        for path in args.files:
            for resolution in args.resolutions:
                m = measure(args.decoder, path, resolution, out)
                a = m["active"]
                near = f"{m['near_corners'] / a:.2f}" if m["field"] == "UDF" else "-"
                print(f"| {path.name} | {m['field']} | {resolution} | {a} | {m['all']} "
                      f"| {m['all'] / a:.2f} | {m['finest'] / a:.2f} "
                      f"| {(m['all'] - m['finest']) / a:.2f} | {near} |")


if __name__ == "__main__":
    main()
