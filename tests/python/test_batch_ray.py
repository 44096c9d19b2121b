"""`nfc encode-batch --workers 2` on a real local Ray cluster (2 CPUs, one for the whole module):
a library with a broken file and a file that kills its worker; rows, isolation, resume, atomic outputs.

The cluster's workers run `ray_hooks.setup` (small epochs, and the crash fault for `crash_*` files).
"""

from __future__ import annotations

import contextlib
import io
import json
import time
from pathlib import Path

import nfencode
import pytest
import trimesh
from nfencode.bitstream import read_nfc
from nfencode.cli import main

ray = pytest.importorskip("ray", reason="Ray not installed (pip install 'nfencode[batch]')")
ENCODE = ["--width", "8", "--epochs", "1", "--quiet"]


@pytest.fixture(scope="module")
def cluster() -> object:
    import ray_hooks

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
             runtime_env={"py_modules": [nfencode, ray_hooks], "worker_process_setup_hook": "ray_hooks.setup"})
    yield ray
    ray.shutdown()


def run(*args: str | Path) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def test_two_workers_rows_isolation_resume(cluster: object, tmp_path: Path) -> None:
    lib, out = tmp_path / "lib", tmp_path / "out"
    lib.mkdir()
    trimesh.creation.icosphere(subdivisions=2).export(lib / "sphere.obj")
    trimesh.creation.box().export(lib / "box.ply")
    trimesh.creation.capsule(height=1.0, radius=0.4).export(lib / "capsule.off")
    (lib / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n")  # truncated header
    trimesh.creation.box().export(lib / "crash_box.ply")

    start = time.perf_counter()
    code, stdout, stderr = run("encode-batch", lib, "-o", out, "--workers", "2", *ENCODE)
    first_seconds = time.perf_counter() - start
    assert code == 1, (stdout, stderr)
    assert "3 encoded, 0 skipped (up to date), 2 failed of 5" in stdout
    rows = {Path(r["input"]).name: r for r in map(json.loads, (out / "results.jsonl").read_text().splitlines())}
    assert rows["broken.ply"]["status"] == "error" and "broken.ply" in rows["broken.ply"]["error"]
    assert rows["crash_box.ply"]["status"] == "error" and "worker failed" in rows["crash_box.ply"]["error"]
    assert rows["broken.ply"]["options_hash"] and rows["crash_box.ply"]["options_hash"] is None  # crashes: retried
    for name in ("sphere.obj", "box.ply", "capsule.off"):
        r = rows[name]
        assert r["status"] == "ok" and r["field"] == "sdf" and r["width"] == 8
        assert read_nfc(Path(r["output"]).read_bytes()).geometry.network.out_features == [8, 8, 1]
    assert sorted(p.name for p in out.iterdir()) == ["box.nfc", "capsule.nfc", "results.jsonl", "sphere.nfc"]
    assert len(stderr.splitlines()) == 2

    # Rerun: nothing finished is encoded again, and the unchanged broken file fails again from its
    # row (no task runs at all).
    (lib / "crash_box.ply").unlink()
    start = time.perf_counter()
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "2", *ENCODE)
    rerun_seconds = time.perf_counter() - start
    assert code == 1 and "0 encoded, 3 skipped (up to date), 1 failed of 4" in stdout
    print(f"first run {first_seconds:.1f} s, rerun {rerun_seconds:.1f} s")
    assert rerun_seconds < 0.5 * first_seconds

    # Every asset good: exit status 0.
    (lib / "broken.ply").unlink()
    code, stdout, _ = run("encode-batch", lib, "-o", out, "--workers", "2", *ENCODE)
    assert code == 0 and "0 encoded, 3 skipped" in stdout
