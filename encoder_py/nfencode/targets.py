"""Encoding to a target: the best file of at most B bytes (`compress_to_bytes`) and the smallest file
whose estimated Chamfer distance is at most C (`compress_to_distortion`).

Both repeat `encoder.compress` at the widths `rate` chooses, and every try of one call shares a
`ShapeWork` (the shape's training pool, a geometry's decoded colour surface), so a try costs its
training and writes the bytes it would write alone. `nfc encode --target-bytes / --target-cd` run
these; `report`, when given, hears one line per finished try (a search takes minutes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from . import config, rate
from .bitstream import read_nfc
from .encoder import EncodeConfig, EncodeResult, ShapeWork, compress, wants_color
from .errors import InputError
from .io import Shape
from .metrics import file_chamfer_distance

Report = Callable[[str], None]


def _quiet(_: str) -> None:
    pass


def compress_to_bytes(shape: Shape, cfg: EncodeConfig, budget: int, geometry: bytes | None = None,
                      color_bits: int | None = None, report: Report = _quiet) -> tuple[EncodeResult, rate.RateChoice]:
    """The widest file of at most `budget` bytes (cfg's width and colour width are chosen; its bits
    are the geometry's, lowered below rate.MIN_WIDTH). On a coloured input (`wants_color`) the
    budget bounds the whole file: a geometry sized to its share of it (rate.geometry_budget), or
    `geometry` (an `.nfc` of this shape) as it is, then the widest colour network at `color_bits`
    (config.TARGET_COLOR_BITS when None) that fits on it. InputError when the budget is no positive
    integer or no file fits in it, or when `geometry` is given for an input without colours."""
    rate.check_targets(budget, None)
    color = wants_color(shape, cfg)
    if geometry is not None and not color:
        raise InputError("--target-bytes with --geometry sizes the colour network: the input needs colours "
                         "(and no --no-color)")
    color_bits = config.TARGET_COLOR_BITS if color_bits is None else color_bits
    geometry_budget = budget
    if color and geometry is None:
        geometry_budget = rate.geometry_budget(budget, cfg.bits, color_bits, cfg.frequencies, cfg.color_frequencies)
        if geometry_budget < rate.FIXED_BYTES:
            raise InputError(f"no file with colour fits in {budget} bytes (pass --no-color for geometry only)")
    geometry_choice = rate.RateChoice(0, 0, [])
    searched = None
    work = ShapeWork()  # every try's pool, and the chosen geometry's surface for every colour try
    if geometry is None:
        geometry_only = dataclasses.replace(cfg, color="off")
        results: dict[tuple[int, int], EncodeResult] = {}

        def encode(width: int, bits: int) -> bytes:
            results[(width, bits)] = compress(shape, dataclasses.replace(geometry_only, width=width, bits=bits),
                                              work=work)
            report(f"tried geometry width {width}, {bits} bits: {len(results[(width, bits)].data)} bytes")
            return results[(width, bits)].data

        _, geometry_choice = rate.choose(geometry_budget, cfg.bits, encode, rate.NetworkSize(cfg.frequencies))
        result = results[(geometry_choice.width, geometry_choice.bits)]
        if not color:
            return result, geometry_choice
        searched, geometry = result, result.data
    colored: dict[tuple[int, int], EncodeResult] = {}

    def encode_color(width: int, bits: int) -> bytes:
        colored[(width, bits)] = compress(shape, dataclasses.replace(cfg, color_width=width, color_bits=bits),
                                          geometry, work)
        report(f"tried colour width {width}, {bits} bits: {len(colored[(width, bits)].data)} bytes with the geometry")
        return colored[(width, bits)].data

    _, color_choice = rate.choose(budget, color_bits, encode_color, rate.color_size(len(geometry), cfg.color_frequencies))
    chosen = colored[(color_choice.width, color_choice.bits)]
    if searched is not None:
        chosen = _reporting_own_geometry(chosen, searched)
    g = read_nfc(chosen.data).geometry.network
    return chosen, dataclasses.replace(geometry_choice, width=g.out_features[0], bits=g.bits, color=color_choice)


def compress_to_distortion(shape: Shape, cfg: EncodeConfig, target_cd: float,
                           report: Report = _quiet) -> tuple[EncodeResult, rate.DistortionChoice]:
    """The smallest geometry (cfg's width is chosen) whose CD, estimated on the reference decoder's
    mesh at config.TARGET_CD_RESOLUTION (metrics.md, seed cfg.seed), is at most `target_cd`. CD is
    the geometry's measure, so the search encodes geometry only; a coloured input then gets its
    colour network (cfg's colour width and bits) fitted on the geometry chosen, as `compress` would.
    InputError when the target is not a positive number or no width up to the search's reaches it."""
    rate.check_targets(None, target_cd)
    geometry_only = dataclasses.replace(cfg, color="off")
    results: dict[int, EncodeResult] = {}
    work = ShapeWork()  # the pool, built by the first try for all

    def encode(width: int, bits: int) -> bytes:
        results[width] = compress(shape, dataclasses.replace(geometry_only, width=width, bits=bits), work=work)
        return results[width].data

    def estimate(data: bytes) -> float:
        cd = file_chamfer_distance(shape, data, config.TARGET_CD_RESOLUTION, seed=cfg.seed)
        width = read_nfc(data).geometry.network.out_features[0]
        report(f"tried geometry width {width}: {len(data)} bytes, estimated CD {cd:.5g}")
        return cd

    _, choice = rate.choose_for_distortion(target_cd, cfg.bits, encode, estimate)
    result = results[choice.width]
    if wants_color(shape, cfg):
        result = _reporting_own_geometry(compress(shape, cfg, result.data), result)
    return result, choice


def _reporting_own_geometry(colored: EncodeResult, geometry: EncodeResult) -> EncodeResult:
    """`colored` (a colour fitted on `geometry`'s bytes, which compress reports as reused) with what
    this search's own geometry encode found: why its field, its loss, the time of both."""
    return dataclasses.replace(colored, field_reason=geometry.field_reason, final_loss=geometry.final_loss,
                               seconds=geometry.seconds + colored.seconds)
