#!/usr/bin/env python3
"""Rate–distortion benchmark: nfc against Draco (decimation envelope) and G-PCC on real shapes.

For each shape: the sampling floor, nfc at every requested width and preset (bytes, CD, encode
seconds), Draco as the lower envelope over quadric decimation x quantization (`draco_encoder -qp
6..14 -cl 10` on `fast-simplification` decimations), and the G-PCC figures of
../shared/baselines/baselines.csv. Prints markdown tables, writes bench/out/rd_<shape>.csv and a
log-log plot bench/plots/rd_<shape>.png. Metric: ../shared/docs/metrics.md (nfencode.metrics).
Shapes that ../shared/baselines has no G-PCC figures for (the range scans) get them from a TMC13
binary when --tmc3 names one (`run_gpcc_cloud`; the shared figures were measured with TMC13 v23).

    .venv/bin/python bench/rd.py --shapes bunny armadillo --widths 16 24 32 48 64 96 --presets fast paper
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nfencode.bitstream import read_nfc
from nfencode.config import NUM_FREQUENCIES
from nfencode.encoder import EncodeConfig, compress
from nfencode.io import Shape, load_shape, save_mesh, save_points
from nfencode.metrics import chamfer_distance, sampling_floor

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
NFC_DECODE = REPO / "build" / "samples" / "nfc-decode"

# name -> (path under shared/data, field, name in shared/baselines)
SHAPES: dict[str, tuple[str, str, str]] = {
    "bunny": ("stanford/bun_zipper.ply.gz", "sdf", "bunny"),
    "armadillo": ("stanford/armadillo_remeshed_odedstein.obj.gz", "sdf", "armadillo"),
    "dragon": ("stanford/dragon_vrip_res3.ply.gz", "sdf", "dragon_res3"),
    "spot": ("misc/spot.obj.gz", "sdf", "spot"),
    "tshirt": ("garments/TShirtNoCoat.obj.gz", "udf", "TShirtNoCoat"),
    "shirt": ("garments/ShirtNoCoat1.obj.gz", "udf", "ShirtNoCoat1"),
    "longcoat": ("garments/LongCoat1.obj.gz", "udf", "LongCoat1"),
    "pants": ("garments/Pants1.obj.gz", "udf", "Pants1"),
    "skirt": ("garments/skirt_2.obj.gz", "udf", "skirt_2"),
    "bunny-udf": ("stanford/bun_zipper.ply.gz", "udf", "bunny"),
    "dragon-udf": ("stanford/dragon_vrip_res3.ply.gz", "udf", "dragon_res3"),
    "happy": ("stanford/happy_vrip_res3.ply.gz", "sdf", "happy_res3"),
    "happy-udf": ("stanford/happy_vrip_res3.ply.gz", "udf", "happy_res3"),
    # The ten raw range scans, aligned by bun.conf and merged: a 362k-point cloud with no faces.
    "bunny-scans": ("stanford/bunny_scans/bun.conf", "udf", "bunny_scans"),
    # Meshes with holes that `--field auto` finds closed below width 64 (config.AUTO_UDF_WIDTH_WITH_HOLES),
    # and demosthenes, whose open base it no longer does: either field.
    "demosthenes": ("misc/demosthenes-low-res.obj.gz", "sdf", "demosthenes"),
    "demosthenes-udf": ("misc/demosthenes-low-res.obj.gz", "udf", "demosthenes"),
    "suzanne": ("misc/suzanne.obj.gz", "sdf", "suzanne"),
    "suzanne-udf": ("misc/suzanne.obj.gz", "udf", "suzanne"),
    # Closed meshes the encoder's defaults were not chosen on (no baselines in ../shared/baselines).
    "nefertiti": ("misc/nefertiti-lowres.obj.gz", "sdf", "nefertiti"),
    "igea": ("misc/igea_tris.ply.gz", "sdf", "igea"),
}
DRACO_CLOUD_POINTS = (500, 1000, 2000, 5000, 10000, 20000)
DRACO_FACES = (500, 1000, 2000, 5000, 10000)
DRACO_QP = range(6, 15)
GPCC_BITS = 10  # the cloud on a 10-bit voxel grid, as the shared "-surf10" / "vox10" rows
GPCC_OCTREE_SCALES = range(0, 8)  # positionQuantizationScale 1 / 2^k
GPCC_TRISOUP_NODES = (2, 3, 4, 5, 6)  # trisoupNodeSizeLog2
SEED = 0


@dataclass
class Point:
    codec: str
    setting: str
    bytes: int
    cd: float
    seconds: float = float("nan")
    surface: str = ""  # decoded mesh: boundary edges, components, largest floating component


def surface_report(mesh: Shape) -> str:
    """Boundary edges (used by one triangle), edges used by more than two, connected components,
    and the largest component other than the biggest one as a share of the surface area: the
    holes, double sheets and floating fragments UDF meshing is known for."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    if len(f) == 0:
        return "empty"
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, uses = np.unique(edges, axis=0, return_counts=True)
    n, label = connected_components(coo_matrix((np.ones(len(unique)), tuple(unique.T)),
                                               shape=(len(v), len(v))))
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    shares = np.bincount(label[f[:, 0]], weights=area, minlength=n)
    shares = np.sort(shares[np.unique(label[f[:, 0]])])[::-1] / area.sum()  # unused vertices: none
    floating = shares[1] if len(shares) > 1 else 0.0
    return (f"{int((uses == 1).sum())} bnd, {int((uses > 2).sum())} non-manifold, "
            f"{len(shares)} comp., largest floating {100 * floating:.2f}%")


def setting_name(preset: str, width: int, frequencies: int) -> str:
    """`fast w32` for format 1.0's 16 frequencies (the earlier rows), `fast L8 w32` otherwise."""
    return f"{preset} w{width}" if frequencies == 16 else f"{preset} L{frequencies} w{width}"


def encode_config(field: str, width: int, preset: str, frequencies: int) -> EncodeConfig:
    """The encoder's defaults at `frequencies`; at 16, format 1.0's whole encoding (β = 1.4, d* =
    0.1, the fast preset's 60 epochs of then), so that `fast w32` rows stay format 1.0's."""
    format_1_0 = ({"frequency_base": 1.4, "truncation": 0.1, "epochs": 60 if preset == "fast" else None}
                  if frequencies == 16 else {})
    return EncodeConfig(field=field, width=width, frequencies=frequencies, preset=preset, seed=SEED, quiet=True,
                        **format_1_0)


def run_nfc(gt: Shape, field: str, width: int, preset: str, frequencies: int, resolution: int,
            keep: Path) -> Point:
    """Encodes, keeps the file as keep/<shape>_<setting>.nfc (bench/decode.py input), decodes it
    with libnfdecode (nfc-decode, CPU path: the same mesh as Vulkan) and measures CD."""
    t0 = time.perf_counter()
    result = compress(gt, encode_config(field, width, preset, frequencies))
    seconds = time.perf_counter() - t0
    keep.mkdir(parents=True, exist_ok=True)
    setting = setting_name(preset, width, frequencies)
    path = keep / f"{gt.name}_{setting.replace(' ', '_')}.nfc"
    path.write_bytes(result.data)
    return measure_nfc(gt, path, setting, resolution, seconds)


def measure_nfc(gt: Shape, path: Path, setting: str, resolution: int, seconds: float) -> Point:
    """Decodes a kept .nfc with nfc-decode (CPU path) and measures CD and the decoded surface."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([str(NFC_DECODE), str(path), "-o", f"{tmp}/mesh.ply", "--resolution",
                        str(resolution), "--device", "cpu"], check=True, capture_output=True)
        mesh = load_shape(f"{tmp}/mesh.ply")
        cd = chamfer_distance(gt, mesh, seed=SEED)
    return Point("nfc", setting, path.stat().st_size, cd, seconds, surface_report(mesh))


def run_draco(gt: Shape) -> list[Point]:
    import fast_simplification

    points: list[Point] = []
    with tempfile.TemporaryDirectory() as tmp:
        for target in DRACO_FACES:
            if target >= len(gt.faces):
                continue
            v, f = fast_simplification.simplify(gt.vertices.astype(np.float32),
                                                gt.faces.astype(np.int32),
                                                target_reduction=1.0 - target / len(gt.faces))
            src = Path(tmp) / "in.ply"
            save_mesh(str(src), v.astype(np.float64), f.astype(np.int64))
            for qp in DRACO_QP:
                drc, dec = Path(tmp) / "out.drc", Path(tmp) / "out.ply"
                subprocess.run(["draco_encoder", "-i", src, "-o", drc, "-qp", str(qp), "-cl", "10"],
                               check=True, capture_output=True)
                subprocess.run(["draco_decoder", "-i", drc, "-o", dec], check=True,
                               capture_output=True)
                rec = load_shape(str(dec))
                points.append(Point("draco", f"dec{target} qp{qp}", drc.stat().st_size,
                                    chamfer_distance(gt, rec, seed=SEED)))
    return points


def run_draco_cloud(gt: Shape) -> list[Point]:
    """Draco's point-cloud mode on random subsets of the cloud (the way it reaches a few KB) at
    every quantization: the point-cloud counterpart of the decimation envelope."""
    rng = np.random.default_rng(SEED)
    points: list[Point] = []
    with tempfile.TemporaryDirectory() as tmp:
        for count in DRACO_CLOUD_POINTS:
            src = Path(tmp) / "in.ply"
            subset = gt.vertices[rng.choice(len(gt.vertices), size=min(count, len(gt.vertices)),
                                            replace=False)]
            save_points(str(src), subset)
            for qp in DRACO_QP:
                drc, dec = Path(tmp) / "out.drc", Path(tmp) / "out.ply"
                subprocess.run(["draco_encoder", "-point_cloud", "-i", src, "-o", drc, "-qp",
                                str(qp), "-cl", "10"], check=True, capture_output=True)
                subprocess.run(["draco_decoder", "-i", drc, "-o", dec], check=True,
                               capture_output=True)
                points.append(Point("draco", f"pc{count} qp{qp}", drc.stat().st_size,
                                    chamfer_distance(gt, load_shape(str(dec)), seed=SEED)))
    return points


def run_gpcc_cloud(gt: Shape, tmc3: Path) -> list[Point]:
    """MPEG G-PCC (TMC13) on a point cloud, geometry only, with the common test conditions'
    geometry tools (planar mode, neighbour availability 2^8, intra prediction up to 2^6 nodes):
    octree at position scales 1 .. 1/128, and trisoup (scale 1) at node sizes 2^2 .. 2^6, which
    reconstructs a surface and samples it. The cloud is first put on a GPCC_BITS voxel grid over
    its bounding box (the offset and scale, 16 bytes, are not counted); decoded points are mapped
    back to the original frame."""
    lo = gt.vertices.min(axis=0)
    extent = float((gt.vertices.max(axis=0) - lo).max())
    top = (1 << GPCC_BITS) - 1
    settings = [(f"octree s=1/{1 << k}", ["--trisoupNodeSizeLog2=0",
                                          f"--positionQuantizationScale={1 / (1 << k)}"])
                for k in GPCC_OCTREE_SCALES]
    settings += [(f"trisoup node={n}", [f"--trisoupNodeSizeLog2={n}",
                                        "--positionQuantizationScale=1",
                                        "--trisoupQuantizationBits=2",
                                        "--trisoupCentroidResidualEnabled=1",
                                        "--trisoupFaceVertexEnabled=1",
                                        "--trisoupImprovedEncoderEnabled=1"])
                 for n in GPCC_TRISOUP_NODES]
    common = ["--mergeDuplicatedPoints=1", "--planarEnabled=1", "--neighbourAvailBoundaryLog2=8",
              "--intra_pred_max_node_size_log2=6", "--disableAttributeCoding=1"]
    points: list[Point] = []
    with tempfile.TemporaryDirectory() as tmp:
        src, stream, rec = Path(tmp) / "in.ply", Path(tmp) / "out.bin", Path(tmp) / "rec.ply"
        save_points(str(src), np.round((gt.vertices - lo) / extent * top))
        for name, flags in settings:
            subprocess.run([str(tmc3), "--mode=0", f"--uncompressedDataPath={src}",
                            f"--compressedStreamPath={stream}", *common, *flags],
                           check=True, capture_output=True)
            subprocess.run([str(tmc3), "--mode=1", f"--compressedStreamPath={stream}",
                            f"--reconstructedDataPath={rec}"], check=True, capture_output=True)
            decoded = load_shape(str(rec))
            decoded.vertices = decoded.vertices / top * extent + lo
            points.append(Point("gpcc", f"{name} ({GPCC_BITS}-bit)", stream.stat().st_size,
                                chamfer_distance(gt, decoded, seed=SEED)))
    return points


def shared_baseline(baseline_name: str, codec: str) -> list[Point]:
    """Rows of ../shared/baselines/baselines.csv (same metric, decoded surface vs ground truth)."""
    rows = csv.DictReader(open(SHARED / "baselines" / "baselines.csv"))
    return [Point(codec, f"{r['mode']} {r['param']} (shared)", int(r["bytes"]),
                  float(r["cd_surf"]))
            for r in rows
            if r["shape"] == baseline_name and r["codec"] == codec and r["cd_surf"]]


def load_csv(path: Path) -> tuple[list[Point], list[Point], list[Point]]:
    """nfc, own-Draco and own-G-PCC points of an earlier run (to re-render tables without
    re-encoding)."""
    ours, draco, gpcc = [], [], []
    for r in csv.DictReader(open(path)):
        p = Point(r["codec"], r["setting"], int(r["bytes"]), float(r["cd"]), float(r["encode_s"]),
                  r.get("surface", ""))
        if r["codec"] == "nfc":
            ours.append(p)
        elif "(shared)" not in r["setting"]:
            {"draco": draco, "gpcc": gpcc}[r["codec"]].append(p)
    return ours, draco, gpcc


def lower_envelope(points: list[Point]) -> list[Point]:
    """Pareto front: the points no other point beats in both bytes and CD, by increasing bytes."""
    front: list[Point] = []
    for p in sorted(points, key=lambda p: (p.bytes, p.cd)):
        if not front or p.cd < front[-1].cd:
            front.append(p)
    return front


def interpolate_cd(envelope: list[Point], size: int) -> float | None:
    """CD of an envelope at `size` bytes, linear in log(bytes)-log(CD). Above its largest file the
    envelope's best CD (more bytes never hurt); None below its smallest file (it cannot get there)."""
    xs = np.log([p.bytes for p in envelope])
    if not len(xs) or np.log(size) < xs[0]:
        return None
    return float(np.exp(np.interp(np.log(size), xs, np.log([p.cd for p in envelope]))))


def verdict(cd: float, draco: float | None, gpcc: float | None, has_gpcc: bool = True) -> str:
    """has_gpcc=False: no G-PCC figure for the shape (the range scans without --tmc3)."""
    pairs = (("Draco", draco), ("G-PCC", gpcc)) if has_gpcc else (("Draco", draco),)
    wins = [name + (" (none this small)" if other is None else "")
            for name, other in pairs if other is None or cd < other]
    verdict = "nfc beats " + " and ".join(wins) if wins else "baselines win"
    return verdict if has_gpcc else verdict + "; no G-PCC figures"


def fmt(x: float | None) -> str:
    return "—" if x is None or np.isnan(x) else f"{x:.4g}"


def plot(shape: str, floor: float, ours: list[Point], draco: list[Point], gpcc: list[Point],
         path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    curves: dict[str, list[Point]] = {}  # a curve per setting without its width: "fast", "fast L8", ...
    for p in ours:
        if not np.isnan(p.cd):
            curves.setdefault(p.setting.rsplit(" w", 1)[0], []).append(p)
    for name, pts in sorted(curves.items()):
        pts.sort(key=lambda p: p.bytes)
        marker = "s--" if name.startswith("paper") else "o-"
        preset, _, frequencies = name.partition(" L")  # "fast" is format 1.0's encoding (setting_name)
        encoding = f"L = {frequencies}" if frequencies else "format 1.0's encoding"
        ax.plot([p.bytes for p in pts], [p.cd for p in pts], marker, label=f"nfc ({preset}, {encoding})")
    for name, pts in (("Draco envelope", lower_envelope(draco)),
                      ("G-PCC envelope", lower_envelope(gpcc))):
        if pts:
            ax.plot([p.bytes for p in pts], [p.cd for p in pts], ".-", label=name, alpha=0.8)
    ax.axhline(floor, color="gray", lw=0.8, ls=":", label="sampling floor")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(200, 40000)
    ax.set_ylim(0.9 * floor, 0.03)
    ax.set_xlabel("bytes")
    ax.set_ylabel("Chamfer distance (unit ball)")
    ax.set_title(shape)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", nargs="+", default=list(SHAPES), choices=list(SHAPES))
    parser.add_argument("--widths", nargs="+", type=int, default=[16, 24, 32, 48, 64, 96])
    parser.add_argument("--presets", nargs="+", default=["fast", "paper"],
                        choices=["fast", "paper"])
    parser.add_argument("--frequencies", type=int, default=NUM_FREQUENCIES,
                        help=f"L of the geometry encoding (default {NUM_FREQUENCIES}, with the encoder's other "
                             "defaults; 16: format 1.0's encoding, β 1.4, d* 0.1 and 60 fast epochs)")
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--no-draco", action="store_true", help="skip the Draco runs")
    parser.add_argument("--tmc3", type=Path,
                        help="a TMC13 (G-PCC) binary: measure G-PCC on point clouds that "
                             "../shared/baselines has no figures for")
    parser.add_argument("--append", action="store_true",
                        help="add to the nfc/Draco points of bench/out/rd_<shape>.csv")
    parser.add_argument("--from-csv", action="store_true",
                        help="no encoding: re-render tables and plots from bench/out/rd_<shape>.csv")
    parser.add_argument("--decode-only", action="store_true",
                        help="no encoding: decode the kept bench/out/nfc files again (after a "
                             "decoder change); encode seconds come from bench/out/rd_<shape>.csv")
    args = parser.parse_args()

    out_dir = REPO / "bench" / "out"
    out_dir.mkdir(parents=True, exist_ok=True)
    for shape in args.shapes:
        rel, field, baseline_name = SHAPES[shape]
        gt = load_shape(str(SHARED / "data" / rel))
        gt.name = shape
        floor = sampling_floor(gt, seed=SEED)
        csv_path = out_dir / f"rd_{shape}.csv"
        reuse = (args.from_csv or args.append or args.decode_only) and csv_path.exists()
        ours, draco, own_gpcc = load_csv(csv_path) if reuse else ([], [], [])
        if args.decode_only:
            encode_seconds = {p.setting: p.seconds for p in ours}
            names = [setting_name(p, w, args.frequencies) for p in args.presets for w in args.widths]
            ours = [measure_nfc(gt, out_dir / "nfc" / f"{shape}_{n.replace(' ', '_')}.nfc", n,
                                args.resolution, encode_seconds.get(n, float("nan")))
                    for n in names if (out_dir / "nfc" / f"{shape}_{n.replace(' ', '_')}.nfc").exists()]
        elif not args.from_csv:
            ours += [run_nfc(gt, field, w, p, args.frequencies, args.resolution, out_dir / "nfc")
                     for p in args.presets for w in args.widths]
        if not args.from_csv and not args.no_draco and not draco:
            draco = run_draco(gt) if gt.faces is not None else run_draco_cloud(gt)
        # The Draco envelope takes our own decimation runs and the shared measurements together:
        # the stronger baseline at every size.
        draco_all = draco + shared_baseline(baseline_name, "draco")
        gpcc = shared_baseline(baseline_name, "gpcc")
        if not gpcc and not own_gpcc and args.tmc3 and gt.faces is None and not args.from_csv:
            own_gpcc = run_gpcc_cloud(gt, args.tmc3)
        gpcc += own_gpcc
        draco_env, gpcc_env = lower_envelope(draco_all), lower_envelope(gpcc)

        print(f"\n### {shape} ({rel}, {field.upper()}; floor {floor:.4g}, seed {SEED}; "
              f"ground truth: {surface_report(gt) if gt.faces is not None else 'point cloud'})\n")
        print("| setting | bytes | CD | excess | Draco env. @bytes | G-PCC env. @bytes | "
              "encode s | verdict | decoded surface |")
        print("|---|---:|---:|---:|---:|---:|---:|---|---|")
        for p in ours:
            d, g = interpolate_cd(draco_env, p.bytes), interpolate_cd(gpcc_env, p.bytes)
            v = "—" if np.isnan(p.cd) else verdict(p.cd, d, g, bool(gpcc))
            print(f"| {p.setting} | {p.bytes} | {fmt(p.cd)} | {fmt(p.cd - floor)} | {fmt(d)} | "
                  f"{fmt(g)} | {p.seconds:.1f} | {v} | {p.surface} |")
        with open(csv_path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["codec", "setting", "bytes", "cd", "encode_s", "floor", "surface"])
            for p in ours + draco_all + gpcc:
                w.writerow([p.codec, p.setting, p.bytes, f"{p.cd:.6g}", f"{p.seconds:.2f}",
                            f"{floor:.6g}", p.surface])
        plot(shape, floor, ours, draco_all, gpcc, REPO / "bench" / "plots" / f"rd_{shape}.png")


if __name__ == "__main__":
    main()
