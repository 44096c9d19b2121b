"""`nfc encode-batch` without Ray (`--workers 1`, in this process) and `--device`: rows, resume by
options hash, isolation of bad assets and manifest lines, atomic outputs, exit status."""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import trimesh
from nfencode import __version__, batch, config
from nfencode.batch import HASHED_OPTIONS, ROW_KEYS, encode_batch, options_hash, write_atomic
from nfencode.bitstream import read_nfc
from nfencode.cli import main
from nfencode.devices import resolve_device
from nfencode.errors import InputError

ENCODE = ["--width", "8", "--epochs", "1", "--quiet"]


@pytest.fixture(autouse=True)
def small_epochs(monkeypatch: pytest.MonkeyPatch) -> None:
    """5k instead of 100k surface points per epoch: these tests check orchestration, not quality."""
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 5_000)


def write_library(root: Path) -> Path:
    """Two small closed meshes, a broken file and a file that is not a shape."""
    lib = root / "lib"
    lib.mkdir()
    trimesh.creation.icosphere(subdivisions=2).export(lib / "sphere.obj")
    trimesh.creation.box().export(lib / "box.ply")
    (lib / "broken.obj").write_text("this is no mesh\n")
    (lib / "README.txt").write_text("ignored: not a shape file\n")
    return lib


def run(*args: str | Path) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in args])
        except SystemExit as e:
            code = int(e.code or 0)
    return code, out.getvalue(), err.getvalue()


def rows(outdir: Path) -> dict[str, dict]:
    lines = (outdir / "results.jsonl").read_text().splitlines()
    return {Path(r["input"]).name: r for r in map(json.loads, lines)}


def test_in_process_batch_rows_isolation_resume_and_no_ray(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lib, out = write_library(tmp_path), tmp_path / "out"
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails: --workers 1 must not need it
    code, stdout, stderr = run("encode-batch", lib, "-o", out, "--workers", "1", *ENCODE)
    assert code == 1  # one asset failed
    assert stderr.splitlines() == [f"nfc: error: {lib / 'broken.obj'}: contains no vertices"]
    assert "2 encoded, 0 skipped (up to date), 1 failed of 3" in stdout
    first = rows(out)
    assert sorted(first) == ["box.ply", "broken.obj", "sphere.obj"]  # README.txt is no shape
    for name in ("box.ply", "sphere.obj"):
        r = first[name]
        assert list(r)[: len(ROW_KEYS)] == list(ROW_KEYS)
        assert r["status"] == "ok" and r["error"] is None and r["field"] == "sdf" and r["width"] == 8
        assert r["target_bytes"] is None and r["target_cd"] is None and r["tries"] is None  # no target, no search
        data = Path(r["output"]).read_bytes()
        assert len(data) == r["bytes"] and r["seconds"] > 0
        assert read_nfc(data).geometry.network.out_features == [8, 8, 1]
    assert first["broken.obj"]["status"] == "error" and first["broken.obj"]["output"] is None
    assert first["broken.obj"]["options_hash"]  # a final failure: these bytes and options always fail
    assert sorted(p.name for p in out.iterdir()) == ["box.nfc", "results.jsonl", "sphere.nfc"]  # no temporaries
    mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.nfc")}

    # Rerun: finished assets are skipped (files untouched); the broken one, unchanged, fails again
    # from its recorded row, without loading or encoding anything (torch must not be needed).
    encode_group = batch.encode_group
    monkeypatch.setattr(batch, "encode_group", None)  # calling it would raise
    code, stdout, stderr = run("encode-batch", lib, "-o", out, "--workers", "1", *ENCODE)
    monkeypatch.setattr(batch, "encode_group", encode_group)
    again = rows(out)
    assert code == 1 and "0 encoded, 2 skipped" in stdout and "contains no vertices" in stderr
    assert [again[n]["status"] for n in ("box.ply", "broken.obj", "sphere.obj")] == ["skipped", "error", "skipped"]
    assert again["box.ply"]["bytes"] == first["box.ply"]["bytes"]
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.nfc")} == mtimes
    # Execution settings (device, threads) are not part of the hash: still up to date.
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", *ENCODE, "--device", "cpu", "--threads", "1")
    assert code == 1 and "0 encoded, 2 skipped" in stdout

    # Another option (seed) or another input file content means another file: re-encoded.
    (lib / "broken.obj").unlink()
    trimesh.creation.icosphere(subdivisions=1).export(lib / "sphere.obj")
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", *ENCODE)
    third = rows(out)
    assert code == 0 and "1 encoded, 1 skipped" in stdout
    assert third["sphere.obj"]["status"] == "ok" and third["box.ply"]["status"] == "skipped"
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", *ENCODE, "--seed", "3")
    assert code == 0 and "2 encoded, 0 skipped" in stdout


def test_json_prints_the_counts_and_this_runs_rows(tmp_path: Path) -> None:
    lib, out = write_library(tmp_path), tmp_path / "out"
    code, stdout, stderr = run("encode-batch", lib, "-o", out, "--workers", "1", "--json", *ENCODE)
    report = json.loads(stdout)  # the whole of stdout: one object, no summary line
    assert code == 1 and "contains no vertices" in stderr  # errors still go to stderr, one line each
    assert (report["encoded"], report["skipped"], report["failed"]) == (2, 0, 1)
    assert report["output"] == str(out) and report["results"] == str(out / "results.jsonl")
    assert report["seconds"] > 0
    assert report["rows"] == [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", "--json", *ENCODE)
    again = json.loads(stdout)
    assert code == 1 and (again["encoded"], again["skipped"], again["failed"]) == (0, 2, 1)
    assert {Path(r["input"]).name: r["status"] for r in again["rows"]} == {
        "box.ply": "skipped", "broken.obj": "error", "sphere.obj": "skipped"}


def test_manifest_per_asset_options_and_bad_lines(tmp_path: Path) -> None:
    lib = write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    manifest.write_text("\n".join([
        json.dumps({"path": "lib/sphere.obj", "width": 12, "name": "ball"}),
        json.dumps({"path": str(lib / "box.ply")}),  # absolute path, command-line options
        "# a comment, then a blank line",
        "",
        "{not json",
        json.dumps({"path": "lib/box.ply", "widht": 4}),
        json.dumps({"path": "lib/box.ply", "width": "wide"}),
        json.dumps({"width": 4}),
        json.dumps({"path": "lib/missing.ply"}),
        json.dumps({"path": "lib/box.ply", "name": "ball"}),  # the output name is taken
        json.dumps({"path": "lib/sphere.obj", "name": "tiny", "bits": 1}),  # rejected by the encoder
    ]) + "\n")
    code, stdout, stderr = run("encode-batch", manifest, "-o", tmp_path / "out", "--workers", "1", *ENCODE)
    assert code == 1 and "2 encoded, 0 skipped (up to date), 7 failed of 9" in stdout
    table = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    by_status = {s: [r for r in table if r["status"] == s] for s in ("ok", "error")}
    ok = {Path(r["output"]).name: r for r in by_status["ok"]}
    assert sorted(ok) == ["ball.nfc", "box.nfc"] and ok["ball.nfc"]["width"] == 12
    assert read_nfc((tmp_path / "out" / "ball.nfc").read_bytes()).geometry.network.out_features == [12, 12, 1]
    errors = " | ".join(r["error"] for r in by_status["error"])
    for expected in (":5: not JSON", ":6: unknown key 'widht'", ":7: width must be int", ':8: missing "path"',
                     "missing.ply: no such file", "ball.nfc already used by", "bit width 1 outside"):
        assert expected in errors, (expected, errors)
    assert len(stderr.splitlines()) == 7 and all(line.startswith("nfc: error: ") for line in stderr.splitlines())


def test_interrupted_run_leaves_whole_files_and_resumes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lib, out = write_library(tmp_path), tmp_path / "out"
    (lib / "broken.obj").unlink()
    real = batch.encode_asset
    calls: list[str] = []

    def interrupt_second(input: str, options: dict, threads: int | None) -> dict:
        calls.append(input)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(input, options, threads)

    monkeypatch.setattr(batch, "encode_asset", interrupt_second)
    with pytest.raises(KeyboardInterrupt):
        encode_batch(lib, out, {"width": 8, "epochs": 1}, workers=1, quiet=True)
    assert sorted(p.name for p in out.iterdir()) == ["box.nfc", "results.jsonl"]  # no partial sphere.nfc
    journal = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert [(Path(r["input"]).name, r["status"]) for r in journal] == [("box.ply", "ok")]
    monkeypatch.setattr(batch, "encode_asset", real)
    summary = encode_batch(lib, out, {"width": 8, "epochs": 1}, workers=1, quiet=True)
    assert [(Path(r["input"]).name, r["status"]) for r in summary.rows] == [("box.ply", "skipped"), ("sphere.obj", "ok")]


def test_write_atomic_keeps_the_old_file_when_the_write_fails(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "a.nfc"
    write_atomic(target, b"old")

    def fail(src: object, dst: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError):
        write_atomic(target, b"new contents")
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["a.nfc"]


@pytest.mark.parametrize("args, message", [
    (["missing_dir"], "missing_dir: no such file or directory"),
    (["notes.txt"], "must be a directory of shapes or a JSON-lines manifest"),
    (["empty"], "no shape files"),
    (["empty.jsonl"], "lists no shapes"),
    (["empty", "--workers", "0"], "--workers must be >= 1"),
    (["empty", "--cpus-per-task", "0"], "--cpus-per-task must be > 0"),
    (["empty", "--target-bytes", "0"], "--target-bytes must be >= 1"),
    (["empty", "--target-cd", "-1"], "--target-cd must be a positive number"),
    (["empty", "--target-cd", "nan"], "--target-cd must be a positive number"),
    (["empty", "--target-bytes", "900", "--target-cd", "0.01"], "give one target, not both"),
])
def test_bad_batch_input_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str],
                                     message: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "empty").mkdir()
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "empty.jsonl").write_text("\n")
    code, _, stderr = run("encode-batch", "--workers", "1", *args, "-o", "out")
    assert code == 1 and stderr.startswith("nfc: error: ") and len(stderr.splitlines()) == 1
    assert message in stderr, stderr


def test_device_resolution() -> None:
    assert resolve_device("cpu").type == "cpu"
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    with pytest.raises(InputError, match="unknown device"):
        resolve_device("tpu")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="no CUDA GPU"):
            resolve_device("cuda")


def test_encode_device_cpu_is_deterministic_and_cuda_without_gpu_is_one_line(tmp_path: Path) -> None:
    box = tmp_path / "box.ply"
    trimesh.creation.box().export(box)
    outputs = []
    for name in ("a", "b"):
        code, stdout, _ = run("encode", box, "-o", tmp_path / f"{name}.nfc", "--device", "cpu", "--threads", "1",
                              *ENCODE)
        assert code == 0 and "cpu)" in stdout
        outputs.append((tmp_path / f"{name}.nfc").read_bytes())
    assert outputs[0] == outputs[1]
    if not torch.cuda.is_available():
        code, _, stderr = run("encode", box, "-o", tmp_path / "c.nfc", "--device", "cuda", *ENCODE)
        assert code == 1 and stderr == "nfc: error: --device cuda: torch sees no CUDA GPU (use --device cpu or auto)\n"


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA GPU: the CUDA encode path is checked on a GPU machine")
def test_cuda_encode_is_deterministic_and_close_to_cpu(tmp_path: Path) -> None:
    from nfencode.encoder import EncodeConfig, compress
    from nfencode.io import load_shape

    box = tmp_path / "box.ply"
    trimesh.creation.box().export(box)
    shape = load_shape(box)
    cuda = [compress(shape, EncodeConfig(width=8, epochs=1, quiet=True, device="cuda")) for _ in range(2)]
    cpu = compress(shape, EncodeConfig(width=8, epochs=1, quiet=True, device="cpu"))
    assert cuda[0].data == cuda[1].data
    assert np.isclose(cuda[0].final_loss, cpu.final_loss, rtol=0.5)


def test_group_trains_assets_together_and_isolates_a_rejected_one(tmp_path: Path) -> None:
    lib, out = write_library(tmp_path), tmp_path / "out"
    points = trimesh.creation.icosphere(subdivisions=2).vertices
    (lib / "cloud.ply").write_text(f"ply\nformat ascii 1.0\nelement vertex {len(points)}\nproperty float x\n"
                                   "property float y\nproperty float z\nend_header\n"
                                   + "".join(f"{x} {y} {z}\n" for x, y, z in points))
    # One group of four: the broken file fails to load; the SDF meshes and the UDF cloud train together.
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", "--group", "4", *ENCODE)
    table = rows(out)
    assert code == 1 and "3 encoded, 0 skipped (up to date), 1 failed of 4" in stdout
    assert {n: r["field"] for n, r in table.items()} == {"box.ply": "sdf", "broken.obj": None, "cloud.ply": "udf",
                                                         "sphere.obj": "sdf"}
    for name in ("box", "cloud", "sphere"):
        assert read_nfc((out / f"{name}.nfc").read_bytes()).geometry.network.out_features == [8, 8, 1]
    # --field sdf: the encoder rejects the point cloud, which fails the group's training; the group
    # falls back to one shape at a time, so only the cloud fails.
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "1", "--group", "4", "--field", "sdf", *ENCODE)
    table = rows(out)
    assert code == 1 and "2 encoded, 0 skipped (up to date), 2 failed of 4" in stdout
    assert "no inside" in table["cloud.ply"]["error"] and table["box.ply"]["status"] == "ok"


MILK = Path(__file__).resolve().parents[3] / "shared" / "data" / "colored" / "pcl_milk_color.ply.gz"


@pytest.mark.skipif(not MILK.exists(), reason="shared data not available")
def test_colour_options_reach_the_encoder_and_the_cache_key(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "COLOR_SCHEDULE", dataclasses.replace(
        config.COLOR_SCHEDULE, points=5_000, validation_points=2_000, qat_epochs=1))
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "milk.ply.gz").write_bytes(MILK.read_bytes())
    out = tmp_path / "out"
    common = ["encode-batch", lib, "-o", out, "--workers", "1", "--width", "16", "--epochs", "3", "--quiet",
              "--color-epochs", "1", "--color-resolution", "32"]

    def colour_width() -> int | None:
        f = read_nfc((out / "milk.nfc").read_bytes())
        return None if f.color is None else f.color.network.out_features[0]

    code, stdout, stderr = run(*common, "--color-width", "4")
    assert code == 0 and "1 encoded" in stdout, stderr
    assert colour_width() == 4
    assert "0 encoded, 1 skipped" in run(*common, "--color-width", "4")[1]
    assert "1 encoded" in run(*common, "--color-width", "6")[1]  # a colour option changes the key
    assert colour_width() == 6
    assert "1 encoded" in run(*common, "--color-width", "6", "--no-color")[1]
    assert colour_width() is None


def test_manifest_rows_with_bad_frequency_and_colour_options(tmp_path: Path) -> None:
    lib = write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    manifest.write_text("\n".join([
        json.dumps({"path": str(lib / "box.ply"), "frequencies": 99}),
        json.dumps({"path": str(lib / "box.ply"), "name": "b2", "color_width": "wide"}),
        json.dumps({"path": str(lib / "box.ply"), "name": "b3", "color": "maybe"}),
        json.dumps({"path": str(lib / "box.ply"), "name": "b4", "frequency_base": 3}),
    ]) + "\n")
    code, stdout, stderr = run("encode-batch", manifest, "-o", tmp_path / "out", "--workers", "1", *ENCODE)
    assert code == 1 and "0 encoded, 0 skipped (up to date), 4 failed of 4" in stdout
    for expected in ("99 frequencies outside", "color_width must be int", "colour mode 'maybe'",
                     "frequency base 3 outside"):
        assert expected in stderr, (expected, stderr)


def test_manifest_rows_with_hostile_truncations(tmp_path: Path) -> None:
    lib = write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    rows = [{"truncation": 0.5}, {"truncation": 0.0}, {"truncation": -0.05}, {"truncation": "narrow"},
            {"truncation": True}]
    manifest.write_text("\n".join(json.dumps({"path": str(lib / "box.ply"), "name": f"b{i}", **row})
                                  for i, row in enumerate(rows)) + "\n")
    code, stdout, stderr = run("encode-batch", manifest, "-o", tmp_path / "out", "--workers", "1", *ENCODE)
    assert code == 1 and "0 encoded, 0 skipped (up to date), 5 failed of 5" in stdout
    for expected in ("truncation 0.5 outside", "truncation 0.0 outside", "truncation -0.05 outside",
                     "truncation must be float or int or null"):
        assert expected in stderr, (expected, stderr)


def test_target_bytes_per_asset_bounds_each_file_and_chooses_its_width(tmp_path: Path) -> None:
    """`target_bytes` (command line or manifest line) runs each asset's rate search: every file at
    most its budget, the row's width the file's, a budget nothing fits and a bad type one error row
    each; with --group the targeted assets train one by one; a rerun skips them (the target is in
    the options hash)."""
    lib = write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    manifest.write_text("\n".join([
        json.dumps({"path": "lib/sphere.obj", "target_bytes": 900, "name": "ball"}),
        json.dumps({"path": "lib/box.ply"}),  # the command line's 700
        json.dumps({"path": "lib/sphere.obj", "target_bytes": 40, "name": "nothing"}),
        json.dumps({"path": "lib/sphere.obj", "target_bytes": "big", "name": "typo"}),
    ]) + "\n")
    out = tmp_path / "out"
    args = ("encode-batch", manifest, "-o", out, "--workers", "1", "--group", "2", "--target-bytes", "700",
            "--epochs", "1", "--quiet")
    code, stdout, _ = run(*args)
    assert code == 1 and "2 encoded, 0 skipped (up to date), 2 failed of 4" in stdout
    table = {r["output"] and Path(r["output"]).name or r["input"]: r
             for r in map(json.loads, (out / "results.jsonl").read_text().splitlines())}
    for name, budget in (("ball.nfc", 900), ("box.nfc", 700)):
        data = (out / name).read_bytes()
        assert len(data) <= budget and table[name]["bytes"] == len(data)
        assert table[name]["width"] == read_nfc(data).geometry.network.out_features[0]
        assert table[name]["target_bytes"] == budget and table[name]["target_cd"] is None
        assert table[name]["tries"] >= 1  # the search's encodes
    assert table["ball.nfc"]["width"] > table["box.nfc"]["width"]
    errors = " | ".join(r["error"] for r in table.values() if r["status"] == "error")
    assert "sphere.obj: no file fits in 40 bytes" in errors and "target_bytes must be int or null" in errors
    assert [r["width"] for r in table.values() if r["status"] == "error"] == [None, None]
    code, stdout, _ = run(*args)
    assert "0 encoded, 2 skipped (up to date), 2 failed of 4" in stdout
    # Without a target the key is what it was before the option existed: earlier runs resume.
    options = {k: 1 for k in HASHED_OPTIONS if k not in batch.TARGETS}
    before = hashlib.sha256(json.dumps({"nfencode": __version__, "input_sha256": "d", **options},
                                       sort_keys=True).encode()).hexdigest()[:16]
    assert options_hash({**options, "target_bytes": None}, "d") == before != options_hash({**options, "target_bytes": 9}, "d")
    rerun = [r for r in map(json.loads, (out / "results.jsonl").read_text().splitlines()) if r["status"] == "skipped"]
    assert {Path(r["output"]).name: (r["width"], r["target_bytes"], r["tries"]) for r in rerun} == {
        name: (table[name]["width"], table[name]["target_bytes"], table[name]["tries"]) for name in ("ball.nfc", "box.nfc")}


def test_target_cd_per_asset_and_a_lines_target_replacing_the_command_lines(tmp_path: Path,
                                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """`target_cd` runs each asset's distortion search; a manifest line's target replaces the command
    line's (here --target-bytes), two targets on one line are one error row."""
    from nfencode.io import load_shape
    from nfencode.metrics import file_chamfer_distance

    monkeypatch.setattr(config, "TARGET_CD_RESOLUTION", 64)
    lib = write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    manifest.write_text("\n".join([
        json.dumps({"path": "lib/sphere.obj", "target_cd": 0.3}),
        json.dumps({"path": "lib/box.ply", "target_cd": 0.2, "target_bytes": 900}),
    ]) + "\n")
    out = tmp_path / "out"
    code, stdout, _ = run("encode-batch", manifest, "-o", out, "--workers", "1", "--target-bytes", "600",
                          "--epochs", "1", "--quiet")
    assert code == 1 and "1 encoded, 0 skipped (up to date), 1 failed of 2" in stdout
    table = {Path(r["input"]).name: r for r in map(json.loads, (out / "results.jsonl").read_text().splitlines())}
    data = (out / "sphere.nfc").read_bytes()
    assert file_chamfer_distance(load_shape(lib / "sphere.obj"), data, 64) <= 0.3
    assert table["sphere.obj"]["width"] == read_nfc(data).geometry.network.out_features[0]
    assert table["sphere.obj"]["target_cd"] == 0.3 and table["sphere.obj"]["target_bytes"] is None
    assert table["sphere.obj"]["tries"] >= 1
    assert "give one target, not both" in table["box.ply"]["error"] and table["box.ply"]["width"] is None


def test_hostile_manifest_targets_are_error_rows_without_an_encode(tmp_path: Path) -> None:
    """Targets a manifest line may hold that no search can serve: each one error row naming the
    value, on a rerun too, and no file."""
    write_library(tmp_path)
    manifest = tmp_path / "assets.jsonl"
    lines = [json.dumps({"path": "lib/sphere.obj", "target_bytes": 0}),
             json.dumps({"path": "lib/sphere.obj", "target_bytes": True, "name": "yes"}),
             json.dumps({"path": "lib/sphere.obj", "target_bytes": -7, "name": "negative_bytes"}),
             json.dumps({"path": "lib/sphere.obj", "target_cd": -1, "name": "negative"}),
             json.dumps({"path": "lib/sphere.obj", "target_cd": 0, "name": "zero"}),
             '{"path": "lib/sphere.obj", "target_cd": NaN, "name": "nan"}',  # Python's json reads NaN
             '{"path": "lib/sphere.obj", "target_cd": Infinity, "name": "inf"}',
             json.dumps({"path": "lib/sphere.obj", "target_cd": "small", "name": "text"})]
    manifest.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    for _ in range(2):
        code, stdout, stderr = run("encode-batch", manifest, "-o", out, "--workers", "1", "--epochs", "1")
        assert code == 1 and "0 encoded, 0 skipped (up to date), 8 failed of 8" in stdout
        assert len(stderr.splitlines()) == 8
    errors = " | ".join(json.loads(line)["error"] for line in (out / "results.jsonl").read_text().splitlines())
    for expected in ("target_bytes must be >= 1, got 0", "target_bytes must be int or null, got true",
                     "target_bytes must be >= 1, got -7", "target_cd must be a positive number, not -1",
                     "target_cd must be a positive number, not 0", "target_cd must be a positive number, not nan",
                     "target_cd must be a positive number, not inf", 'target_cd must be float or int or null, got "small"'):
        assert expected in errors, (expected, errors)
    assert not list(out.glob("*.nfc"))
