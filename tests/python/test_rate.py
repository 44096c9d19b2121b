"""Rate control (`nfc encode --target-bytes B`, nfencode.rate): never more than B bytes, the widest
network that fits, and what was chosen reported."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from conftest import SHARED_DATA
from nfencode import config, rate
from nfencode.bitstream import NfcFile, read_nfc, write_nfc
from nfencode.cli import main
from nfencode.errors import InputError
from nfencode.io import load_shape
from nfencode.metrics import file_chamfer_distance

BUNNY = SHARED_DATA / "stanford" / "bun_zipper_res2.ply.gz"


def synthetic(bytes_per_parameter: float):
    """An encoder whose files cost `bytes_per_parameter` at 8 bits (proportionally fewer bits)."""
    calls: list[tuple[int, int]] = []

    def encode(width: int, bits: int) -> bytes:
        calls.append((width, bits))
        return bytes(int(90 + bytes_per_parameter * bits / 8 * rate.parameters(width)))

    return encode, calls


@pytest.mark.parametrize("budget", [800, 1000, 1500, 3000, 5000, 8000, 12000, 20000])
@pytest.mark.parametrize("bytes_per_parameter", [0.55, 0.72, 0.95])  # easier and harder than the prior
def test_never_more_than_the_budget_and_the_widest_that_fits(budget: int, bytes_per_parameter: float) -> None:
    encode, calls = synthetic(bytes_per_parameter)
    data, choice = rate.choose(budget, 8, encode)
    assert len(data) <= budget
    assert len(calls) <= rate.MAX_ENCODES and [(a.width, a.bits) for a in choice.attempts] == calls
    if choice.bits == 8:  # one width more would not have fitted
        assert len(encode(choice.width + 1, 8)) > budget


def test_small_budgets_lower_the_bit_width_and_impossible_ones_are_one_line_errors() -> None:
    encode, _ = synthetic(0.72)
    # At L = 7 (the default) width 4 has 209 parameters: 240 B at 8 bits, 221 at 7, 202 at 6.
    assert rate.parameters(4) == 209
    data, choice = rate.choose(210, 8, encode)
    assert len(data) <= 210 and (choice.width, choice.bits) == (rate.MIN_WIDTH, 6)
    with pytest.raises(InputError, match="no file fits in 100 bytes"):
        rate.choose(100, 8, encode)


@pytest.mark.skipif(not BUNNY.exists(), reason="shared data not available")
@pytest.mark.parametrize("budget", [800, 2500])
def test_nfc_encode_target_bytes_on_a_real_scan(tmp_path: Path, budget: int, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    out = tmp_path / "b.nfc"
    code = main(["encode", str(BUNNY), "-o", str(out), "--target-bytes", str(budget), "--epochs", "3",
                 "--quiet", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out.stat().st_size <= budget and report["bytes"] == out.stat().st_size
    f = read_nfc(out.read_bytes())
    assert f.geometry.network.out_features[0] == report["width"] and f.geometry.network.bits == report["bits"]
    assert report["target_bytes"] == budget and 1 <= len(report["attempts"]) <= rate.MAX_ENCODES


@pytest.mark.parametrize("size", [rate.GEOMETRY, rate.NetworkSize(16), rate.color_size(1100), rate.color_size(0, 4)])
def test_size_models_give_the_widest_width_their_prediction_fits(size: rate.NetworkSize) -> None:
    for budget in (50, 300, 800, 1500, 4000, 12000, 20000):
        for bytes_per_parameter in (0.4, 0.9):
            width = size.width_for(budget, bytes_per_parameter)
            fits = [w for w in range(1, 400) if size.fixed_bytes + bytes_per_parameter * size.parameters(w) <= budget]
            assert width == (max(fits) if fits else 0), (budget, bytes_per_parameter)


def test_colour_networks_are_counted_as_the_file_holds_them() -> None:
    # three sine layers of W after 8 frequencies, three outputs (test_color's `nfc info` check)
    assert rate.color_size(0).parameters(8) == 51 * 8 + 8 + 2 * (8 * 8 + 8) + 8 * 3 + 3
    assert rate.color_size(1234).fixed_bytes == 1234 + rate.color_size(0).fixed_bytes


@pytest.mark.parametrize("budget", [1200, 1500, 2500, 4000, 8000, 12000, 20000])
def test_a_coloured_file_splits_the_budget_and_never_exceeds_it(budget: int) -> None:
    share = rate.geometry_budget(budget, 8, 6)
    low, high = (rate.predicted_bytes(rate.GEOMETRY, w, 8) for w in config.COLORED_GEOMETRY_WIDTHS)
    color_minimum = rate.predicted_bytes(rate.color_size(0), rate.MIN_WIDTH, 6)
    assert share == min(max(round(config.COLORED_GEOMETRY_SHARE * budget), low), high, budget - color_minimum)
    geometry, _ = rate.choose(share, 8, synthetic(0.72)[0])
    calls: list[tuple[int, int]] = []

    def encode_colour(width: int, bits: int) -> bytes:  # the colour's rate differs from the prior
        calls.append((width, bits))
        return bytes(len(geometry) + 61 + int(0.61 * bits / 6 * rate.color_size(0).parameters(width)))

    data, choice = rate.choose(budget, 6, encode_colour, rate.color_size(len(geometry)))
    assert len(data) <= budget and len(calls) <= rate.MAX_ENCODES
    if choice.bits == 6:
        assert len(encode_colour(choice.width + 1, 6)) > budget


def test_target_bytes_refuses_width_unreachable_and_non_positive_budgets(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shape = tmp_path / "t.obj"
    shape.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    assert main(["encode", str(shape), "-o", str(tmp_path / "x.nfc"), "--target-bytes", "900",
                 "--width", "16"]) == 1
    assert "not --width too" in capsys.readouterr().err
    # Unreachable: every try is too big (one epoch each: the sizes do not depend on training).
    assert main(["encode", str(shape), "-o", str(tmp_path / "x.nfc"), "--target-bytes", "10",
                 "--epochs", "1"]) == 1
    assert "no file fits in 10 bytes" in capsys.readouterr().err
    for bad in ("0", "-5"):
        assert main(["encode", str(shape), "-o", str(tmp_path / "x.nfc"), "--target-bytes", bad]) == 1
        assert "--target-bytes must be >= 1" in capsys.readouterr().err
    assert not (tmp_path / "x.nfc").exists()


def synthetic_distortion(floor: float = 0.007, gain: float = 0.3):
    """An encoder whose CD falls with the width as the measured curves do: floor + gain / width."""
    calls: list[int] = []

    def encode(width: int, bits: int) -> bytes:
        calls.append(width)
        return width.to_bytes(2, "little") + bytes(int(90 + 0.9 * bits / 8 * rate.parameters(width)))

    def estimate(data: bytes) -> float:
        return floor + gain / int.from_bytes(data[:2], "little")

    return encode, estimate, calls


@pytest.mark.parametrize("target", [0.0095, 0.012, 0.02, 0.05, 0.1])
def test_target_cd_is_met_by_the_narrowest_width_within_the_bracket(target: float) -> None:
    encode, estimate, calls = synthetic_distortion()
    data, choice = rate.choose_for_distortion(target, 8, encode, estimate)
    assert estimate(data) <= target and choice.cd == estimate(data)
    assert len(calls) <= rate.MAX_DISTORTION_ENCODES and [a.width for a in choice.attempts] == calls
    exact = next(w for w in range(rate.MIN_WIDTH, config.TARGET_CD_MAX_WIDTH + 1) if estimate(encode(w, 8)) <= target)
    assert exact <= choice.width <= max(exact, int(exact * rate.BRACKET_RATIO) + 1)


def test_target_cd_writes_the_smallest_passing_file_despite_noise_and_errors_when_unreachable() -> None:
    encode, estimate, _ = synthetic_distortion()
    noisy = {32: 0.0119, 16: 0.02, 23: 0.0115, 21: 0.013}  # not monotonic in the width; others fail
    data, choice = rate.choose_for_distortion(0.012, 8, encode, lambda d: noisy.get(int.from_bytes(d[:2], "little"), 1.0))
    assert choice.cd <= 0.012 and len(data) == min(a.bytes for a in choice.attempts if a.cd <= 0.012)
    assert [a.width for a in choice.attempts] == [32, 16, 23, 19, 21] and choice.width == 23
    with pytest.raises(InputError, match="no file reaches CD 0.005 up to width 128"):
        rate.choose_for_distortion(0.005, 8, encode, estimate)


@pytest.mark.skipif(not BUNNY.exists(), reason="shared data not available")
def test_nfc_encode_target_cd_on_a_real_scan(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    monkeypatch.setattr(config, "TARGET_CD_RESOLUTION", 64)
    out = tmp_path / "b.nfc"
    code = main(["encode", str(BUNNY), "-o", str(out), "--target-cd", "0.25", "--epochs", "3", "--quiet", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["target_cd"] == 0.25 and report["estimated_cd"] <= 0.25
    assert report["bytes"] == out.stat().st_size
    assert report["width"] == read_nfc(out.read_bytes()).geometry.network.out_features[0]
    assert any(a["width"] == report["width"] and a["cd"] == report["estimated_cd"] for a in report["attempts"])
    for argv, message in [(["--target-cd", "0.01", "--target-bytes", "900"], "give one target"),
                          (["--target-cd", "0.01", "--width", "16"], "not --width too"),
                          (["--target-cd", "-1"], "positive number"), (["--target-cd", "nan"], "positive number")]:
        assert main(["encode", str(BUNNY), "-o", str(tmp_path / "x.nfc"), *argv, "--quiet"]) != 0
        assert message in capsys.readouterr().err


MILK = SHARED_DATA / "colored" / "pcl_milk_color.ply.gz"
MILK_GEOMETRY = Path(__file__).resolve().parents[1] / "vectors" / "v1_1_milk_udf_w16_c16.nfc"


@pytest.mark.skipif(not MILK.exists(), reason="shared data not available")
def test_nfc_encode_target_bytes_bounds_a_coloured_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    monkeypatch.setattr(config, "COLOR_SCHEDULE", dataclasses.replace(
        config.COLOR_SCHEDULE, points=5_000, validation_points=2_000, qat_epochs=1))
    fast = ["--epochs", "10", "--color-epochs", "2", "--color-resolution", "64", "--threads", "2", "--quiet", "--json"]
    budget = 2600
    out = tmp_path / "milk.nfc"
    assert main(["encode", str(MILK), "-o", str(out), "--target-bytes", str(budget), *fast]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    f = read_nfc(out.read_bytes())
    assert out.stat().st_size == report["bytes"] <= budget and f.color is not None
    assert (report["color_width"], report["color_bits"]) == (f.color.network.out_features[0], config.TARGET_COLOR_BITS)
    assert report["width"] == f.geometry.network.out_features[0]
    geometry_bytes = out.stat().st_size - f.chunk_bytes["colr"]  # the file without its colour chunk
    assert geometry_bytes <= rate.geometry_budget(budget, 8, 6)
    assert any(a["width"] == report["width"] and a["bytes"] == geometry_bytes for a in report["attempts"])
    assert any(a["width"] == report["color_width"] and a["bytes"] == report["bytes"] for a in report["color_attempts"])

    # With --geometry only the colour is sized, on that geometry; --color-width is the search's.
    out2 = tmp_path / "milk2.nfc"
    assert main(["encode", str(MILK), "-o", str(out2), "--geometry", str(MILK_GEOMETRY), "--target-bytes", "3000",
                 "--color-bits", "7", *fast]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    f2 = read_nfc(out2.read_bytes())
    assert out2.stat().st_size <= 3000 and report["attempts"] == [] and report["color_bits"] == 7
    assert f2.geometry.network.levels[0][0].tolist() == read_nfc(MILK_GEOMETRY.read_bytes()).geometry.network.levels[0][0].tolist()
    for argv, message in [(["--color-width", "16"], "not --color-width too"),
                          (["--target-bytes", "250"], "no file with colour fits in 250 bytes"),
                          (["--no-color", "--geometry", str(MILK_GEOMETRY)], "the input needs colours")]:
        assert main(["encode", str(MILK), "-o", str(tmp_path / "x.nfc"), "--target-bytes", "3000", *argv, "--quiet"]) == 1
        assert message in capsys.readouterr().err


@pytest.mark.skipif(not MILK.exists(), reason="shared data not available")
def test_nfc_encode_target_cd_sizes_the_geometry_of_a_coloured_input_and_fits_its_colour(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    monkeypatch.setattr(config, "TARGET_CD_RESOLUTION", 64)
    monkeypatch.setattr(config, "COLOR_SCHEDULE", dataclasses.replace(
        config.COLOR_SCHEDULE, points=5_000, validation_points=2_000, qat_epochs=1))
    fast = ["--epochs", "3", "--color-epochs", "2", "--color-resolution", "64", "--threads", "2"]
    out = tmp_path / "milk.nfc"
    assert main(["encode", str(MILK), "-o", str(out), "--target-cd", "0.5", "--color-width", "12", *fast]) == 0
    printed, progress = capsys.readouterr()
    f = read_nfc(out.read_bytes())
    assert f.color is not None and f.color.network.out_features[0] == 12
    assert f"tried geometry width {f.geometry.network.out_features[0]}: " in progress  # a line per try
    # The search's own estimate: the geometry alone decodes to the same mesh with or without colour.
    geometry = write_nfc(NfcFile(f.geometry))
    assert file_chamfer_distance(load_shape(MILK), geometry, 64) <= 0.5
    assert "target CD 0.5: chose width" in printed and "colour: width 12" in printed
    assert "reused" not in printed  # the field line tells why this run's own geometry has its field
    assert main(["encode", str(MILK), "-o", str(tmp_path / "x.nfc"), "--target-cd", "0.5",
                 "--geometry", str(MILK_GEOMETRY), "--quiet"]) == 1
    assert "cannot reuse the one --geometry gives" in capsys.readouterr().err


@pytest.mark.skipif(not BUNNY.exists(), reason="shared data not available")
def test_the_python_api_encodes_to_a_byte_budget_and_reports_each_try(monkeypatch: pytest.MonkeyPatch) -> None:
    """nfencode.targets, what the CLI's targets run, called directly: the bound, the choice it
    reports, a line per try."""
    from nfencode import targets
    from nfencode.encoder import EncodeConfig

    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 10_000)
    lines: list[str] = []
    result, choice = targets.compress_to_bytes(load_shape(BUNNY), EncodeConfig(epochs=2, quiet=True, threads=2), 900,
                                               report=lines.append)
    assert len(result.data) <= 900 and any(a.width == choice.width and a.bytes == len(result.data) for a in choice.attempts)
    assert read_nfc(result.data).geometry.network.out_features[0] == choice.width
    assert lines == [f"tried geometry width {a.width}, {a.bits} bits: {a.bytes} bytes" for a in choice.attempts]
    with pytest.raises(InputError, match="positive number"):
        targets.compress_to_distortion(load_shape(BUNNY), EncodeConfig(), 0.0)


@pytest.mark.parametrize("target_bytes, target_cd, message", [
    (0, None, "target_bytes must be >= 1, got 0"), (-5, None, "must be >= 1"), (True, None, "must be >= 1"),
    (2.5, None, "must be >= 1"), ("900", None, "must be >= 1"),
    (None, 0.0, "target_cd must be a positive number"), (None, -1.0, "positive number"),
    (None, float("nan"), "positive number"), (None, float("inf"), "positive number"), (None, True, "positive number"),
    (None, "0.01", "positive number"), (900, 0.01, "give one target, not both"),
])
def test_hostile_targets_are_input_errors_before_any_encode(target_bytes: object, target_cd: object,
                                                            message: str) -> None:
    """nfencode.targets checks its target before it loads anything (the shape is not even looked at)."""
    from nfencode import targets
    from nfencode.encoder import EncodeConfig

    with pytest.raises(InputError, match=message):
        rate.check_targets(target_bytes, target_cd)
    if target_cd is None:
        with pytest.raises(InputError, match=message):
            targets.compress_to_bytes(None, EncodeConfig(), target_bytes)  # type: ignore[arg-type]
    elif target_bytes is None:
        with pytest.raises(InputError, match=message):
            targets.compress_to_distortion(None, EncodeConfig(), target_cd)  # type: ignore[arg-type]
    rate.check_targets(900, None)
    rate.check_targets(None, 0.01)
    rate.check_targets(None, 1)
