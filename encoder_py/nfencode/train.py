"""Training: Adam with the λ·Σ|θ| term and QAT for any network and loss (`optimize`), and the
geometry's use of it: the paper's truncated loss over epochs drawn from the pool (`fit`).

The positional encoding of every pool point is computed once up front (it does not depend on the
weights); an epoch then only gathers rows. On 2 cores this halves the time of an epoch at W = 32.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np
import torch
from tqdm import tqdm

from . import config
from .model import ParameterTransform, Siren
from .quantize import fake_quantize
from .sampling import DistancePool, draw_epoch, epoch_counts

ENCODE_CHUNK = 100_000


@dataclass
class TrainingData:
    """Encoded pool (n, 3 + 6L) and distances (n,), the same for the validation set, and the pool's
    sides (n,) where it has them (a UDF with sides: DistancePool.sides)."""

    encoded: torch.Tensor
    distances: torch.Tensor
    validation_encoded: torch.Tensor
    validation_distances: torch.Tensor
    sides: torch.Tensor | None = None


def _encode(model: Siren, points: np.ndarray) -> torch.Tensor:
    u = torch.from_numpy(points)
    out = torch.empty(len(u), model.encoding.out_features)
    with torch.no_grad():
        for i in range(0, len(u), ENCODE_CHUNK):
            out[i : i + ENCODE_CHUNK] = model.encoding(u[i : i + ENCODE_CHUNK])
    return out


def prepare_data(model: Siren, pool: DistancePool) -> TrainingData:
    return TrainingData(
        _encode(model, pool.points),
        torch.from_numpy(pool.distances),
        _encode(model, pool.validation_points),
        torch.from_numpy(pool.validation_distances),
        None if pool.sides is None else torch.from_numpy(pool.sides),
    )


def signed_epochs(epochs: int) -> int:
    """How many of `epochs` a fit of data with sides trains as a signed field first (`fit`)."""
    return round(epochs * config.UDF_SIGNED_EPOCHS)


def truncated_loss(pred: torch.Tensor, distance: torch.Tensor, truncation: float) -> torch.Tensor:
    """Paper loss: (pred − sgn(d)·min(|d|, d*))², counted where |d| ≤ d* or |pred| ≤ d*, mean over
    the batch. Far points whose prediction stays beyond d* cost nothing: only the band matters."""
    target = torch.clamp(distance, -truncation, truncation)
    counted = (distance.abs() <= truncation) | (pred.abs() <= truncation)
    return torch.where(counted, (pred - target) ** 2, torch.zeros_like(pred)).mean()


def add_l1_gradient(parameters: list[torch.Tensor]) -> None:
    """Adds the gradient of λ·Σ|θ|, λ·sign(θ), to each parameter's gradient: the sum autograd forms
    for loss + λ·Σ|θ| bit for bit (one addition of the same two terms), without the penalty's
    dozen extra graph nodes per step (10% of a width-16 step)."""
    for p in parameters:
        assert p.grad is not None  # every parameter is in the loss's graph
        p.grad.add_(p.sign(), alpha=config.L1_WEIGHT)


def quantizer(bits: int | None) -> ParameterTransform | None:
    return None if bits is None else (lambda x: fake_quantize(x, bits))


def validation_loss(model: Siren, data: TrainingData, bits: int | None, truncation: float) -> float:
    """Truncated loss on the held-out set, of the float network or of its b-bit quantization."""
    with torch.no_grad():
        pred = model.forward_encoded(data.validation_encoded, quantizer(bits))
        return float(truncated_loss(pred, data.validation_distances, truncation))


Batch = tuple[torch.Tensor, torch.Tensor]  # encoded inputs, targets
LossFn = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]


def optimize(
    model: Siren,
    epoch_batches: Callable[[], Iterable[Batch]],
    loss_fn: LossFn,
    *,
    epochs: int,
    steps_per_epoch: int,
    lr: float,
    cosine: bool,
    bits: int | None = None,
    quiet: bool = False,
    desc: str = "train",
) -> float:
    """Adam on loss_fn(prediction, target) + λ·Σ|θ| over the batches `epoch_batches()` yields for
    each epoch; `bits` trains through fake quantization (QAT).

    The learning rate is constant, or cosine-decayed per step from `lr` to 0 over
    epochs · steps_per_epoch steps. Returns the mean data loss of the last epoch.
    """
    transform = quantizer(bits)
    parameters = list(model.parameters())
    optimizer = torch.optim.Adam(parameters, lr=lr)
    total_steps = max(1, epochs * steps_per_epoch)
    device = parameters[0].device
    step = 0
    epoch_loss = float("nan")
    # disable=None: tqdm draws only on a terminal, so logs and CI output stay free of bar frames.
    bar = tqdm(range(epochs), desc=desc, unit="epoch", disable=True if quiet else None, leave=False,
               dynamic_ncols=True)
    for _ in bar:
        running = torch.zeros((), dtype=torch.float64, device=device)  # no per-step sync on CUDA
        count = 0
        for inputs, targets in epoch_batches():
            if cosine:
                for group in optimizer.param_groups:
                    group["lr"] = 0.5 * lr * (1.0 + math.cos(math.pi * step / total_steps))
            pred = model.forward_encoded(inputs, transform)
            loss = loss_fn(pred, targets)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            add_l1_gradient(parameters)
            optimizer.step()
            running += loss.detach().to(torch.float64) * len(inputs)
            count += len(inputs)
            step += 1
        epoch_loss = float(running) / count
        bar.set_postfix(loss=f"{epoch_loss:.3e}")
    bar.close()
    return epoch_loss


def fit(
    model: Siren,
    data: TrainingData,
    pool: DistancePool,
    *,
    epochs: int,
    lr: float,
    cosine: bool,
    batch_size: int,
    rng: np.random.Generator,
    truncation: float,
    bits: int | None = None,
    signed: int = 0,
    quiet: bool = False,
    desc: str = "train",
) -> float:
    """`optimize` on the truncated loss at d* = `truncation` over epochs drawn from the geometry pool.
    The first `signed` epochs (data with sides: `signed_epochs`) fit the output before its `abs` to the
    distances signed by data.sides, in the same schedule: an `abs` network whose inner field has a side
    per region of space keeps a zero set wherever two regions meet, and one started from random weights
    leaves such phantom sheets near the surface (and holes where they cut it); started from the sides,
    the inner field is near the surface a signed distance, whose only zero set is the surface
    (bench/RESULTS.md, issue 6)."""
    output = model.output
    signed_targets = data.distances * data.sides if signed > 0 and data.sides is not None else None
    epoch = 0

    def batches() -> Iterator[Batch]:
        nonlocal epoch
        is_signed = epoch < signed and signed_targets is not None
        epoch += 1
        model.output = "identity" if is_signed else output
        targets = signed_targets if is_signed else data.distances
        order = torch.from_numpy(draw_epoch(pool, rng)).to(data.encoded.device)
        for batch in order.split(batch_size):
            # index_select, not data.encoded[batch]: the same rows, 5x faster on the CPU than
            # advanced indexing's generic kernel (a fifth of an epoch's time at width 16)
            yield data.encoded.index_select(0, batch), targets.index_select(0, batch)

    loss = functools.partial(truncated_loss, truncation=truncation)
    try:
        return optimize(model, batches, loss, epochs=epochs,
                        steps_per_epoch=math.ceil(sum(epoch_counts(1.0)) / batch_size), lr=lr, cosine=cosine,
                        bits=bits, quiet=quiet, desc=desc)
    finally:
        model.output = output
