"""The colour encoder end to end (a real coloured cloud, a tiny schedule), its CLI, and colour PSNR."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import plyfile
import pytest
from scipy.spatial import cKDTree
from conftest import SHARED_DATA
from test_cli_errors import nfc

from nfencode import config
from nfencode.bitstream import TAG_GEOM, read_nfc
from nfencode.color import color_loss
from nfencode.encoder import EncodeConfig, compress
from nfencode.errors import InputError
from nfencode.io import Shape, load_shape, save_points
from nfencode.metrics import color_psnr, color_psnr_directions, shape_color_psnr
from nfencode.normalize import to_unit, unit_ball_frame
from nfencode.reference import color_bytes, decode_points, extract_unit_mesh, sample_points

MILK = SHARED_DATA / "colored" / "pcl_milk_color.ply.gz"
VECTORS = Path(__file__).resolve().parents[1] / "vectors"
GEOMETRY = VECTORS / "v1_1_milk_udf_w16_c16.nfc"  # its GEOM is reused; its colour is refitted
TINY = {"color_width": 16, "color_resolution": 64, "color_epochs": 20, "threads": 2, "quiet": True}
# A small schedule for the tests: fewer points per epoch, one QAT epoch.
TEST_SCHEDULE = dataclasses.replace(config.COLOR_SCHEDULE, points=10_000, validation_points=5_000, qat_epochs=1)

pytestmark = pytest.mark.skipif(not MILK.exists(), reason="shared data not available")


@pytest.fixture(scope="module", autouse=True)
def small_schedule() -> Iterator[None]:
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(config, "COLOR_SCHEDULE", TEST_SCHEDULE)
        yield


@pytest.fixture(scope="module")
def milk() -> Shape:
    return load_shape(MILK)


@pytest.fixture(scope="module")
def encoded(milk: Shape) -> bytes:
    return compress(milk, EncodeConfig(color="on", **TINY), geometry=GEOMETRY.read_bytes()).data  # type: ignore[arg-type]


def test_color_is_fitted_on_the_reused_geometry(encoded: bytes) -> None:
    f, golden = read_nfc(encoded), read_nfc(GEOMETRY.read_bytes())
    assert (encoded[5], f.minor) == (1, 1) and f.color is not None
    assert encoded[16:16 + f.chunk_bytes[TAG_GEOM]] == GEOMETRY.read_bytes()[16:16 + golden.chunk_bytes[TAG_GEOM]]
    net = f.color.network
    assert (net.num_frequencies, net.out_features, net.bits, net.omega0) == (8, [16, 16, 16, 3], 8, 20.0)


def test_fits_sharing_one_colour_surface_are_the_fits_on_fresh_ones(milk: Shape, encoded: bytes) -> None:
    """A rate search fits several colour widths on one geometry: the surface it decodes and matches
    once (ShapeWork) gives each fit the bytes of a fit that built its own, in any order; another
    resolution builds its own."""
    from nfencode.encoder import ShapeWork

    cfg = EncodeConfig(color="on", **TINY)  # type: ignore[arg-type]
    work = ShapeWork()
    narrow = dataclasses.replace(cfg, color_width=8)
    coarse = dataclasses.replace(narrow, color_resolution=32)
    for c, fresh in [(narrow, None), (cfg, encoded), (coarse, None), (narrow, None)]:
        shared = compress(milk, c, GEOMETRY.read_bytes(), work).data
        assert shared == (fresh or compress(milk, c, GEOMETRY.read_bytes()).data)
    assert len(work._surfaces) == 2
    # fit_color refuses a surface built for another resolution or seed.
    import torch

    from nfencode.color import ColorOptions, fit_color

    surface = next(iter(work._surfaces.values()))
    with pytest.raises(ValueError, match="resolution 64 and seed 0 given to a fit at 32"):
        fit_color(read_nfc(GEOMETRY.read_bytes()), milk, ColorOptions(resolution=32), torch.device("cpu"), surface)


def test_decoded_colour_beats_a_constant_colour(milk: Shape, encoded: bytes) -> None:
    """PSNR (metrics.md) of the decoded points' colours against the best constant colour (the mean)
    on the same points: a network that learnt nothing scores about the same."""
    assert milk.colors is not None
    f = read_nfc(encoded)
    points, colors = decode_points(f, extract_unit_mesh(f, 64), len(milk.vertices), 0)
    assert colors is not None
    center, scale = unit_ball_frame(milk.vertices)
    gt, rec = to_unit(milk.vertices, center, scale), to_unit(points, center, scale)
    ours = color_psnr(gt, milk.colors, rec, color_bytes(colors))
    mean = np.tile(np.rint(milk.colors.mean(axis=0)).astype(np.uint8), (len(rec), 1))
    constant = color_psnr(gt, milk.colors, rec, mean)
    assert ours > constant + 4.0, (ours, constant)


def test_color_modes(milk: Shape) -> None:
    geometry = GEOMETRY.read_bytes()
    off = compress(milk, EncodeConfig(color="off", **TINY), geometry=geometry)  # type: ignore[arg-type]
    assert off.color is None and off.data[5] == 0 and read_nfc(off.data).color is None
    plain = Shape(milk.vertices, None, None, "plain")
    auto = compress(plain, EncodeConfig(**TINY), geometry=geometry)  # type: ignore[arg-type]
    assert auto.color is None and auto.data[5] == 0
    with pytest.raises(InputError, match="no \\(usable\\) colours"):
        compress(plain, EncodeConfig(color="on", **TINY), geometry=geometry)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="colour width"):
        compress(milk, EncodeConfig(color="on", **{**TINY, "color_width": 0}), geometry=geometry)  # type: ignore[arg-type]


def test_wide_colour_networks_learn_slower_and_longer() -> None:
    schedule = config.COLOR_SCHEDULE
    assert schedule.lr_at(16) == schedule.lr_at(schedule.lr_width) == schedule.lr
    assert schedule.lr_at(2 * schedule.lr_width) == pytest.approx(schedule.lr / 2)
    assert schedule.epochs_at(16) == schedule.epochs_at(schedule.epochs_width) == schedule.epochs
    assert schedule.epochs_at(2 * schedule.epochs_width) == 2 * schedule.epochs


def test_training_pairs_come_from_both_sides_of_the_metric(milk: Shape) -> None:
    """Pairs for both terms of the colour PSNR: decoded-surface points with the colour of their
    nearest ground-truth point (rec -> gt), then ground-truth points' colours at decoded points near
    them (gt -> rec), in the share config.COLOR_GROUND_TRUTH_SIDE."""
    import torch

    from nfencode.color import _SurfaceColors
    from nfencode.model import Siren
    from nfencode.reference import frame_of

    assert milk.colors is not None
    f = read_nfc(GEOMETRY.read_bytes())
    mesh = extract_unit_mesh(f, 64)
    surface = _SurfaceColors(mesh, milk, f, np.random.default_rng(0), torch.device("cpu"))
    assert surface.seen_at.shape == (config.COLOR_DECODED_CLOUDS, len(milk.vertices), 3)
    encoded, targets = surface.draw(Siren(8, "sigmoid", outputs=3, num_frequencies=0), 1000)
    points, colours = encoded.numpy(), (targets.numpy() + 1.0) * 127.5  # L = 0: the encoding is u itself
    assert points.shape == (1000, 3)
    truth = to_unit(milk.vertices, *frame_of(f.geometry))
    truth_tree, surface_tree = cKDTree(truth), cKDTree(sample_points(mesh.vertices, mesh.faces, 200_000, 1))
    assert surface_tree.query(points, k=1)[0].max() < 0.01  # every point lies on the decoded surface
    rec_side = 1000 - round(1000 * config.COLOR_GROUND_TRUTH_SIDE)
    _, nearest = truth_tree.query(points[:rec_side], k=1)
    np.testing.assert_allclose(colours[:rec_side], milk.colors[nearest], atol=1e-3)
    tri = mesh.vertices[mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    spacing = np.sqrt(area / len(truth))  # of the decoder-like clouds
    for p, c in zip(points[rec_side:], colours[rec_side:]):
        # a ground-truth point of this colour whose decoded neighbour p can be: no farther from p than
        # from the surface plus a few of the clouds' spacings
        same = np.flatnonzero(np.all(np.abs(milk.colors - c) < 1e-3, axis=1))
        gap = np.linalg.norm(truth[same] - p, axis=1) - surface_tree.query(truth[same], k=1)[0]
        assert gap.min() < 3 * spacing, (gap.min(), spacing)


def test_color_loss_is_the_error_of_2_sigmoid_minus_1() -> None:
    import torch

    pred, target = torch.tensor([[0.5, 1.0, 0.0]]), torch.tensor([[0.0, 0.0, -1.0]])
    assert float(color_loss(pred, target)) == pytest.approx((0.0 + 1.0 + 0.0) / 3)


def test_shape_color_psnr_follows_metrics_md() -> None:
    """Each direction: nearest point's colour, MSE over points and channels, peak 255; the mean."""
    gt = Shape(np.array([[0.0, 0, 0], [1, 0, 0]]), None, np.array([[10, 20, 30], [40, 50, 60]], np.uint8), "gt")
    rec = Shape(np.array([[0.1, 0, 0]]), None, np.array([[10, 20, 40]], np.uint8), "rec")
    forward = 10 * np.log10(255**2 / ((0 + 0 + 100 + 900 + 900 + 400) / 6))  # both gt points -> the one rec point
    backward = 10 * np.log10(255**2 / (100 / 3))  # the rec point -> gt point 0
    assert shape_color_psnr(gt, rec) == pytest.approx(0.5 * (forward + backward))
    assert color_psnr_directions(gt.vertices, gt.colors, rec.vertices, rec.colors) == pytest.approx((forward, backward))
    assert shape_color_psnr(gt, Shape(rec.vertices, None, None, "plain")) is None


# ---------------------------------------------------------------------------------------------
# CLI


def test_cli_encode_info_decode_eval(tmp_path: Path) -> None:
    out = tmp_path / "milk.nfc"
    r = nfc("encode", MILK, "-o", out, "--geometry", GEOMETRY, "--color-width", "8", "--color-resolution", "64",
            "--color-epochs", "4", "--threads", "2", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "colour: width 8, 8 bits" in r.stdout and "with colour" in r.stdout
    info = nfc("info", out, "--json", cwd=tmp_path)
    color = json.loads(info.stdout)["color"]
    assert color["width"] == 8 and color["bits"] == 8 and color["num_frequencies"] == 8
    assert color["parameters"] == 51 * 8 + 8 + 2 * (8 * 8 + 8) + 8 * 3 + 3  # three sine layers
    assert color["omega0"] == 20.0
    assert color["bytes"] + json.loads(info.stdout)["geometry_bytes"] + 16 == out.stat().st_size
    text = nfc("info", out, cwd=tmp_path).stdout
    assert "colour      rgb, width 8, 8 frequencies, omega0 20," in text and f"colr chunk {color['bytes']} bytes" in text

    points = tmp_path / "points.ply"
    r = nfc("decode", out, "-o", points, "--points", "20000", "--resolution", "64", cwd=tmp_path)
    assert r.returncode == 0 and "with colour" in r.stdout
    header = points.read_bytes().split(b"end_header")[0].decode()
    assert "property uchar red" in header
    mesh = tmp_path / "mesh.ply"
    assert nfc("decode", out, "-o", mesh, "--resolution", "48", cwd=tmp_path).returncode == 0
    assert "red" in (plyfile.PlyData.read(str(mesh))["vertex"].data.dtype.names or ())

    r = nfc("eval", MILK, points, "--json", "--samples", "5000", cwd=tmp_path)
    psnr = json.loads(r.stdout)["color_psnr"]
    assert r.returncode == 0 and 10.0 < psnr < 60.0
    assert "PSNR" in nfc("eval", MILK, points, "--samples", "5000", cwd=tmp_path).stdout
    assert json.loads(nfc("eval", MILK, mesh, "--json", "--samples", "5000", cwd=tmp_path).stdout)["color_psnr"]
    geometry_only = nfc("decode", GEOMETRY, "-o", tmp_path / "g.ply", "--resolution", "32", cwd=tmp_path)
    assert geometry_only.returncode == 0


def bad_milk(tmp_path: Path) -> Path:
    """The milk cloud with one NaN colour channel value (float colours)."""
    shape = load_shape(MILK)
    assert shape.colors is not None
    data = np.empty(len(shape.vertices), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "f4"),
                                                 ("green", "f4"), ("blue", "f4")])
    for k, c in enumerate("xyz"):
        data[c] = shape.vertices[:, k]
    for k, c in enumerate(("red", "green", "blue")):
        data[c] = shape.colors[:, k] / 255.0
    data["green"][5] = np.nan
    path = tmp_path / "bad_milk.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(data, "vertex")]).write(str(path))
    return path


def test_cli_colour_errors_and_warnings(tmp_path: Path) -> None:
    bad = bad_milk(tmp_path)
    out = tmp_path / "o.nfc"
    r = nfc("encode", bad, "-o", out, "--geometry", GEOMETRY, "--color", "--quiet", cwd=tmp_path)
    assert r.returncode == 1 and r.stderr.count("\n") == 1
    assert r.stderr.startswith("nfc: error: ") and "not finite" in r.stderr and not out.exists()

    r = nfc("encode", bad, "-o", out, "--geometry", GEOMETRY, "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and r.stderr.count("\n") == 1 and r.stderr.startswith("nfc: warning: ")
    assert "not finite" in r.stderr and "no colour" in r.stdout and out.read_bytes()[5] == 0

    plain = tmp_path / "plain.ply"
    save_points(plain, load_shape(MILK).vertices)  # the cloud without its colours
    r = nfc("encode", plain, "-o", out, "--geometry", GEOMETRY, "--color", "--quiet", cwd=tmp_path)
    assert r.returncode == 1 and "colour requested but the input has no (usable) colours" in r.stderr
    assert r.stderr.count("\n") == 1

    r = nfc("encode", MILK, "-o", out, "--color", "--no-color", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    for flag, value in (("--color-width", "0"), ("--color-bits", "17"), ("--color-resolution", "4"),
                        ("--color-epochs", "0")):
        r = nfc("encode", MILK, "-o", out, flag, value, cwd=tmp_path)
        assert r.returncode == 1 and flag in r.stderr and r.stderr.count("\n") == 1, (flag, r.stderr)
