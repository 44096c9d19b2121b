"""Colour encoder (FORMAT.md 1.1, `colr`): a second small SIREN fitted on the decoded surface.

The geometry is decoded exactly as the decoder will (the numpy reference extractor at a resolution),
and the network is fitted to both terms of the colour PSNR (metrics.md), on pairs drawn fresh every
epoch: points area-uniform on that surface with the colour of the nearest ground-truth point (in the
geometry's unit frame), and the decoded points nearest ground-truth points with those points' colours.
The network (8 frequencies at β = 1.7, three sine layers at ω₀ = 20, 3 sigmoid outputs: config.py says
why) learns 2·sigmoid(y) − 1 against the colours mapped to [-1, 1] with the geometry's λ·Σ|θ| term,
then is quantized per layer with a short QAT, like the geometry's.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass

import numpy as np
import torch
from scipy.spatial import cKDTree

from . import config
from .bitstream import (
    COLOR_SPACE_RGB,
    MAX_BITS,
    MAX_FREQUENCIES,
    MAX_WIDTH,
    MIN_BITS,
    OUTPUT_SIGMOID,
    ColorChunk,
    NfcFile,
)
from .errors import InputError
from .io import Shape
from .model import Siren
from .normalize import to_unit
from .quantize import quantized_network
from .reference import ExtractedMesh, extract_unit_mesh, frame_of, sample_points
from .train import Batch, optimize, quantizer

MIN_RESOLUTION, MAX_RESOLUTION = 8, 1024  # the decoder's grid range


@dataclass
class ColorOptions:
    width: int = config.COLOR_WIDTH
    bits: int = config.DEFAULT_BITS
    resolution: int = config.COLOR_RESOLUTION
    frequencies: int = config.COLOR_NUM_FREQUENCIES  # L of the colour network's encoding
    epochs: int | None = None  # overrides the schedule's epoch count (QAT unchanged)
    seed: int = 0
    quiet: bool = False


@dataclass
class ColorFit:
    chunk: ColorChunk
    validation_loss: float  # mean squared error in [-1, 1] units of the network that was kept
    surface_vertices: int  # of the decoded surface the colour was fitted on
    seconds: float


def check_color_options(options: ColorOptions) -> None:
    if not 1 <= options.width <= MAX_WIDTH:
        raise InputError(f"colour width {options.width} outside 1..{MAX_WIDTH}")
    if not MIN_BITS <= options.bits <= MAX_BITS:
        raise InputError(f"colour bit width {options.bits} outside {MIN_BITS}..{MAX_BITS}")
    if not MIN_RESOLUTION <= options.resolution <= MAX_RESOLUTION:
        raise InputError(f"colour resolution {options.resolution} outside {MIN_RESOLUTION}..{MAX_RESOLUTION}")
    if not 0 <= options.frequencies <= MAX_FREQUENCIES:
        raise InputError(f"{options.frequencies} colour frequencies outside 0..{MAX_FREQUENCIES}")
    if options.epochs is not None and options.epochs < 0:
        raise InputError(f"colour epochs must be non-negative, got {options.epochs}")


def color_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Squared error of 2·sigmoid(y) − 1 (pred is sigmoid(y)) against targets in [-1, 1]."""
    return ((2.0 * pred - 1.0 - target) ** 2).mean()


class _SurfaceColors:
    """Training pairs for both directions of the colour PSNR (metrics.md): a point drawn on the
    decoded surface with the colour of its nearest ground-truth point (rec -> gt), and the decoded
    point nearest a ground-truth point with that point's colour (gt -> rec). The second kind is taken
    from clouds drawn as the decoder draws them (area-uniform on the decoded surface, as many points
    as the ground truth up to config.COLOR_MAX_TRUTH_POINTS), so that the pairs follow the metric's own
    matching."""

    def __init__(self, mesh: ExtractedMesh, shape: Shape, geometry: NfcFile, rng: np.random.Generator,
                 device: torch.device) -> None:
        assert shape.colors is not None
        g = geometry.geometry
        self.mesh, self.rng, self.device = mesh, rng, device
        truth = to_unit(shape.vertices, *frame_of(g))
        self.tree = cKDTree(truth)
        self.targets = torch.from_numpy(shape.colors.astype(np.float32) * np.float32(2.0 / 255.0) - np.float32(1.0))
        self.seen_from = np.zeros(0, np.int64)  # the ground-truth points that have decoded neighbours
        self.seen_at = np.zeros((0, 0, 3), np.float32)  # (cloud, point, xyz): those neighbours
        if config.COLOR_GROUND_TRUTH_SIDE > 0.0:
            self._find_decoded_neighbours(truth)

    def _find_decoded_neighbours(self, truth: np.ndarray) -> None:
        count = min(len(truth), config.COLOR_MAX_TRUTH_POINTS)
        self.seen_from = self.rng.choice(len(truth), count, replace=False) if count < len(truth) else np.arange(count)
        self.seen_at = np.empty((config.COLOR_DECODED_CLOUDS, count, 3), np.float32)
        for k in range(config.COLOR_DECODED_CLOUDS):
            cloud = sample_points(self.mesh.vertices, self.mesh.faces, count, self.rng).astype(np.float32)
            _, nearest = cKDTree(cloud).query(truth[self.seen_from], k=1, workers=-1)
            self.seen_at[k] = cloud[nearest]

    def draw(self, model: Siren, n: int) -> Batch:
        """n fresh pairs, the points encoded by `model` (on the training device), and their colours."""
        from_truth = int(round(n * config.COLOR_GROUND_TRUTH_SIDE)) if len(self.seen_from) else 0
        u = sample_points(self.mesh.vertices, self.mesh.faces, n - from_truth, self.rng).astype(np.float32)
        _, nearest = self.tree.query(u, k=1, workers=-1)
        if from_truth:
            cloud = self.rng.integers(len(self.seen_at), size=from_truth)
            which = self.rng.integers(len(self.seen_from), size=from_truth)
            u = np.concatenate([u, self.seen_at[cloud, which]])
            nearest = np.concatenate([nearest, self.seen_from[which]])
        with torch.no_grad():
            encoded = model.encoding(torch.from_numpy(u).to(self.device))
        return encoded, self.targets[torch.from_numpy(nearest)].to(self.device)


def _validation_loss(model: Siren, batch: Batch, bits: int) -> float:
    with torch.no_grad():
        return float(color_loss(model.forward_encoded(batch[0], quantizer(bits)), batch[1]))


@dataclass
class ColorSurface:
    """The decoded surface a colour network is fitted on, and the source of its training pairs: built
    once per geometry, resolution and seed, and shared by every fit on them (a rate search's widths).
    Building it draws from the numpy stream; each fit continues a copy of the stream as it stood
    then, so a fit on a shared surface is byte for byte the fit on a fresh one."""

    resolution: int
    seed: int
    mesh: ExtractedMesh
    pairs: _SurfaceColors


def color_surface(geometry: NfcFile, shape: Shape, resolution: int, seed: int, device: torch.device) -> ColorSurface:
    """The surface `geometry` decodes to at `resolution`, with the colours of `shape` (InputError
    when it has none, or when the geometry decodes to no surface)."""
    if shape.colors is None:
        raise InputError(f"{shape.name}: has no colours to encode")
    mesh = extract_unit_mesh(geometry, resolution)
    if len(mesh.faces) == 0:
        raise InputError(f"{shape.name}: the decoded geometry has no surface to colour")
    return ColorSurface(resolution, seed, mesh, _SurfaceColors(mesh, shape, geometry, np.random.default_rng(seed), device))


def fit_color(geometry: NfcFile, shape: Shape, options: ColorOptions, device: torch.device,
              surface: ColorSurface | None = None) -> ColorFit:
    """The colour chunk of `shape` (which must have colours) on the surface `geometry` decodes to;
    `surface`, when given, is that surface (`color_surface` of this geometry and shape, at the
    options' resolution and seed), built once for several fits."""
    start = time.perf_counter()
    check_color_options(options)
    if surface is None:
        surface = color_surface(geometry, shape, options.resolution, options.seed, device)
    elif (surface.resolution, surface.seed) != (options.resolution, options.seed):
        raise ValueError(f"a colour surface of resolution {surface.resolution} and seed {surface.seed} given "
                         f"to a fit at {options.resolution} and seed {options.seed}")
    pairs = copy.copy(surface.pairs)
    pairs.rng = copy.deepcopy(surface.pairs.rng)
    schedule = config.COLOR_SCHEDULE
    epochs = schedule.epochs_at(options.width) if options.epochs is None else options.epochs
    generator = torch.Generator().manual_seed(options.seed)
    model = Siren(options.width, "sigmoid", outputs=3, hidden_layers=config.COLOR_HIDDEN_LAYERS,
                  num_frequencies=options.frequencies, frequency_base=config.COLOR_FREQUENCY_BASE,
                  omega0=config.COLOR_OMEGA0, generator=generator)
    model = model.to(device)
    validation = pairs.draw(model, schedule.validation_points)

    def batches() -> list[Batch]:
        encoded, targets = pairs.draw(model, schedule.points)
        return list(zip(encoded.split(schedule.batch_size), targets.split(schedule.batch_size)))

    steps = -(-schedule.points // schedule.batch_size)
    optimize(model, batches, color_loss, epochs=epochs, steps_per_epoch=steps, lr=schedule.lr_at(options.width),
             cosine=True, quiet=options.quiet, desc="colour")
    best_loss = _validation_loss(model, validation, options.bits)
    best_layers = copy.deepcopy(model.layers)
    if schedule.qat_epochs > 0:
        optimize(model, batches, color_loss, epochs=schedule.qat_epochs, steps_per_epoch=steps, lr=schedule.qat_lr,
                 cosine=True, bits=options.bits, quiet=options.quiet, desc="colour qat")
        qat_loss = _validation_loss(model, validation, options.bits)
        if qat_loss < best_loss:
            best_loss, best_layers = qat_loss, model.layers
    network = quantized_network(best_layers.cpu(), options.bits, num_frequencies=options.frequencies,
                                frequency_base=config.COLOR_FREQUENCY_BASE, omega0=config.COLOR_OMEGA0,
                                output=OUTPUT_SIGMOID)
    return ColorFit(ColorChunk(COLOR_SPACE_RGB, network), best_loss, len(surface.mesh.vertices),
                    time.perf_counter() - start)
