"""Where the encoder trains: `--device auto|cpu|cuda` and the CPU thread count.

Determinism: for a given seed an encode is reproducible on a given device (and, on the CPU, a given
thread count). All random draws (sampling, initialisation) happen on the CPU with numpy and a CPU
torch.Generator, so CPU and CUDA start from the same pool and the same initial weights; they then
differ only by float rounding of the training arithmetic.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from . import config
from .errors import DeviceError, InputError

if TYPE_CHECKING:  # torch is imported only where a device is resolved: `nfc info` etc. never need it
    import torch

DEVICE_CHOICES = ("auto", "cpu", "cuda")


def resolve_device(name: str) -> torch.device:
    """`auto` → CUDA when torch sees a GPU, else the CPU; `cuda` without a GPU is an InputError."""
    import torch

    if name not in DEVICE_CHOICES:
        raise InputError(f"unknown device {name!r} (use {', '.join(DEVICE_CHOICES)})")
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda" and not torch.cuda.is_available():
        raise DeviceError("--device cuda: torch sees no CUDA GPU (use --device cpu or auto)")
    return torch.device(name)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask), at least 1."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def cpu_threads(requested: int | None = None) -> int:
    """Torch threads for one encode: `requested` if given, else min(available CPUs, MAX_TORCH_THREADS)
    (the networks are tiny: more threads only add overhead)."""
    if requested is not None:
        if requested < 1:
            raise InputError(f"threads must be >= 1, got {requested}")
        return requested
    return max(1, min(available_cpus(), config.MAX_TORCH_THREADS))
