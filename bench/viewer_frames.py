#!/usr/bin/env python3
"""Frame times of nfc-viewer while assets stream and refine, against the same scene fully loaded.

For each decode device, runs the viewer headless (xvfb-run) twice on the same assets:
  streaming  every asset arrives at --bandwidth through nfd_stream and refines through --levels
             while the frames run (frames counted while some asset is still loading);
  loaded     --preload: every final mesh is decoded before the first frame.
and prints one markdown table: frame time p50 / p99 / max (the interval between frame starts,
paced to 60 Hz), and the streaming frames longer than twice the loaded p99. The first WARMUP
frames of each run (pipeline compilation, first uploads) are left out of both.

    bench/viewer_frames.py [--viewer build/samples/nfc-viewer] [--devices cpu,vulkan]
                           [--bandwidth 256KB/s] [--levels 32,64,128,256] FILE.nfc...
"""
import argparse
import os
import subprocess
import sys
import tempfile

WARMUP = 5


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


def run(viewer, files, device, extra, args):
    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, "frames.txt")
        cmd = ["xvfb-run", "-a", "-s", f"-screen 0 {args.width}x{args.height}x24", viewer, *files,
               "--decode-device", device, "--bandwidth", args.bandwidth, "--levels", args.levels,
               "--width", str(args.width), "--height", str(args.height),
               "--screenshot", os.path.join(tmp, "shot.png"), "--frame-log", log,
               "--timeout", "1200", *extra]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"viewer_frames: {' '.join(cmd)} failed:\n{done.stderr}")
        rows = []
        with open(log) as f:
            for line in f:
                if not line.startswith("#"):
                    ms, work, loading = line.split()
                    rows.append((float(ms), float(work), loading == "1"))
        return rows[WARMUP:], done.stdout


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("files", nargs="+")
    p.add_argument("--viewer", default="build/samples/nfc-viewer")
    p.add_argument("--devices", default="cpu,vulkan")
    p.add_argument("--bandwidth", default="256KB/s")
    p.add_argument("--levels", default="32,64,128,256")
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=720)
    p.add_argument("--loaded-frames", type=int, default=600)
    args = p.parse_args()

    print(f"{len(args.files)} assets at {args.bandwidth} each, levels {args.levels}, "
          f"{args.width}x{args.height}, 60 Hz cap; frame ms (interval between frame starts)\n")
    print("| decode device | scene | frames | p50 | p99 | max | mean work ms "
          "| frames > 2x loaded p99 | all final after s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for device in args.devices.split(","):
        loaded, _ = run(args.viewer, args.files, device,
                        ["--preload", "--frames", str(args.loaded_frames)], args)
        streaming, out = run(args.viewer, args.files, device, ["--wait-loaded", "--frames", "10"],
                             args)
        limit = 2 * percentile([r[0] for r in loaded], 0.99)
        busy = [r for r in streaming if r[2]]
        for name, rows in (("fully loaded", loaded), ("streaming", busy)):
            ms = [r[0] for r in rows]
            over = str(sum(1 for m in ms if m > limit)) if rows is busy else "-"
            final = f"{sum(r[0] for r in busy) / 1e3:.1f}" if rows is busy else "-"
            print(f"| {device} | {name} | {len(ms)} | {percentile(ms, 0.5):.1f} "
                  f"| {percentile(ms, 0.99):.1f} | {max(ms):.1f} "
                  f"| {sum(r[1] for r in rows) / len(rows):.1f} | {over} | {final} |")
        sys.stdout.flush()
        print(f"\n<!-- {device} streaming run:\n{out.strip()}\n-->", file=sys.stderr)


if __name__ == "__main__":
    main()
