"""Runs in every worker of the test Ray cluster (runtime_env worker_process_setup_hook).

- Small epochs (5k instead of 100k surface points), as the in-process tests' `small_epochs`
  fixture does: the Ray tests check orchestration, not quality.
- Fault injection: loading a file whose name starts with `crash_` kills the worker process, as a
  segfault or the OOM killer would; the batch must turn that into an error row for that asset only.
"""

from __future__ import annotations

import os
from pathlib import Path


def setup() -> None:
    from nfencode import config, io

    config.SURFACE_POINTS_PER_EPOCH = 5_000
    real_load = io.load_shape

    def load_shape(path, *args, **kwargs):  # type: ignore[no-untyped-def]
        if Path(path).name.startswith("crash_"):
            os._exit(1)
        return real_load(path, *args, **kwargs)

    io.load_shape = load_shape
