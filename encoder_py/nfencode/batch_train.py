"""Many shapes at once: K networks of one width trained as one batched model.

The K SIRENs' weights are stacked into (K, out, in) tensors and every layer is one batched matrix
product (`torch.baddbmm`), so one kernel launch serves all K shapes: on a GPU, where a single tiny
network (≤ 20k parameters) leaves the device nearly idle, this is what makes shapes per minute scale.

It is the one-by-one pipeline of `encoder.compress`, shape by shape, not an approximation of it:

- each shape gets its own frame, field choice, ground-truth pool and initial weights from its own
  seeded streams (`encoder.prepare`), exactly those one-by-one encoding would draw;
- each shape draws its own epochs from its own pool (per-shape sampling) with its own stream;
- the objective is the sum of the K per-shape objectives (truncated loss + λ·Σ|θ|), so each shape's
  gradient is its own, and Adam is elementwise, so each shape's update is what it would be alone;
- a UDF with sides (a mesh's, or an oriented cloud's) trains its first epochs as the signed field
  of its sides, as `train.fit` does;
- QAT quantizes each shape's tensors on their own grids (per shape, per tensor), and each shape keeps
  whichever of its pre- and post-QAT networks validates better.

The results differ from one-by-one encoding only by float rounding (batched vs. single matrix
products), which training then amplifies a little; `tests/python/test_batch_train.py` bounds the
quality difference. Optional early stopping (`patience`) freezes a shape whose validation loss has
not improved for `patience` epochs (it keeps its best weights) and ends the phase when all are frozen.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from . import config
from .bitstream import max_level
from .devices import cpu_threads, resolve_device
from .encoder import EncodeConfig, EncodeResult, Prepared, add_color, check_config, finish, prepare, wants_color
from .io import Shape
from .sampling import draw_epoch, epoch_counts
from .train import TrainingData, signed_epochs


def batched_fake_quantize(x: torch.Tensor, bits: int) -> torch.Tensor:
    """`quantize.fake_quantize` of each x[k] on its own grid (step = max|x[k]| / (2^(b-1) − 1))."""
    dims = tuple(range(1, x.ndim))
    peak = x.detach().abs().amax(dim=dims, keepdim=True).to(torch.float32)
    step = torch.where(peak > 0, peak / max_level(bits), torch.ones_like(peak))
    limit = max_level(bits)
    levels = torch.round(x.detach().to(torch.float64) / step.to(torch.float64)).clamp_(-limit, limit)
    snapped = levels.to(torch.float32) * step
    return x + (snapped - x).detach()


@dataclass
class StackedSiren:
    """K SIRENs of one shape: weights[i] (K, out, in), biases[i] (K, out); `absolute[k]` for UDFs."""

    weights: list[torch.Tensor]
    biases: list[torch.Tensor]
    absolute: torch.Tensor  # (K,) bool
    omega0: float = config.OMEGA0

    @classmethod
    def stack(cls, preps: Sequence[Prepared], device: torch.device) -> StackedSiren:
        layers = [p.model.layers for p in preps]
        weights = [torch.stack([m[i].weight.detach() for m in layers]).to(device).requires_grad_()
                   for i in range(len(layers[0]))]
        biases = [torch.stack([m[i].bias.detach() for m in layers]).to(device).requires_grad_()
                  for i in range(len(layers[0]))]
        absolute = torch.tensor([p.model.output == "abs" for p in preps], device=device)
        return cls(weights, biases, absolute)

    def parameters(self) -> list[torch.Tensor]:
        return [*self.weights, *self.biases]

    def forward(self, h: torch.Tensor, bits: int | None = None) -> torch.Tensor:
        """(K, B, D) encoded points → (K, B) field values; `bits`: through fake quantization (QAT)."""
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            if bits is not None:
                w, b = batched_fake_quantize(w, bits), batched_fake_quantize(b, bits)
            h = torch.baddbmm(b.unsqueeze(1), h, w.transpose(1, 2))
            if i < last:
                h = torch.sin(self.omega0 * h)
        y = h[..., 0]
        return torch.where(self.absolute[:, None], y.abs(), y)

    def l1(self) -> torch.Tensor:
        """(K,) Σ|θ| of each network."""
        return sum(p.abs().flatten(1).sum(dim=1) for p in self.parameters())  # type: ignore[return-value]

    def snapshot(self) -> list[torch.Tensor]:
        return [p.detach().clone() for p in self.parameters()]

    def restore(self, saved: list[torch.Tensor], which: torch.Tensor) -> None:
        """Put back the saved weights of the shapes where `which` (K,) is true."""
        with torch.no_grad():
            for p, s in zip(self.parameters(), saved):
                p[which] = s[which]

    def write_back(self, preps: Sequence[Prepared], saved: list[torch.Tensor]) -> None:
        """Copy saved stacked weights into each shape's own Siren (on the CPU)."""
        n = len(self.weights)
        with torch.no_grad():
            for k, prep in enumerate(preps):
                for i, layer in enumerate(prep.model.layers):
                    layer.weight.copy_(saved[i][k].cpu())
                    layer.bias.copy_(saved[n + i][k].cpu())


def per_shape_loss(pred: torch.Tensor, distance: torch.Tensor, truncation: torch.Tensor) -> torch.Tensor:
    """`train.truncated_loss` of each row, at its shape's d* (truncation: (K, 1)): (K, B) → (K,)."""
    target = torch.minimum(torch.maximum(distance, -truncation), truncation)
    counted = (distance.abs() <= truncation) | (pred.abs() <= truncation)
    return torch.where(counted, (pred - target) ** 2, torch.zeros_like(pred)).mean(dim=1)


@dataclass
class StackedData:
    encoded: torch.Tensor  # (K, n, D)
    distances: torch.Tensor  # (K, n)
    validation_encoded: torch.Tensor
    validation_distances: torch.Tensor
    sides: torch.Tensor  # (K, n): TrainingData.sides, ones for a shape without them
    has_sides: torch.Tensor  # (K,) bool
    truncation: torch.Tensor  # (K, 1): each shape's d* (Prepared.truncation)


def validation_losses(net: StackedSiren, data: StackedData, bits: int | None) -> torch.Tensor:
    with torch.no_grad():
        return per_shape_loss(net.forward(data.validation_encoded, bits), data.validation_distances,
                              data.truncation)


def fit_many(
    net: StackedSiren,
    data: StackedData,
    preps: Sequence[Prepared],
    *,
    epochs: int,
    lr: float,
    cosine: bool,
    batch_size: int,
    bits: int | None = None,
    signed: int = 0,
    patience: int | None = None,
) -> int:
    """`train.fit` for K shapes at once (module docstring); the shapes with sides train the first
    `signed` epochs as signed fields. Returns the epochs run."""
    optimizer = torch.optim.Adam(net.parameters(), lr=lr)
    batches_per_epoch = math.ceil(sum(epoch_counts(1.0)) / batch_size)
    total_steps = max(1, epochs * batches_per_epoch)
    k = len(preps)
    rows = torch.arange(k, device=data.encoded.device)[:, None]
    frozen = torch.zeros(k, dtype=torch.bool, device=data.encoded.device)
    best_loss = validation_losses(net, data, bits) if patience is not None else None
    best = net.snapshot() if patience is not None else None
    stale = torch.zeros(k, dtype=torch.int64, device=data.encoded.device)
    step = 0
    absolute = net.absolute
    signed_targets = data.distances * data.sides if signed > 0 else data.distances  # sides: 1 without them
    for epoch in range(epochs):
        order = torch.from_numpy(np.stack([draw_epoch(p.pool, p.rng) for p in preps])).to(data.encoded.device)
        targets = signed_targets if epoch < signed else data.distances
        net.absolute = absolute & ~(data.has_sides & (epoch < signed))
        for batch in order.split(batch_size, dim=1):
            if cosine:
                for group in optimizer.param_groups:
                    group["lr"] = 0.5 * lr * (1.0 + math.cos(math.pi * step / total_steps))
            pred = net.forward(data.encoded[rows, batch], bits)
            loss = per_shape_loss(pred, targets[rows, batch], data.truncation)
            optimizer.zero_grad(set_to_none=True)
            (loss + config.L1_WEIGHT * net.l1()).sum().backward()
            optimizer.step()
            step += 1
        net.absolute = absolute
        if patience is not None:
            assert best is not None and best_loss is not None
            current = validation_losses(net, data, bits)
            improved = (current < best_loss) & ~frozen
            for saved, p in zip(best, net.parameters()):
                saved[improved] = p.detach()[improved]
            best_loss = torch.where(improved, current, best_loss)
            stale = torch.where(improved, torch.zeros_like(stale), stale + 1)
            frozen |= stale >= patience
            net.restore(best, frozen)  # frozen shapes keep their best weights
            if bool(frozen.all()):
                return epoch + 1
    if patience is not None and best is not None:
        net.restore(best, torch.ones_like(frozen))
    return epochs


def _prepare_stacked(shapes: Sequence[Shape], cfg: EncodeConfig,
                     device: torch.device) -> tuple[list[Prepared], StackedData]:
    """Each shape's `encoder.prepare` (on the CPU), its training data copied into one stacked
    (K, ...) tensor per kind on `device` and then dropped, so peak memory is the stack plus one shape
    (~200 MB per shape at the default 100k surface points per epoch and 16 frequencies)."""
    names = ("encoded", "distances", "validation_encoded", "validation_distances")
    preps: list[Prepared] = []
    stacked: list[torch.Tensor] = []
    has_sides = torch.zeros(len(shapes), dtype=torch.bool, device=device)
    for k, shape in enumerate(shapes):
        prep = prepare(shape, cfg, torch.device("cpu"))
        sides = prep.data.sides if prep.data.sides is not None else torch.ones_like(prep.data.distances)
        parts = [getattr(prep.data, name) for name in names] + [sides]
        if k == 0:
            stacked = [torch.empty((len(shapes), *t.shape), dtype=t.dtype, device=device) for t in parts]
        for target, part in zip(stacked, parts):
            target[k].copy_(part)
        has_sides[k] = prep.data.sides is not None
        prep.data = TrainingData(*(torch.empty(0) for _ in names))  # the stack holds it now
        preps.append(prep)
    truncation = torch.tensor([[p.truncation] for p in preps], dtype=torch.float32, device=device)
    return preps, StackedData(*stacked, has_sides, truncation)


def compress_many(shapes: Sequence[Shape], cfg: EncodeConfig, *, patience: int | None = None) -> list[EncodeResult]:
    """Encode every shape with the same settings (width, bits, preset, epochs, seed) as one batched
    model; the i-th result is what `encoder.compress(shapes[i], cfg)` computes, up to float rounding.
    Every EncodeResult.seconds is the wall time of the whole group."""
    start = time.perf_counter()
    preset = check_config(cfg)
    device = resolve_device(cfg.device)
    epochs = preset.epochs if cfg.epochs is None else cfg.epochs
    if not shapes:
        return []
    previous_threads = torch.get_num_threads()
    torch.set_num_threads(cpu_threads(cfg.threads))
    try:
        preps, data = _prepare_stacked(shapes, cfg, device)
        net = StackedSiren.stack(preps, device)
        schedule = {"batch_size": preset.batch_size, "patience": patience}
        fit_many(net, data, preps, epochs=epochs, lr=preset.lr, cosine=preset.cosine,
                 signed=signed_epochs(epochs), **schedule)

        best_loss = validation_losses(net, data, cfg.bits)
        best = net.snapshot()
        if preset.qat_epochs > 0:
            fit_many(net, data, preps, epochs=preset.qat_epochs, lr=preset.qat_lr, cosine=True, bits=cfg.bits,
                     **schedule)
            qat_loss = validation_losses(net, data, cfg.bits)
            better = qat_loss < best_loss
            for saved, p in zip(best, net.parameters()):
                saved[better] = p.detach()[better]
            best_loss = torch.where(better, qat_loss, best_loss)
        net.write_back(preps, best)
        losses = best_loss.cpu().tolist()
        results = [finish(prep, prep.model.layers, cfg.bits, loss, start) for prep, loss in zip(preps, losses)]
        return [add_color(result, shape, cfg, device) if wants_color(shape, cfg) else result
                for result, shape in zip(results, shapes)]
    finally:
        torch.set_num_threads(previous_threads)
