"""Bad input to `nfc` ends in exactly one line `nfc: error: ...` and a non-zero exit, never a traceback."""

from __future__ import annotations

import contextlib
import gzip
import io
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from conftest import cos_blob_file, random_file

from nfencode import config
from nfencode.bitstream import read_nfc, write_nfc
from nfencode.cli import main


@dataclass
class Result:
    returncode: int
    stdout: str
    stderr: str


def nfc(*args: str | Path, cwd: Path) -> Result:
    """Runs `nfc` in this process (fast; an escaping exception fails the test like a traceback would)."""
    out, err = io.StringIO(), io.StringIO()
    previous = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as e:
                code = int(e.code or 0)
    finally:
        os.chdir(previous)
    return Result(code, out.getvalue(), err.getvalue())


def nfc_process(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess:
    """Runs the real entry point in a fresh interpreter."""
    return subprocess.run(
        [sys.executable, "-m", "nfencode.cli", *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=120
    )


def assert_one_line_error(result: Result | subprocess.CompletedProcess, code: int = 1, contains: str = "") -> str:
    assert result.returncode == code, result
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("nfc: error: "), result.stderr
    assert contains.lower() in lines[0].lower(), lines[0]
    return lines[0]


def test_console_entry_point(tmp_path: Path) -> None:
    (tmp_path / "corrupt.nfc").write_bytes(b"\x89NFC" + bytes(40))
    assert_one_line_error(nfc_process("encode", "missing.ply", "-o", "x.nfc", cwd=tmp_path), contains="no such file")
    assert_one_line_error(nfc_process("info", "corrupt.nfc", cwd=tmp_path), contains="corrupt")
    assert_one_line_error(nfc_process("decode", cwd=tmp_path), code=2)


PLY_HEADER = "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"

BAD_INPUTS = {
    "missing.ply": (None, "no such file"),
    "empty.ply": ("", "empty"),
    "no_vertices.ply": (PLY_HEADER.format(n=0) + "end_header\n", "no vertices"),
    "nan.ply": (PLY_HEADER.format(n=3) + "end_header\n0 0 0\nnan 1 0\n0 0 1\n", "non-finite"),
    "inf.obj": ("v 0 0 0\nv inf 1 0\nv 0 0 1\nf 1 2 3\n", "non-finite"),
    "zero_area.obj": ("v 0 0 0\nv 1 1 1\nv 2 2 2\nv 0 0 0\nf 1 2 3\nf 1 4 2\n", "zero area"),
    "one_point.ply": (PLY_HEADER.format(n=3) + "end_header\n1 2 3\n1 2 3\n1 2 3\n", "identical"),
    "garbage.ply": ("this is not a ply file\n", "cannot parse"),
    "bad_index.off": ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "face"),
    "bad_index.ply": (PLY_HEADER.format(n=3) + "element face 1\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n", "does not exist"),
    "shape.xyz": ("0 0 0\n", "unknown extension"),
    "not_gzip.ply.gz": (PLY_HEADER.format(n=1) + "end_header\n0 0 0\n", "gzip"),
    # Hostile sizes and coordinates (issue 13, item 5): refused before any allocation or training.
    "announces_1e12.ply": (PLY_HEADER.format(n=10**12) + "end_header\n0 0 0\n", "announces elements"),
    "enormous.obj": ("v 0 0 0\nv 1e38 0 0\nv 0 1e38 0\nf 1 2 3\n", "too large for float32"),
    "beyond_f32.obj": ("v 0 0 0\nv 1e39 0 0\nv 0 1e39 0\nf 1 2 3\n", "overflow float32"),
    "tiny.obj": ("v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 0\nf 1 2 3\n", "too small for float32"),
}


@pytest.mark.parametrize("name", sorted(BAD_INPUTS))
def test_bad_encoder_input(tmp_path: Path, name: str) -> None:
    content, message = BAD_INPUTS[name]
    if content is not None:
        (tmp_path / name).write_text(content)
    assert_one_line_error(nfc("encode", name, "-o", "out.nfc", cwd=tmp_path), contains=message)
    assert not (tmp_path / "out.nfc").exists()


def test_directory_and_wrong_output_extension(tmp_path: Path) -> None:
    (tmp_path / "dir.ply").mkdir()
    assert_one_line_error(nfc("encode", "dir.ply", "-o", "out.nfc", cwd=tmp_path), contains="directory")
    (tmp_path / "ok.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert_one_line_error(nfc("encode", "ok.obj", "-o", "out.ply", cwd=tmp_path), contains=".nfc")
    assert_one_line_error(nfc("encode", "ok.obj", "-o", "out.nfc", "--bits", "1", cwd=tmp_path), contains="--bits")


def test_bad_nfc_files(tmp_path: Path) -> None:
    data = write_nfc(random_file())
    (tmp_path / "truncated.nfc").write_bytes(data[:-7])
    damaged = bytearray(data)
    damaged[40] ^= 0x20
    (tmp_path / "corrupt.nfc").write_bytes(bytes(damaged))
    (tmp_path / "empty.nfc").write_bytes(b"")
    (tmp_path / "shape.nfc").write_text("ply\nformat ascii 1.0\nelement vertex 0\nend_header\n")
    for command in ("info", "decode"):
        extra = ["-o", "out.ply"] if command == "decode" else []
        assert_one_line_error(nfc(command, "truncated.nfc", *extra, cwd=tmp_path), contains="truncated")
        assert_one_line_error(nfc(command, "corrupt.nfc", *extra, cwd=tmp_path), contains="corrupt")
        assert_one_line_error(nfc(command, "empty.nfc", *extra, cwd=tmp_path), contains="truncated")
        assert_one_line_error(nfc(command, "shape.nfc", *extra, cwd=tmp_path), contains="magic")
        assert_one_line_error(nfc(command, "missing.nfc", *extra, cwd=tmp_path), contains="no such file")


def test_decode_refusals(tmp_path: Path) -> None:
    (tmp_path / "sdf.nfc").write_bytes(write_nfc(cos_blob_file()))
    assert_one_line_error(nfc("decode", "sdf.nfc", "-o", "out.stl", cwd=tmp_path), contains=".ply or .obj")
    assert_one_line_error(nfc("decode", "sdf.nfc", "-o", "out.ply", "--resolution", "4", cwd=tmp_path),
                          contains="resolution")
    assert_one_line_error(nfc("decode", "sdf.nfc", "-o", "no/such/dir/out.ply", cwd=tmp_path), contains="no such")
    assert not (tmp_path / "out.ply").exists()


def test_decode_udf_mesh_and_points(tmp_path: Path) -> None:
    tshirt = Path(__file__).resolve().parents[1] / "vectors" / "v1_0_tshirt_udf_w16.nfc"
    mesh = nfc("decode", tshirt, "-o", "tshirt.ply", "--resolution", "32", cwd=tmp_path)
    assert mesh.returncode == 0 and "triangles (udf" in mesh.stdout, mesh.stderr
    points = nfc("decode", tshirt, "-o", "points.ply", "--resolution", "32", "--points", "500", cwd=tmp_path)
    assert points.returncode == 0 and "500 points (udf" in points.stdout, points.stderr
    again = nfc("decode", tshirt, "-o", "again.ply", "--resolution", "32", "--points", "500", cwd=tmp_path)
    assert again.returncode == 0 and (tmp_path / "again.ply").read_bytes() == (tmp_path / "points.ply").read_bytes()


def test_usage_errors_exit_2(tmp_path: Path) -> None:
    assert_one_line_error(nfc(cwd=tmp_path), code=2)
    assert_one_line_error(nfc("encode", cwd=tmp_path), code=2)
    assert_one_line_error(nfc("decode", "x.nfc", "-o", "y.ply", "--resolution", "many", cwd=tmp_path), code=2)
    assert_one_line_error(nfc("frobnicate", cwd=tmp_path), code=2)


def test_eval_errors(tmp_path: Path) -> None:
    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert_one_line_error(nfc("eval", "a.obj", "missing.ply", cwd=tmp_path), contains="missing.ply")
    assert_one_line_error(nfc("eval", "a.obj", "a.obj", "--samples", "0", cwd=tmp_path), contains="--samples")


def test_info_decode_eval_succeed(tmp_path: Path) -> None:
    """The happy path of the torch-free commands on a hand-built SDF file."""
    (tmp_path / "blob.nfc").write_bytes(write_nfc(cos_blob_file()))
    info = nfc("info", "blob.nfc", cwd=tmp_path)
    assert info.returncode == 0 and "sdf" in info.stdout and "3->3->1" in info.stdout
    assert '"field": "sdf"' in nfc("info", "blob.nfc", "--json", cwd=tmp_path).stdout
    assert nfc("decode", "blob.nfc", "-o", "blob.ply", "--resolution", "32", cwd=tmp_path).returncode == 0
    assert nfc("decode", "blob.nfc", "-o", "blob.obj", "--resolution", "32", cwd=tmp_path).returncode == 0
    points = nfc("decode", "blob.nfc", "-o", "points.ply", "--resolution", "32", "--points", "5000", cwd=tmp_path)
    assert points.returncode == 0, points.stderr
    with gzip.open(tmp_path / "blob.obj.gz", "wb") as out:
        out.write((tmp_path / "blob.obj").read_bytes())
    result = nfc("eval", "blob.ply", "blob.obj.gz", "--samples", "5000", "--seed", "7", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "seed 7" in result.stdout and "floor" in result.stdout
    result = nfc("eval", "blob.ply", "points.ply", "--json", "--samples", "5000", cwd=tmp_path)
    assert result.returncode == 0 and '"chamfer_distance"' in result.stdout


def test_input_beyond_the_size_limit_is_refused_while_decompressing(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A gzip bomb stops at the input limit (here lowered to 4 KiB; 4 GiB by default)."""
    from nfencode import io as nfio
    monkeypatch.setattr(nfio, "MAX_INPUT_BYTES", 4096)
    body = "".join(f"v {i} {i % 7} {i % 3}\n" for i in range(2000)) + "f 1 2 3\n"
    (tmp_path / "bomb.obj.gz").write_bytes(gzip.compress(body.encode()))
    assert_one_line_error(nfc("encode", "bomb.obj.gz", "-o", "out.nfc", cwd=tmp_path), contains="input limit")
    (tmp_path / "big.obj").write_text(body)
    assert_one_line_error(nfc("encode", "big.obj", "-o", "out.nfc", cwd=tmp_path), contains="input limit")
    assert not (tmp_path / "out.nfc").exists()


def test_frequency_options(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 5_000)  # plumbing, not quality
    (tmp_path / "ok.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    for flag in ("--frequencies", "--color-frequencies"):
        for value in ("25", "-1"):
            assert_one_line_error(nfc("encode", "ok.obj", "-o", "out.nfc", flag, value, cwd=tmp_path), contains=flag)
    for value in ("0.99", "2.01", "nan"):
        assert_one_line_error(nfc("encode", "ok.obj", "-o", "out.nfc", "--frequency-base", value, cwd=tmp_path),
                              contains="--frequency-base")
    assert not (tmp_path / "out.nfc").exists()
    result = nfc("encode", "ok.obj", "-o", "f.nfc", "--frequencies", "4", "--frequency-base", "1.7", "--width", "4",
                 "--epochs", "1", "--quiet", "--json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout.splitlines()[-1])
    assert report["frequencies"] == 4 and report["frequency_base"] == float(np.float32(1.7))
    network = read_nfc((tmp_path / "f.nfc").read_bytes()).geometry.network
    assert network.num_frequencies == 4 and network.in_features[0] == 3 + 6 * 4
    assert network.frequency_base == float(np.float32(1.7))


def test_truncation_option(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(config, "SURFACE_POINTS_PER_EPOCH", 5_000)  # plumbing, not quality
    (tmp_path / "ok.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    for value in ("0.01", "0.2", "nan"):
        assert_one_line_error(nfc("encode", "ok.obj", "-o", "out.nfc", "--truncation", value, cwd=tmp_path),
                              contains="--truncation")
    assert not (tmp_path / "out.nfc").exists()
    result = nfc("encode", "ok.obj", "-o", "f.nfc", "--truncation", "0.07", "--width", "4", "--epochs", "1",
                 "--quiet", "--json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.splitlines()[-1])["truncation"] == float(np.float32(0.07))
    assert read_nfc((tmp_path / "f.nfc").read_bytes()).geometry.truncation == float(np.float32(0.07))
