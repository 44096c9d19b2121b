"""`nfc`: encode shapes into .nfc files, inspect, decode and evaluate them.

Every user-facing failure (bad input file, corrupt .nfc, I/O error, wrong arguments) ends in exactly
one line `nfc: error: ...` on stderr and a non-zero exit status (2 for command-line misuse, 1 for the
rest); tracebacks are reserved for bugs. `info`, `decode` and `eval` never import torch; `encode-batch`
imports Ray only when it runs on Ray. `encode-batch` reports each failed asset as one such line and
exits 1 when any failed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn, Sequence

from . import __version__, rate
from .bitstream import (
    COLOR_SPACE_NAMES,
    FIELD_NAMES,
    FIELD_UDF,
    MAX_BITS,
    MAX_FREQUENCIES,
    MAX_WIDTH,
    MIN_BITS,
    OUTPUT_NAMES,
    TAG_COLOR,
    TAG_GEOM,
    NetworkBlock,
    NfcFile,
    frequency_base_in_range,
    read_nfc,
)
from .config import (
    COLOR_NUM_FREQUENCIES,
    COLOR_RESOLUTION,
    COLOR_WIDTH,
    DEFAULT_BITS,
    DEFAULT_WIDTH,
    FREQUENCY_BASE,
    MAX_TORCH_THREADS,
    MAX_TRUNCATION,
    MIN_TRUNCATION,
    NUM_FREQUENCIES,
    TARGET_COLOR_BITS,
    TRUNCATION,
)
from .devices import DEVICE_CHOICES
from .errors import InputError, NfcError
from .io import Shape, load_shape, save_mesh, save_points

EXIT_ERROR = 1
EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse that reports misuse as one line instead of usage + message."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"nfc: error: {message} (see `{self.prog} --help`)\n")
        raise SystemExit(EXIT_USAGE)


def _fmt(x: float) -> str:
    """4 significant digits, trailing zeros kept (metrics.md)."""
    return format(x, "#.4g")


def _output_path(path: str, suffixes: tuple[str, ...]) -> Path:
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise InputError(f"{p}: output must end in {' or '.join(suffixes)}")
    if not p.parent.is_dir():  # fail before the long work, not after it
        raise InputError(f"{p}: no such directory {p.parent}")
    return p


def _read_nfc_file(path: str) -> tuple[NfcFile, int]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file" if not p.exists() else f"{p}: not a regular file")
    data = p.read_bytes()
    try:
        return read_nfc(data), len(data)
    except NfcError as e:
        raise NfcError(f"{p}: {e.message}") from None


def _positive(name: str, value: int | None, low: int = 1, high: int | None = None) -> None:
    if value is None:
        return
    if value < low or (high is not None and value > high):
        bound = f"{low}..{high}" if high is not None else f">= {low}"
        raise InputError(f"{name} must be {bound}, got {value}")


def _warn(message: str) -> None:
    sys.stderr.write(f"nfc: warning: {message}\n")


def _progress(args: argparse.Namespace) -> Callable[[str], None]:
    """Where a rate search's line per finished try goes: stderr, unless --quiet."""

    def say(message: str) -> None:
        if not args.quiet:
            sys.stderr.write(f"nfc: {message}\n")

    return say


def cmd_encode(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    output = _output_path(args.output, (".nfc",))
    _check_encode_args(args)
    geometry = None if args.geometry is None else _read_nfc_file(args.geometry)[0]
    shape = load_shape(args.input, colors=args.color, warn=_warn)
    from . import encoder  # imports torch: only this command needs it
    from .bitstream import write_nfc

    from .devices import resolve_device

    device = resolve_device(args.device)
    config = encoder.EncodeConfig(**_encode_options(args), quiet=args.quiet, threads=args.threads)
    choice = None
    rate.check_targets(args.target_bytes, args.target_cd, TARGET_FLAGS)
    if args.target_bytes is not None:
        result, choice = _encode_to_target(shape, config, args, None if geometry is None else write_nfc(geometry))
    elif args.target_cd is not None:
        result, choice = _encode_to_distortion(shape, config, args, geometry is not None)
    else:
        result = encoder.compress(shape, config, None if geometry is None else write_nfc(geometry))
    from .batch import write_atomic

    write_atomic(output, result.data)
    seconds = time.perf_counter() - start
    if args.json:
        print(json.dumps(_encode_report(args, output, result, choice, seconds)))
        return 0
    print(f"field: {result.field}, {result.field_reason}")
    if result.color is not None:
        c = result.color
        print(f"colour: width {c.chunk.network.out_features[0]}, {c.chunk.network.bits} bits, {c.chunk.network.parameter_count} "
              f"parameters, fitted on the surface decoded at {args.color_resolution} ({c.surface_vertices} vertices) "
              f"in {c.seconds:.1f} s, validation MSE {c.validation_loss:.3g} (colours in [-1, 1])")
    width, bits = (choice.width, choice.bits) if choice is not None else (config.width, config.bits)
    geometry_what = (f"geometry of {args.geometry}" if geometry is not None else
                     f"width {width}, {bits} bits, preset {args.preset}")
    if choice is not None and args.target_cd is not None:
        tried = ", ".join(f"w{a.width} {a.bytes} B CD {a.cd:.5g}" for a in choice.attempts)
        print(f"target CD {args.target_cd:g}: chose width {width}, {bits} bits, estimated CD {choice.cd:.5g} "
              f"(encodes: {tried})")
    elif choice is not None:
        if choice.attempts:
            tried = ", ".join(f"w{a.width}/{a.bits}b {a.bytes} B" for a in choice.attempts)
            print(f"target {args.target_bytes} bytes: chose width {width}, {bits} bits (encodes: {tried})")
        if choice.color is not None:
            tried = ", ".join(f"w{a.width}/{a.bits}b {a.bytes} B" for a in choice.color.attempts)
            print(f"target {args.target_bytes} bytes: chose colour width {choice.color.width}, {choice.color.bits} bits "
                  f"(whole-file encodes: {tried})")
    print(
        f"{output}: {len(result.data)} bytes ({result.field}, {geometry_what}, "
        f"{'with' if result.color is not None else 'no'} colour, {device.type}), encoded in {seconds:.1f} s "
        f"(training {result.seconds:.1f} s" + ("" if geometry is not None else f", final loss {result.final_loss:.3g}")
        + ")"
    )
    return 0


def _check_target(option: str, args: argparse.Namespace, chooses_color: bool = False) -> None:
    if args.width is not None:
        raise InputError(f"{option} chooses the width: give one or the other, not --width too")
    if chooses_color and args.color_width is not None:
        raise InputError(f"{option} chooses the colour width: give one or the other, not --color-width too")


def _encode_to_target(shape: Shape, cfg, args: argparse.Namespace, geometry: bytes | None):  # type: ignore[no-untyped-def]
    """--target-bytes (nfencode.targets.compress_to_bytes): with colour the bound is the whole
    file's, the colour width chosen too; with --geometry only the colour is sized."""
    from . import encoder, targets

    _check_target("--target-bytes", args, chooses_color=encoder.wants_color(shape, cfg))
    return targets.compress_to_bytes(shape, cfg, args.target_bytes, geometry, args.color_bits, _progress(args))


def _encode_to_distortion(shape: Shape, cfg, args: argparse.Namespace, reuses_geometry: bool):  # type: ignore[no-untyped-def]
    """--target-cd (nfencode.targets.compress_to_distortion): the geometry is searched, so none is
    reused; a coloured input's colour is fitted on the geometry chosen."""
    from . import targets

    _check_target("--target-cd", args)
    if reuses_geometry:
        raise InputError("--target-cd sizes the geometry: it cannot reuse the one --geometry gives")
    return targets.compress_to_distortion(shape, cfg, args.target_cd, _progress(args))


def _encode_report(args: argparse.Namespace, output: Path, result, choice, seconds: float) -> dict:  # type: ignore[no-untyped-def]
    """encode --json: the file written and how."""
    f = read_nfc(result.data)
    net = f.geometry.network
    return {
        "output": str(output),
        "bytes": len(result.data),
        "field": result.field,
        "width": net.out_features[0],
        "bits": net.bits,
        "frequencies": net.num_frequencies,
        "frequency_base": net.frequency_base,
        "truncation": f.geometry.truncation,
        "preset": args.preset,
        "color": f.color is not None,
        "frame64": f.geometry.frame64 is not None,
        "seconds": round(seconds, 3),
        "target_bytes": args.target_bytes,
        "target_cd": args.target_cd,
        "estimated_cd": choice.cd if args.target_cd is not None else None,
        "attempts": None if choice is None else [dataclasses.asdict(a) for a in choice.attempts],
        "color_width": None if f.color is None else f.color.network.out_features[0],
        "color_bits": None if f.color is None else f.color.network.bits,
        "color_attempts": (None if not isinstance(choice, rate.RateChoice) or choice.color is None
                           else [dataclasses.asdict(a) for a in choice.color.attempts]),
    }


def _encode_options(args: argparse.Namespace) -> dict:
    """The EncodeConfig fields that `encode` and `encode-batch` share (batch.ENCODE_OPTIONS)."""
    width = args.width if args.width is not None else DEFAULT_WIDTH
    color_width = args.color_width if args.color_width is not None else COLOR_WIDTH
    color_bits = args.color_bits if args.color_bits is not None else DEFAULT_BITS
    return {"field": args.field, "width": width, "bits": args.bits, "frequencies": args.frequencies,
            "frequency_base": args.frequency_base, "preset": args.preset, "epochs": args.epochs, "seed": args.seed,
            "device": args.device, "color": args.color, "color_width": color_width, "color_bits": color_bits,
            "color_frequencies": args.color_frequencies, "color_resolution": args.color_resolution,
            "color_epochs": args.color_epochs, "truncation": args.truncation}


def _check_encode_args(args: argparse.Namespace) -> None:
    _positive("--width", args.width, 1, MAX_WIDTH)
    _positive("--bits", args.bits, MIN_BITS, MAX_BITS)
    _positive("--frequencies", args.frequencies, 0, MAX_FREQUENCIES)
    if not frequency_base_in_range(args.frequency_base):
        raise InputError(f"--frequency-base must be in [1, 2], got {args.frequency_base}")
    if args.truncation is not None and not MIN_TRUNCATION <= args.truncation <= MAX_TRUNCATION:
        raise InputError(f"--truncation must be in [{MIN_TRUNCATION}, {MAX_TRUNCATION}], got {args.truncation}")
    _positive("--epochs", args.epochs)
    _positive("--threads", args.threads)
    _positive("--color-width", args.color_width, 1, MAX_WIDTH)
    _positive("--color-bits", args.color_bits, MIN_BITS, MAX_BITS)
    _positive("--color-resolution", args.color_resolution, 8, 1024)
    _positive("--color-frequencies", args.color_frequencies, 0, MAX_FREQUENCIES)
    _positive("--color-epochs", args.color_epochs)


def cmd_encode_batch(args: argparse.Namespace) -> int:
    from . import batch

    _check_encode_args(args)
    _positive("--workers", args.workers)
    _positive("--tasks-per-gpu", args.tasks_per_gpu)
    _positive("--group", args.group)
    if args.cpus_per_task <= 0:
        raise InputError(f"--cpus-per-task must be > 0, got {args.cpus_per_task}")
    gpus_per_task = 0.0
    if args.device == "cuda" or (args.device == "auto" and args.address is None and _driver_sees_gpu()):
        gpus_per_task = 1.0 / args.tasks_per_gpu
    joined = args.address is not None or bool(os.environ.get("RAY_ADDRESS"))
    if not joined and args.device == "cuda":
        from .devices import resolve_device

        resolve_device("cuda")  # fail once here, not once per asset
    workers = args.workers if args.workers is not None else (None if joined else batch.available_cpus())
    rate.check_targets(args.target_bytes, args.target_cd, TARGET_FLAGS)  # once here, not per asset
    targets = {"target_bytes": args.target_bytes, "target_cd": args.target_cd}
    summary = batch.encode_batch(
        args.input, args.output, {**_encode_options(args), **targets}, workers=workers,
        address=args.address,
        cpus_per_task=args.cpus_per_task, gpus_per_task=gpus_per_task, threads=args.threads, group=args.group,
        quiet=args.quiet,
        report=lambda message: sys.stderr.write(f"nfc: error: {message}\n"),
    )
    ok, skipped, failed = summary.count("ok"), summary.count("skipped"), summary.count("error")
    results = Path(args.output) / batch.RESULTS_NAME
    if args.json:
        print(json.dumps({"output": str(args.output), "results": str(results), "encoded": ok, "skipped": skipped,
                          "failed": failed, "seconds": round(summary.seconds, 3), "rows": summary.rows}, indent=2))
    else:
        print(f"{args.output}: {ok} encoded, {skipped} skipped (up to date), {failed} failed of {len(summary.rows)} "
              f"in {summary.seconds:.1f} s; rows in {results}")
    return EXIT_ERROR if summary.failed else 0


def _driver_sees_gpu() -> bool:
    import torch

    return bool(torch.cuda.is_available())


def _layers(net: NetworkBlock) -> list[dict]:
    activations = ["sine"] * (len(net.out_features) - 1) + [OUTPUT_NAMES[net.output]]
    return [{"in": i, "out": o, "activation": a} for i, o, a in zip(net.in_features, net.out_features, activations)]


def _network_info(net: NetworkBlock) -> dict:
    """What `nfc info --json` says of a network block (geometry and colour alike)."""
    return {
        "num_frequencies": net.num_frequencies,
        "frequency_base": net.frequency_base,
        "omega0": net.omega0,
        "layers": _layers(net),
        "bits": net.bits,
        "parameters": net.parameter_count,
        "steps": [list(s) for s in net.steps],
    }


def _color_info(f: NfcFile) -> dict | None:
    if f.color is None:
        return None
    net = f.color.network
    return {
        "color_space": COLOR_SPACE_NAMES[f.color.color_space],
        "bytes": f.chunk_bytes.get(TAG_COLOR),
        "width": net.out_features[0],
        **_network_info(net),
    }


def _info_dict(path: str, f: NfcFile, size: int) -> dict:
    g, net = f.geometry, f.geometry.network
    return {
        "file": path,
        "bytes": size,
        "format": f"{f.major}.{f.minor}",
        "field": FIELD_NAMES[g.field_type],
        "truncation": g.truncation,
        "center": list(g.center),
        "scale": g.scale,
        "frame64": None if g.frame64 is None else {"center": list(g.frame64.center), "scale": g.frame64.scale},
        **_network_info(net),
        "geometry_bytes": f.chunk_bytes.get(TAG_GEOM),
        "color": _color_info(f),
        "skipped_chunks": list(f.skipped_chunks),
    }


def _widths(layers: list[dict]) -> str:
    return "->".join([str(layers[0]["in"])] + [str(layer["out"]) for layer in layers])


def cmd_info(args: argparse.Namespace) -> int:
    f, size = _read_nfc_file(args.file)
    info = _info_dict(args.file, f, size)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    acts = ", ".join(layer["activation"] for layer in info["layers"])
    c = ", ".join(f"{x:.6g}" for x in info["center"])
    print(f"file        {args.file}: {size} bytes, format {info['format']}")
    print(f"field       {info['field']}, truncation {info['truncation']:.6g}")
    frame64 = info["frame64"]
    if frame64 is None:
        print(f"frame       original = unit * {info['scale']:.6g} + ({c})")
    else:  # geo-referenced: the exact values, which decoded positions are offset by
        c64 = ", ".join(f"{x:.17g}" for x in frame64["center"])
        print(f"frame       original = unit * {frame64['scale']:.17g} + ({c64})  (64-bit; positions offset by the center)")
    print(
        f"encoding    {info['num_frequencies']} frequencies, pi * {info['frequency_base']:.6g}^k; "
        f"omega0 {info['omega0']:.6g}"
    )
    print(f"network     {_widths(info['layers'])} ({acts})")
    print(f"weights     {info['parameters']} parameters at {info['bits']} bits, GEOM chunk {info['geometry_bytes']} bytes")
    color = info["color"]
    if color is not None:
        print(
            f"colour      {color['color_space']}, width {color['width']}, {color['num_frequencies']} frequencies, "
            f"omega0 {color['omega0']:.6g}, network {_widths(color['layers'])} (sigmoid output), {color['parameters']} parameters at "
            f"{color['bits']} bits, colr chunk {color['bytes']} bytes"
        )
    if info["skipped_chunks"]:
        print(f"skipped     unknown optional chunks: {', '.join(info['skipped_chunks'])}")
    return 0


def cmd_decode(args: argparse.Namespace) -> int:
    from .reference import color_bytes, decode_points, extract_mesh, extract_unit_mesh, frame_offset

    output = _output_path(args.output, (".ply", ".obj"))
    _positive("--points", args.points)
    start = time.perf_counter()
    f, _ = _read_nfc_file(args.file)
    if args.points is not None:
        mesh = extract_unit_mesh(f, args.resolution, args.sample_band)
        if len(mesh.faces) == 0:
            raise NfcError(f"{args.file}: the decoded field has no surface, no points to sample")
        points, colors = decode_points(f, mesh, args.points, args.seed)
        save_points(output, points, None if colors is None else color_bytes(colors), frame_offset(f))
        what = f"{args.points} points"
    else:
        mesh = extract_mesh(f, args.resolution, band=args.sample_band)
        colors = mesh.colors
        save_mesh(output, mesh.vertices, mesh.faces, mesh.normals, None if colors is None else color_bytes(colors),
                  frame_offset(f))
        what = f"{len(mesh.vertices)} vertices, {len(mesh.faces)} triangles"
    seconds = time.perf_counter() - start
    gradients = f" + {mesh.gradients_evaluated} with gradients" if f.geometry.field_type == FIELD_UDF else ""
    colored = ", with colour" if colors is not None else ""
    print(
        f"{output}: {what}{colored} ({FIELD_NAMES[f.geometry.field_type]}, resolution {args.resolution}, "
        f"{mesh.points_evaluated} field evaluations{gradients}, {seconds:.1f} s)"
    )
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from .metrics import chamfer_distance, sampling_floor, shape_color_psnr

    _positive("--samples", args.samples)
    gt: Shape = load_shape(args.ground_truth, warn=_warn)
    rec: Shape = load_shape(args.reconstruction, warn=_warn)
    cd = chamfer_distance(gt, rec, args.samples, args.seed)
    floor = sampling_floor(gt, args.samples, args.seed)
    psnr = shape_color_psnr(gt, rec)
    result = {
        "ground_truth": args.ground_truth,
        "reconstruction": args.reconstruction,
        "chamfer_distance": cd,
        "sampling_floor": floor,
        "excess": cd - floor,
        "samples": args.samples,
        "seed": args.seed,
        "color_psnr": psnr,
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"CD      {_fmt(cd)}  (ground truth's unit-ball frame, {args.samples} samples per side, seed {args.seed})")
        print(f"floor   {_fmt(floor)}  (two independent samplings of the ground truth)")
        print(f"excess  {_fmt(cd - floor)}  (CD - floor)")
        if psnr is not None:
            print(f"PSNR    {_fmt(psnr)} dB  (colour, mean of both directions over all points, peak 255)")
    return 0


TARGET_FLAGS = ("--target-bytes", "--target-cd")


def _add_target_options(p: argparse.ArgumentParser, bytes_help: str, cd_help: str) -> None:
    p.add_argument(TARGET_FLAGS[0], type=int, default=None, metavar="B", help=bytes_help)
    p.add_argument(TARGET_FLAGS[1], type=float, default=None, metavar="C", help=cd_help)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="nfc", description="3D compression with neural fields (.nfc files).")
    parser.add_argument("--version", action="version", version=f"nfc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("encode", help="compress a mesh or point cloud into an .nfc file")
    p.add_argument("input", help="PLY, OBJ, OFF, glTF or GLB file (optionally .gz), or a scanalyze .conf of scans")
    p.add_argument("-o", "--output", required=True, help="output .nfc file")
    _add_encode_options(p)
    _add_target_options(
        p, "write the widest network whose file is at most B bytes (chooses --width, and fewer bits below width "
           "4); with colour B bounds the whole file: the geometry gets a share, the colour network (--color-width "
           "chosen) the rest",
        "write the smallest file (choosing --width) whose Chamfer distance to the input, estimated by decoding "
        "each candidate with the reference decoder at 256 (metrics.md, seed --seed), is at most C; a coloured "
        "input's colour network (--color-width) is then fitted on that geometry")
    p.add_argument("--json", action="store_true", help="print what was written as one JSON object")
    _add_color_options(p)
    p.add_argument("--geometry", metavar="FILE.nfc", default=None,
                   help="reuse the geometry of this .nfc file (of the same input) and fit only the colour")
    p.set_defaults(run=cmd_encode)

    p = sub.add_parser("encode-batch", help="encode a directory of shapes or a JSON-lines manifest (Ray)")
    p.add_argument("input", help="directory of shape files, or a .jsonl manifest: one {\"path\": ..., options} per line")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                   help="output directory: <name>.nfc per asset and results.jsonl (created if missing)")
    p.add_argument("--workers", type=int, default=None,
                   help="assets encoded at once (default: the CPUs here; on a joined cluster, as many as it "
                        "schedules); 1 runs in this process without Ray (unless --address or RAY_ADDRESS is given)")
    p.add_argument("--address", default=None,
                   help="join this Ray cluster (e.g. ray://head:10001 or head:6379; default $RAY_ADDRESS) "
                        "instead of starting a local one")
    p.add_argument("--cpus-per-task", type=float, default=1.0, help="Ray CPUs (and torch threads) per asset (default 1)")
    p.add_argument("--tasks-per-gpu", type=int, default=4, help="with a GPU: tasks sharing one GPU (default 4)")
    p.add_argument("--group", type=int, default=1,
                   help="train up to K assets with the same options per task as one batched model "
                        "(many tiny networks per kernel launch; for GPUs, e.g. 16; default 1)")
    _add_target_options(
        p, "write each asset's best file of at most B bytes, as `encode --target-bytes` does (its width, and with "
           "colour its colour width, chosen; assets then train one by one); a manifest line's target replaces it",
        "write each asset's smallest file whose estimated Chamfer distance is at most C, as `encode --target-cd` "
        "does; a manifest line's target replaces it")
    p.add_argument("--json", action="store_true",
                   help="print the counts and this run's row of every asset (as results.jsonl has them) as one "
                        "JSON object instead of the summary line")
    _add_encode_options(p)
    _add_color_options(p)
    p.set_defaults(run=cmd_encode_batch)

    p = sub.add_parser("info", help="describe an .nfc file")
    p.add_argument("file")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=cmd_info)

    p = sub.add_parser("decode", help="extract a mesh (or sampled points) from an .nfc file (SDF or UDF)")
    p.add_argument("file")
    p.add_argument("-o", "--output", required=True, help="output .ply or .obj")
    p.add_argument("--resolution", type=int, default=256, help="marching cubes grid cells per axis (8..1024)")
    p.add_argument("--points", type=int, default=None, help="write this many surface points instead of the mesh")
    p.add_argument("--seed", type=int, default=0, help="seed of the point sampling")
    p.add_argument("--sample-band", action="store_true",
                   help="sample the band around the surface, not only the cells it crosses (UDF: can "
                        "carry triangles; nfc-decode --sample-band): more evaluations, also finds an "
                        "SDF's small voids inside the solid")
    p.set_defaults(run=cmd_decode)

    p = sub.add_parser("eval", help="Chamfer distance (and colour PSNR when both are coloured) between a "
                                    "ground truth and a reconstruction")
    p.add_argument("ground_truth")
    p.add_argument("reconstruction")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--samples", type=int, default=100_000, help="surface samples per mesh (default 100000)")
    p.add_argument("--seed", type=int, default=0, help="sampling seed (default 0)")
    p.set_defaults(run=cmd_eval)
    return parser


def _add_encode_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--field", choices=("sdf", "udf", "auto"), default="auto",
                   help="signed (watertight shapes), unsigned (anything) or auto (SDF when closed, nearly manifold)")
    p.add_argument("--width", type=int, default=None,
                   help=f"hidden layer width: sets the rate (default {DEFAULT_WIDTH})")
    p.add_argument("--bits", type=int, default=8, help="quantization bit width (default 8)")
    p.add_argument("--frequencies", type=int, default=NUM_FREQUENCIES, metavar="L",
                   help=f"positional-encoding frequencies of the geometry network (default {NUM_FREQUENCIES})")
    p.add_argument("--frequency-base", type=float, default=FREQUENCY_BASE, metavar="BETA",
                   help=f"their spacing: frequencies pi * BETA^k, 1 <= BETA <= 2 (default {FREQUENCY_BASE}; "
                        "the paper's encoding: --frequencies 16 --frequency-base 1.4)")
    p.add_argument("--truncation", type=float, default=None, metavar="D",
                   help=f"d*, the distance beyond which the field is truncated, in the unit ball, "
                        f"{MIN_TRUNCATION}..{MAX_TRUNCATION} (default {TRUNCATION['sdf']} for an SDF, "
                        f"{TRUNCATION['udf']} for a UDF; the paper's 0.1 decodes with ~10%% fewer evaluations)")
    p.add_argument("--preset", choices=("fast", "paper"), default="fast", help="training schedule")
    p.add_argument("--epochs", type=int, default=None, help="override the preset's epoch count")
    p.add_argument("--seed", type=int, default=0, help="random seed (same bytes for the same seed on a given device)")
    p.add_argument("--device", choices=DEVICE_CHOICES, default="auto",
                   help="train on the CPU, a CUDA GPU, or auto (CUDA when torch sees one; default)")
    p.add_argument("--threads", type=int, default=None,
                   help=f"CPU torch threads (default: the CPUs available, at most {MAX_TORCH_THREADS})")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_color_options(p: argparse.ArgumentParser) -> None:
    group = p.add_mutually_exclusive_group()
    group.add_argument("--color", dest="color", action="store_const", const="on", default="auto",
                       help="encode the input's colours (an error if it has none or they are unusable); by "
                            "default colour is encoded when the input has usable colours")
    group.add_argument("--no-color", dest="color", action="store_const", const="off", help="geometry only")
    p.add_argument("--color-width", type=int, default=None,
                   help=f"hidden layer width of the colour network (default {COLOR_WIDTH})")
    p.add_argument("--color-bits", type=int, default=None,
                   help=f"quantization bit width of the colour network (default {DEFAULT_BITS}; "
                        f"{TARGET_COLOR_BITS} when --target-bytes sizes it)")
    p.add_argument("--color-resolution", type=int, default=COLOR_RESOLUTION,
                   help=f"grid resolution of the decoded surface the colour is fitted on (default {COLOR_RESOLUTION})")
    p.add_argument("--color-frequencies", type=int, default=COLOR_NUM_FREQUENCIES, metavar="L",
                   help=f"positional-encoding frequencies of the colour network (default {COLOR_NUM_FREQUENCIES})")
    p.add_argument("--color-epochs", type=int, default=None, help="override the colour schedule's epoch count")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args))
    except NfcError as e:
        message = e.message
    except OSError as e:
        message = f"{e.filename}: {e.strerror}" if e.filename and e.strerror else str(e)
    except MemoryError:
        message = "out of memory"
    except KeyboardInterrupt:
        message = "interrupted"
    sys.stderr.write(f"nfc: error: {message}\n")
    return EXIT_ERROR


if __name__ == "__main__":
    sys.exit(main())
