#!/usr/bin/env python3
"""Progressive decode cost in instructions: nfc-decode --levels LADDER against --levels FINAL.

Issue 7 asks the full ladder (32 -> 64 -> 128 -> 256) to cost at most 10% more than a one-shot
decode. bench/progressive.py measures it in CPU and wall time, which on a shared 2-core VM drift
by 20% within seconds; this script counts instructions with valgrind's callgrind instead, which
no load or clock change moves (two runs of the same command agree to a few parts per million on
the CPU path).

Per file and device: the instructions of the whole `nfc-decode` process for the final level alone
and for the ladder, and their ratio; then the same with the context's creation taken out (the
instructions of a run whose input is cut after 64 bytes: the context, then a parse error), which
is what the ladder's `cpu_ms` covers (from the first byte on; the written `.ply` is the same in
both runs). Under valgrind, lavapipe's LLVM targets valgrind's CPU (no AVX-512), so each network
shape's kernels are first compiled into Mesa's shader cache by a warm-up run that is not counted;
the C++ path runs its AVX2 build, where a network evaluation costs relatively more than in the
AVX-512 build a native run picks: on the CPU path the counts overweight evaluations against
bookkeeping, so a change that trades one for the other must be timed too (bench/RESULTS.md,
"0.13.2: the C++ gradient in reverse mode", its third try). A lavapipe run takes 1-2 minutes
under callgrind.

    python3 bench/ladder_instructions.py bench/out/nfc/bunny-udf_fast_L8_w32.nfc --devices vulkan cpu
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"


def instructions(args: list[str], binary: Path) -> int:
    """Instructions callgrind collected over the whole process `binary args`."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run(["valgrind", "--tool=callgrind", "--smc-check=all-non-file",
                              f"--callgrind-out-file={tmp}/callgrind.out", str(binary), *args,
                              "-o", f"{tmp}/out.ply"],
                             capture_output=True, text=True)
    found = re.search(r"Collected : (\d+)", run.stderr)
    if not found:
        raise SystemExit(f"callgrind counted nothing for {args}:\n{run.stderr[-2000:]}")
    return int(found.group(1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--levels", default="32,64,128,256")
    ap.add_argument("--devices", nargs="+", default=["vulkan", "cpu"])
    ap.add_argument("--binary", type=Path, default=NFC_DECODE)
    args = ap.parse_args()
    final = args.levels.split(",")[-1]
    print("| file | device | final only, instructions | ladder | ladder / final |"
          " context creation | ladder / final without it |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for device in args.devices:
        with tempfile.TemporaryDirectory() as tmp:
            cut = Path(tmp) / "cut.nfc"
            cut.write_bytes(args.files[0].read_bytes()[:64])
            context_args = [str(cut), "--levels", final, "--device", device]
            if device != "cpu":
                instructions(context_args, args.binary)  # the device's kernels into Mesa's cache
            context = instructions(context_args, args.binary)
        for path in args.files:
            common = [str(path), "--device", device]
            if device != "cpu":
                instructions([*common, "--levels", final], args.binary)  # Mesa's cache, warmed
            last = instructions([*common, "--levels", final], args.binary)
            ladder = instructions([*common, "--levels", args.levels], args.binary)
            print(f"| {path.name} | {device} | {last:,} | {ladder:,} | {ladder / last:.3f} |"
                  f" {context:,} | {(ladder - context) / (last - context):.3f} |", flush=True)


if __name__ == "__main__":
    main()
