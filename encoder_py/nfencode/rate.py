"""Rate control: `nfc encode --target-bytes B`, the widest network whose file fits in B bytes, and
`--target-cd C`, the narrowest whose file's estimated Chamfer distance is at most C.

The width sets the rate (FORMAT.md: P = W^2 + (3 + 6L + 3) W + 1 parameters for two hidden layers),
and a file costs about `rate` bytes per parameter at a given bit width, plus framing. The rate is
the shape's own (how well brotli compresses its levels), so it is measured, not assumed: the first
encode uses a prior, every encode after it the rate of the previous file. Encodes are repeated at a
smaller width while the file is too large and tried once at a larger width when the best fitting one
leaves room; the result is the widest file found that is at most B bytes, never a larger one. Below
width MIN_WIDTH at the requested bit width, the bit width comes down (7, then 6) before giving up.

The distortion target searches the width alone (at the requested bits): the CD falls as the width
grows (bench/RESULTS.md), so the narrowest width whose estimate meets C is bracketed by doubling or
halving from a start width, then narrowed by bisection in log width until the bracket is within
about 12% (a step of the bits a file saves there). Training noise makes the CD only nearly
monotonic in the width; the file written is the smallest of those tried whose estimate is at most
C, so the bound holds on the estimate by construction.

With colour, `--target-bytes` bounds the whole file: the geometry first gets a share of the budget
(COLORED_GEOMETRY_SHARE, held between the predicted files of the widths COLORED_GEOMETRY_WIDTHS;
config.py says why), found by the search above, then the same search sizes the colour network on
that geometry to the whole budget.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import config
from .bitstream import CHUNK_OVERHEAD, HEADER_SIZE, MAX_WIDTH, MIN_BITS, parameter_count
from .errors import InputError

MIN_WIDTH = 4
MAX_ENCODES = 5  # each is a full encode: the search stops there with the best that fits
# Bytes per parameter of 8-bit files by frequency count L (interpolated between, held beyond):
# L = 16 bunny and armadillo at widths 16-96 (RESULTS.md "Rate control"); L = 8 the median of the
# five shapes at widths 16-48 (0.87-0.93; "Where the parameters go"): the weights of the top
# octaves that L = 8 drops were the cheapest. Colour networks cost about the same (loot, 6 bits:
# 0.61 bytes per parameter, i.e. 0.82 at 8 bits).
PRIOR_BYTES_PER_PARAMETER_8_BITS = {8: 0.90, 16: 0.72}
NETWORK_FIELDS = 48  # a network block's fields before its brotli stream, with room to spare
FIXED_BYTES = HEADER_SIZE + CHUNK_OVERHEAD + NETWORK_FIELDS  # header, GEOM framing, frame and network fields
LOWEST_BITS = 6  # the bit widths tried below MIN_WIDTH: the requested one down to this
SAFETY = 1.03  # after a file too large: aim 3% under the measured rate's prediction


@dataclass(frozen=True)
class NetworkSize:
    """How a file's size follows the width of the network the search sizes: `hidden_layers` sine
    layers of that width after an encoding of `frequencies`, `outputs` outputs, and `fixed_bytes`
    of everything else in the file (the geometry's: FIXED_BYTES)."""

    frequencies: int = config.NUM_FREQUENCIES
    hidden_layers: int = config.HIDDEN_LAYERS
    outputs: int = 1
    fixed_bytes: int = FIXED_BYTES

    def parameters(self, width: int) -> int:
        return parameter_count(self.frequencies, [width] * self.hidden_layers + [self.outputs])

    def width_for(self, budget: int, bytes_per_parameter: float) -> int:
        """The largest width whose predicted file fits in `budget` bytes (0 if none)."""
        usable = (budget - self.fixed_bytes) / bytes_per_parameter
        # P(W) = (h - 1) W^2 + (inputs + h + outputs) W + outputs, increasing in W
        a = self.hidden_layers - 1
        b = 3 + 6 * self.frequencies + self.hidden_layers + self.outputs
        c = self.outputs - usable
        if c > 0:
            return 0
        root = -c / b if a == 0 else (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
        width = max(0, int(root))
        while width > 0 and self.parameters(width) > usable:  # float rounding at the boundary
            width -= 1
        return width


GEOMETRY = NetworkSize()


def color_size(geometry_bytes: int, frequencies: int = config.COLOR_NUM_FREQUENCIES) -> NetworkSize:
    """The colour network's size model in a file whose geometry takes `geometry_bytes` (the file
    without colour, header included)."""
    return NetworkSize(frequencies, config.COLOR_HIDDEN_LAYERS, 3, geometry_bytes + CHUNK_OVERHEAD + 1 + NETWORK_FIELDS)


@dataclass
class Attempt:
    width: int
    bits: int
    bytes: int


@dataclass
class RateChoice:
    """What --target-bytes chose: the written file's width and bits, and every encode tried; with
    colour, the colour network's own choice (its attempts' bytes are whole files')."""

    width: int
    bits: int
    attempts: list[Attempt]
    color: RateChoice | None = None


def prior_bytes_per_parameter(frequencies: int) -> float:
    points = sorted(PRIOR_BYTES_PER_PARAMETER_8_BITS.items())
    return float(np.interp(frequencies, [L for L, _ in points], [r for _, r in points]))


def parameters(width: int, frequencies: int = config.NUM_FREQUENCIES) -> int:
    """A geometry network's parameter count at `width`."""
    return NetworkSize(frequencies).parameters(width)


def predicted_bytes(size: NetworkSize, width: int, bits: int) -> int:
    """The file's bytes at `width` by the prior rate."""
    return size.fixed_bytes + math.ceil(prior_bytes_per_parameter(size.frequencies) * bits / 8 * size.parameters(width))


def geometry_budget(budget: int, bits: int, color_bits: int, frequencies: int = config.NUM_FREQUENCIES,
                    color_frequencies: int = config.COLOR_NUM_FREQUENCIES) -> int:
    """The bytes the geometry of a coloured file gets out of `budget` (module docstring): its
    share, held between the predicted files of COLORED_GEOMETRY_WIDTHS, and never so much that the
    narrowest colour network could not follow."""
    size = NetworkSize(frequencies)
    low, high = (predicted_bytes(size, w, bits) for w in config.COLORED_GEOMETRY_WIDTHS)
    share = min(max(round(config.COLORED_GEOMETRY_SHARE * budget), low), high)
    color_minimum = predicted_bytes(color_size(0, color_frequencies), MIN_WIDTH, min(color_bits, LOWEST_BITS))
    return min(share, budget - color_minimum)


def check_targets(target_bytes: object, target_cd: object,
                  names: tuple[str, str] = ("target_bytes", "target_cd")) -> None:
    """At most one target; a byte budget a positive integer, a CD target a positive finite number.
    InputError otherwise, naming them as `names` says (command-line flags or manifest keys)."""
    if target_bytes is not None and target_cd is not None:
        raise InputError(f"{names[0]} and {names[1]}: give one target, not both")
    if target_bytes is not None and (isinstance(target_bytes, bool) or not isinstance(target_bytes, int)
                                     or target_bytes < 1):
        raise InputError(f"{names[0]} must be >= 1, got {target_bytes}")
    if target_cd is not None and (isinstance(target_cd, bool) or not isinstance(target_cd, (int, float))
                                  or not 0.0 < target_cd < math.inf):
        raise InputError(f"{names[1]} must be a positive number, not {target_cd}")


def choose(budget: int, bits: int, encode: Callable[[int, int], bytes],
           size: NetworkSize = GEOMETRY) -> tuple[bytes, RateChoice]:
    """The widest file of at most `budget` bytes that `encode(width, bits)` writes (its size
    following `size`), with what was tried. InputError when none of the encodes fits (even width
    MIN_WIDTH at LOWEST_BITS)."""
    attempts: list[Attempt] = []
    best: tuple[bytes, Attempt] | None = None
    too_large = MAX_WIDTH + 1  # the smallest width found too large at the current bits
    rate = prior_bytes_per_parameter(size.frequencies) * bits / 8
    width = min(size.width_for(budget, rate), MAX_WIDTH)
    while len(attempts) < MAX_ENCODES:
        if width < MIN_WIDTH:
            if best is not None or bits <= max(LOWEST_BITS, MIN_BITS):
                break
            rate *= (bits - 1) / bits  # nothing fits at this bit width: one bit less
            bits -= 1
            too_large = MAX_WIDTH + 1
            width = max(MIN_WIDTH, min(size.width_for(budget, rate), MAX_WIDTH))
        data = encode(width, bits)
        attempts.append(Attempt(width, bits, len(data)))
        rate = max((len(data) - size.fixed_bytes) / size.parameters(width), 1e-3)  # this shape's own
        if len(data) <= budget:
            if best is None or width > best[1].width:
                best = (data, attempts[-1])
            wider = min(size.width_for(budget, rate), too_large - 1, MAX_WIDTH)
            if wider <= width:
                break  # no room for a wider network at the measured rate
            width = wider
        else:
            too_large = min(too_large, width)
            width = min(size.width_for(budget, rate * SAFETY), width - 1)
            if best is not None and width <= best[1].width:
                break  # the best fitting width is the widest below a too-large one
    if best is None:
        tried = ", ".join(f"w{a.width} {a.bits} bits: {a.bytes} B" for a in attempts)
        raise InputError(f"no file fits in {budget} bytes (tried {tried})")
    return best[0], RateChoice(best[1].width, best[1].bits, attempts)


MAX_DISTORTION_ENCODES = 7  # each is an encode and a reference decode
BRACKET_RATIO = 1.125       # bisection stops when the passing width is within this of the failing


@dataclass
class DistortionAttempt:
    width: int
    bits: int
    bytes: int
    cd: float


@dataclass
class DistortionChoice:
    """What --target-cd chose: the written file's width, bits and estimated CD, and every try."""

    width: int
    bits: int
    cd: float
    attempts: list[DistortionAttempt]


def choose_for_distortion(target: float, bits: int, encode: Callable[[int, int], bytes],
                          estimate: Callable[[bytes], float], start: int = config.DEFAULT_WIDTH,
                          max_width: int = config.TARGET_CD_MAX_WIDTH) -> tuple[bytes, DistortionChoice]:
    """The smallest file of those tried whose `estimate(data)` is at most `target`, networks of
    widths MIN_WIDTH..max_width at `bits` (module docstring), with what was tried. InputError when
    none meets it (the widest's estimate is in the message)."""
    attempts: list[DistortionAttempt] = []
    best: tuple[bytes, DistortionAttempt] | None = None
    failing, passing = MIN_WIDTH - 1, max_width + 1  # widest known above C, narrowest known at/below
    width = max(MIN_WIDTH, min(start, max_width))
    while len(attempts) < MAX_DISTORTION_ENCODES:
        data = encode(width, bits)
        attempt = DistortionAttempt(width, bits, len(data), float(estimate(data)))
        attempts.append(attempt)
        if attempt.cd <= target:
            passing = min(passing, width)
            if best is None or attempt.bytes < best[1].bytes:
                best = (data, attempt)
        else:
            failing = max(failing, width)
        if passing > max_width:  # nothing meets the target yet: wider
            if width >= max_width:
                break
            width = min(2 * width, max_width)
        elif failing < MIN_WIDTH:  # everything tried meets it: narrower
            if width <= MIN_WIDTH:
                break
            width = max(width // 2, MIN_WIDTH)
        elif passing <= max(failing + 1, int(failing * BRACKET_RATIO)):
            break
        else:
            width = min(max(round(math.sqrt(failing * passing)), failing + 1), passing - 1)
    if best is None:
        tried = ", ".join(f"w{a.width}: CD {a.cd:.5g}" for a in attempts)
        raise InputError(f"no file reaches CD {target:g} up to width {max_width} at {bits} bits "
                         f"(tried {tried})")
    return best[0], DistortionChoice(best[1].width, best[1].bits, best[1].cd, attempts)
