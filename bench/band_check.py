#!/usr/bin/env python3
"""Cells the CPU path's surface following loses against the keep rule's band (issue 11, item 2).

For each SDF file and resolution: `nfc-decode --device cpu --stats` as decoders run it (surface
following) and with `--sample-band` (the keep rule, which the Vulkan path's SDF levels use), the
active cells of each, the difference (cells the schedule lost), and the evaluations per active
cell; with --baseline, the same figures from another nfc-decode build (e.g. the previous
release's, built from a `git worktree`). Prints a markdown table and a summary line. Fast (two or
three decodes per row) where bench/lost_cells.py evaluates the dense grid.

    .venv/bin/python bench/band_check.py bench/out/nfc/dragon_fast_L7_w*.nfc --resolutions 256 512
"""

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

from evaluations import NFC_DECODE, run

STATS = re.compile(r"\((\d+) active cells, ([\d.]+) points evaluated per cell\)")


def active_cells(decoder: Path, path: Path, resolution: int, band: bool) -> tuple[int, float]:
    """(active cells, evaluations per active cell) of one CPU-path decode."""
    with tempfile.TemporaryDirectory() as tmp:
        stats = run(decoder, path, f"{tmp}/m.ply", "--stats", "--resolution", str(resolution),
                    *(["--sample-band"] if band else []))
    match = STATS.search(stats)
    if match is None:
        raise RuntimeError(f"{decoder} printed no mesh statistics for {path}")
    return int(match.group(1)), float(match.group(2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--resolutions", nargs="+", type=int, default=[256])
    ap.add_argument("--baseline", type=Path, help="another nfc-decode build to compare with")
    args = ap.parse_args()

    header = "| file | res | band cells | lost | per cell |"
    if args.baseline:
        header += " baseline lost | baseline per cell |"
    print(header)
    print("|---|---:" + "|---:" * (header.count("|") - 3) + "|")
    rows = lost_rows = lost_total = base_rows = base_total = 0
    for path in args.files:
        for resolution in args.resolutions:
            band, _ = active_cells(NFC_DECODE, path, resolution, band=True)
            ours, per_cell = active_cells(NFC_DECODE, path, resolution, band=False)
            line = f"| {path.name} | {resolution} | {band} | {band - ours} | {per_cell:.2f} |"
            rows += 1
            lost_rows += ours != band
            lost_total += band - ours
            if args.baseline:
                base, base_per_cell = active_cells(args.baseline, path, resolution, band=False)
                line += f" {band - base} | {base_per_cell:.2f} |"
                base_rows += base != band
                base_total += band - base
            print(line, flush=True)
    summary = f"\n{rows} decodes: {lost_rows} lose cells against the band ({lost_total} cells)"
    if args.baseline:
        summary += f"; the baseline: {base_rows} ({base_total} cells)"
    print(summary)


if __name__ == "__main__":
    main()
