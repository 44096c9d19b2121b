"""Every hyper-parameter of the encoder, in one place.

Values marked *paper* follow Postels et al., "3D Compression Using Neural Fields" (CVPR 2024); the
others were chosen by measurement on the Stanford bunny (numbers in the comments, 2-core x86-64 CPU).
The bitstream fixes nothing here except what the file stores (frequencies, ω₀, bit width, steps).
"""

from __future__ import annotations

from dataclasses import dataclass

# --- Field -----------------------------------------------------------------------------------------
TRUNCATION = {"sdf": 0.05, "udf": 0.1}
"""d* per field: distances are clamped to ±d* and the loss ignores points farther than d*; the file
stores it (GEOM's truncation, which decoders read only as a VDB grid's background). The paper's is
0.1. An SDF at 0.05 spends the network on the band where its zero set is: BD-rate -8% to -18% on
the five shapes of issue 10 over three seeds (at equal width about the same bytes and a CD 0.4% to
5% lower, most at widths 16-24 and on the detailed shapes), for 10-15% more field evaluations in a
decode (the coarse levels keep the cells that read d*: 2.7-2.9 per active cell at 256 instead of
2.4-2.6); 0.03 and below cost far more evaluations (armadillo w96: 4.7 per cell) for little more
CD (bench/RESULTS.md, "A narrower truncation band"). UDFs keep the paper's: at 0.05 five garments
and the bunny moved by -4% to +47% in CD for 12-62% more evaluations (seed 0, width 16 / 32)."""

MIN_TRUNCATION, MAX_TRUNCATION = 0.02, 0.1
"""`--truncation`'s range: at most the paper's 0.1 (the pool stores distances up to sampling.FAR,
twice that); below 0.02 a decode's coarse levels keep nearly every cell."""

AUTO_PROBE_SIGMA = 0.1
"""Std. dev. of the offset of `--field auto`'s probe points (sampling.resolve_field): the paper's d*,
with which AUTO_SDF_MAX_AMBIGUOUS and AUTO_HOLES_MIN_AMBIGUOUS were measured."""

NEAR_SURFACE_SIGMA = {"sdf": 0.01, "udf": 0.025}
"""Std. dev. of the Gaussian offset of near-surface training points, unit-ball frame (paper)."""

# --- Training points -------------------------------------------------------------------------------
SURFACE_POINTS_PER_EPOCH = 100_000
"""On-surface points per epoch (paper). The epoch adds as many near-surface points and half as many
uniform ones, i.e. the 40% / 40% / 20% split of the paper: 250,000 samples per epoch."""

UNIFORM_PER_SURFACE = 0.5
NEAR_PER_SURFACE = 1.0

POOL_EPOCHS = 2
"""The ground-truth pool holds this many epochs' worth of samples (500k points); each epoch draws
from it. Exact distances cost ~8 µs per point on the bunny (69k triangles), so this pool (300k
distance queries) takes ~2.5 s, while fresh points every epoch would cost more than the training."""

VALIDATION_FRACTION = 0.1
"""A held-out set of this fraction of an epoch (same 20/40/40 split, never trained on) picks the
better of the pre- and post-QAT networks."""

AUTO_SDF_MAX_AMBIGUOUS = 0.01
"""`--field auto` picks SDF when at most this fraction of probe points near the surface (offset by
N(0, d*), the band the loss sees) has an ambiguous generalized winding number (0.2 < |w| < 0.8), i.e.
the mesh encloses an inside despite small holes. Measured (20k points, seeds 0 and 1): armadillo,
dragon, spot, igea, nefertiti 0.00%, suzanne 0.41-0.53%, bunny 0.56-0.64% (5 holes) → SDF (but see
AUTO_UDF_WIDTH_WITH_HOLES); demosthenes 1.15-1.26% (an open base), garments 3.7% (Pants1) to 17%
(skirt), lionstatue 18% → UDF. An SDF must cap every hole, surface that the input does not have:
demosthenes as a UDF, fast preset, L = 8, CD at 256, w16 0.01086 vs SDF 0.01301, w32 0.00914 vs
0.01119, w64 0.00835 vs 0.01045 (it was SDF under the earlier bound of 2%; bench/RESULTS.md "Holes:
where a UDF beats an SDF").
Meshes folded onto themselves (the res3 dragon and Happy Buddha: ~3% non-manifold edges, ~2.5%
duplicate faces) still enclose an inside and stay SDF, which is measured better: fast w32 at L = 8, CD
at 256, dragon SDF 0.00936 vs UDF 0.00971, happy SDF 0.00929 vs UDF 0.00985 (the UDFs with their signed
start, UDF_SIGNED_EPOCHS; without it 0.0126 and more; bench/RESULTS.md)."""

AUTO_HOLES_MIN_AMBIGUOUS = 0.002
"""A mesh that `auto` finds closed but whose probe has at least this fraction ambiguous has holes
(closed meshes, folded ones included: 0.00%; the bunny and suzanne: 0.41-0.64%)."""

AUTO_UDF_WIDTH_WITH_HOLES = 64
"""From this width `auto` encodes a mesh with holes (AUTO_HOLES_MIN_AMBIGUOUS) as a UDF: the caps an
SDF puts over its holes cost a fixed Chamfer distance, while the SDF's better fit of the rest shrinks
with the width. Bunny (fast, L = 8, seed 0, CD at 256) UDF against SDF: w32 +3.2%, w48 +0.2%, w64
-1.2%, w96 -3.1% (at w96 the SDF's decoded -> input term is 0.00409 against the sampling floor's
0.00361, 9% of it from points farther than 0.02 from the input: the caps; the UDF's 0.00385);
suzanne w16 +4.2%, w32 -3.2%, w64 -3.0%."""

AUTO_PROBE_POINTS = 20_000
"""Probe points of the winding test every mesh gets (sampling.resolve_field: its orientation, and
`auto`'s choice; ~0.3 s on the bunny)."""

AMBIGUOUS_WINDING = (0.2, 0.8)

# --- Model -----------------------------------------------------------------------------------------
NUM_FREQUENCIES = 7
"""L, Fourier frequencies of the positional encoding. The paper uses 16; fewer give smaller files at
equal or better CD (the first layer has 3 + 6L inputs and holds most parameters at widths 16-32,
and the top octaves' weights come out near zero). 8 from 0.6 (BD-rate against L = 16 at seed 0:
bunny -19%, armadillo -14%, dragon -18%, spot -27%); 7 at β = 1.5 since 2026-12-07: with the fast
preset's 120 epochs and an SDF's d* = 0.05 on both sides, BD-rate against L = 8 at β = 1.4 (three
seeds, widths 16-48) bunny -5.5%, armadillo -1.8%, dragon -3.4%, Happy Buddha -5.3%, spot +13.8%
(its curve flat near the sampling floor), and against format 1.0 -28% to -42% on each of the five
(bench/RESULTS.md "Seven frequencies at β = 1.5 and 120 epochs").
`--frequencies 16` is the paper's."""

FREQUENCY_BASE = 1.5
"""β (`--frequency-base`): f_k = π·β^k. With β = 1.4 the top frequency of L = 16 is ~489 rad/unit,
well inside f32 precision on [-1, 1] (2^k would put the top octaves beyond it); see FORMAT.md.
β = 1.5 gives L = 7 the top of L = 8 at 1.4 (36 against 33 rad/unit) with 6 fewer inputs. Fewer
still pays on the detailed shapes only: L = 6 at β = 1.6 (same top, 39 inputs; 90 epochs) against
L = 8 at 1.4, BD-rate -7.8% on dragon and -6.6% on Happy Buddha but +46% on spot; L = 5 at 1.8 (33
inputs) likewise (bench/RESULTS.md "Where the 8-bit grid costs, and the encoding's spacing")."""

OMEGA0 = 30.0
"""ω₀ of the SIREN sine layers (paper, Sitzmann et al.)."""

HIDDEN_LAYERS = 2
"""Sine layers of width W before the linear output layer (paper)."""

WIDTHS = (16, 24, 32, 48, 64, 96)
"""The rate ladder of the paper: W sets the file size."""

# --- Optimisation ----------------------------------------------------------------------------------
PAPER_BATCH_SIZE = 10_000
"""Adam mini-batch of the paper (the `paper` preset); `fast` uses smaller ones, see PRESETS."""

L1_WEIGHT = 1e-8
"""λ of the λ·Σ|θ| term (paper)."""

UDF_SIGNED_EPOCHS = 1 / 3
"""A UDF trains the first third of its epochs as a signed field: the output before its
`abs` fitted to the distances signed by the side of the surface each point lies on (the faces'
orientation; +1 where the nearest surface point is on a free edge, so that the signed field does
not continue a sheet past its edge: sampling.SurfaceSampler.unsigned_distances_and_sides), then as the UDF, in one
learning-rate schedule (train.fit). Measured (fast preset, seed 0, CD at 256, bench/RESULTS.md "The
signed start"): bunny UDF w32 0.01225 -> 0.00867 (its SDF: 0.00841), T-shirt w32 0.00992 -> 0.00760,
Pants1 w32 0.00776 -> 0.00660; at w16 all five garments below the decimated-Draco envelope; boundary
edges 59k -> 11 on the bunny. A third, a sixth or two thirds of the epochs (the schedule restarted
between the phases, T-shirt w32, before the free-edge rule): 0.00790 / 0.00790 / 0.00815.
A point cloud's sides come from its normals, estimated and consistently oriented
(CLOUD_NORMAL_NEIGHBOURS), where they agree (UDF_SIGNED_MIN_ORIENTED): the bunny's range scans
w24 0.0107 -> 0.00759, w32 0.00910 -> 0.00722 (CD against the cloud)."""

UDF_SIGNED_MIN_ORIENTED = 0.9
"""The signed start needs faces whose orientation means something: the share of edges between two
faces that the two traverse in opposite directions must be at least this (sampling.oriented_share;
every mesh in shared/data: 1.0), or reach it once each edge-connected patch is reoriented by BFS
(SurfaceSampler.orient_consistently); a soup with no shared edge trains unsigned. Likewise a cloud's
oriented normals: the share of clearly related neighbours (|cos| > 0.5) whose normals agree
(cloud_normals; the bunny's range scans: 0.9999). Measured on the
bunny with faces flipped at random (w32, seed 0): 50% flipped (share 0.50) took as it was: CD 0.0559,
849k boundary edges, far worse than no signed start (0.01225); reoriented first: 0.00864, 0 boundary
edges, as with its own faces."""

CLOUD_NORMAL_NEIGHBOURS = 16
"""A cloud point's normal is the least-variance direction of this many nearest neighbours
(cloud_normals)."""

CLOUD_MIN_FLAT_SHARE = 0.5
"""A cloud takes sides only when at least half its points have a flat neighbourhood (cloud_normals.
FLATNESS; scanned surfaces: 98-100%): a curve, a clump of duplicates or a volume of points has no
sides, and an arbitrary plane through it would only mislead the signed start."""

CLOUD_MAX_EDGE_SHARE = 0.0025
"""A cloud takes sides only when at most 0.25% of its points are edge points (cloud_normals.
EDGE_SHIFT): objects scanned from around (the bunny's range scans 0.009%, loot 0.004%) or an open
relief (the egyptian mask 0.18%) have sides, and starting from them cut CD by 20-39% where the
unsigned fit left phantom sheets (the scans w24/w32, the mask; loot: the same CD; bench/RESULTS.md). A single-view scan of a scene (PCL's Kinect and
stereo clouds, 0.36-5.0%: every depth discontinuity ends a surface) has nothing behind its surfaces
to take a side from, and a side from the nearest point puts a phantom sheet between a surface and
the one behind it: table scene w16 CD 0.00684 -> 0.0192, office1 0.0172 -> 0.0217."""

CLOUD_SIDE_COSINE = 0.5
"""A point gets side -1 from a cloud only where its offset from the nearest cloud point leans against
that point's normal by more than this share of its length (60°); along the surface it gets +1, as
past a mesh's free edge."""

DEFAULT_BITS = 8
DEFAULT_WIDTH = 32  # hidden layer width of `nfc encode` without --width or a target; --target-cd's start
"""Bit width b of the symmetric uniform quantization grid (paper)."""


@dataclass(frozen=True)
class Preset:
    """A training schedule: Adam at `lr` (constant, or cosine-decayed to 0) on mini-batches of
    `batch_size`, then QAT.

    QAT trains the float weights through fake-quantized ones (straight-through estimator) at
    `qat_lr`, cosine-decayed; the encoder keeps whichever of the pre- and post-QAT quantized networks
    has the lower validation loss.
    """

    epochs: int
    lr: float
    cosine: bool
    qat_epochs: int
    qat_lr: float
    batch_size: int


PRESETS: dict[str, Preset] = {
    # Paper: 500 epochs of Adam at 1e-4 on batches of 10,000; QAT "50 epochs, small lr".
    "paper": Preset(epochs=500, lr=1e-4, cosine=False, qat_epochs=50, qat_lr=1e-5,
                    batch_size=PAPER_BATCH_SIZE),
    # Fast: 4x smaller batches (4x more Adam steps per epoch at about the same cost per epoch) and a
    # 10x higher learning rate cosine-decayed to zero. Bunny, idle 2-core machine, CD at resolution
    # 256: w16 0.01036 in 12.6 s, w32 0.00856 in 14.8 s, against the paper preset's 0.01025 in 73 s
    # and 0.00848 in 104 s. Batches of 10,000 needed 150 epochs for w32 0.00875 (38 s) and stayed
    # 13% behind at w16; lr 2e-3 or 5e-4 were worse, batches of 1,250 no better. 120 epochs since
    # 2026-12-07 (60 before): BD-rate -7% to -14% on five shapes at widths 16-48 over three seeds
    # (L = 8, d* = 0.05), for 1.2x format 1.0's encode time at 60 (a training step got 20% cheaper
    # the same day; bench/RESULTS.md "Seven frequencies at β = 1.5 and 120 epochs").
    "fast": Preset(epochs=120, lr=1e-3, cosine=True, qat_epochs=10, qat_lr=1e-5, batch_size=2_500),
}
DEFAULT_PRESET = "fast"

MAX_TORCH_THREADS = 4
"""The network is tiny (≤ 20k parameters at W = 96): more threads than this only add overhead."""

# --- Colour (FORMAT.md 1.1, `colr`) ----------------------------------------------------------------
COLOR_NUM_FREQUENCIES = 8
"""L of the colour network's positional encoding (paper's attribute network); ω₀ as geometry."""

COLOR_FREQUENCY_BASE = 1.7
"""β of the colour encoding: f_k = π·β^k, k < 8. Measured on loot (geometry w16, colour w32, 8 bits,
100 epochs, two layers): β 1.4 30.32 dB at 3,923 B, 1.7 30.45 dB at 3,875 B, 2.0 30.11 dB at 3,670 B.
With three layers at ω₀ 20, 300 epochs, 6 bits (since 0.13.12): loot 1.7 30.57 dB at 2,965 B and 31.01
at 3,565 B against 1.4's 30.52 at 3,002 B and 30.87 at 3,606 B; egyptian mask 28.57 at 2,894 B
against 28.53 at 2,928 B."""

COLOR_WIDTH = 32
"""Default width W_c of the colour network's sine layers (`--color-width`)."""

TARGET_COLOR_BITS = 6
"""The colour network's bit width when `--target-bytes` sizes it (and `--color-bits` is not given): at
6 bits loot's colour chunk is 27-30% smaller for 0.2-0.3 dB, the better rate point at every width
measured (bench/RESULTS.md, "Colour"); 5 bits lose too much."""

COLORED_GEOMETRY_SHARE = 0.35
COLORED_GEOMETRY_WIDTHS = (12, 16)
"""`--target-bytes` on a coloured shape: the geometry's budget is this share of the file, held between
the predicted geometry files of these widths (nfencode.rate). Past a small geometry, colour width buys
the PSNR: on loot width 24 under the wide colour networks was no better than 16, and a width-12
geometry was 0.06 dB behind width 16 at equal colour width for 300 bytes less (bench/RESULTS.md,
"Colour: the learning rate by width"); the egyptian mask's colour depends more on its geometry (at
3 KB a width-11 geometry gave 27.96 dB where width 16 gave 28.41; "Rate control with colour"), hence
35% of the budget rather than the quarter first tried."""

COLOR_HIDDEN_LAYERS = 3
"""Sine layers of the colour network. At equal bytes three beat two (loot, geometry w16, 6 bits,
100 epochs: three of width 26 30.22 dB at 2,948 B, two of width 32 29.98 dB at 2,920 B; four of 22
30.24 dB at 2,929 B); bench/RESULTS.md, "Colour: a deeper network"."""

COLOR_OMEGA0 = 20.0
"""ω₀ of the colour network (the file stores it). Loot, three layers of 26, 100 epochs: 15 30.36 dB,
20 30.35 dB, 30 30.22 dB, 45 28.15 dB; two layers of 32: 60 27.81 dB, 15 29.99 dB, 30 29.98 dB."""

COLOR_GROUND_TRUTH_SIDE = 0.5
"""Share of the colour network's training pairs taken from the ground truth's side of the colour PSNR
(a ground-truth point's colour at the decoded point nearest it); the rest are decoded-surface points
with their nearest ground-truth colour (the other side). Loot, 6 bits, both sides against the second
alone: width 64 32.73 dB at 8,372 B against 32.52 at 8,537 B, 80 33.41 at 11,620 B against 33.07 at
11,865 B; against G-PCC at equal size width 32 -0.02 dB, the egyptian mask at 32 and 64 -0.02 / +0.04 dB
(bench/RESULTS.md, "Colour: the learning rate by width, both directions")."""

COLOR_DECODED_CLOUDS = 4
"""Decoder-like point clouds on the decoded surface from which the ground-truth side's pairs are drawn."""

COLOR_MAX_TRUTH_POINTS = 1_000_000
"""At most this many ground-truth points (a random subset) get decoded neighbours, in clouds of as many
points (the decoder's density when the ground truth is no larger): bounds that side's memory to
COLOR_DECODED_CLOUDS × this × 12 bytes."""

TARGET_CD_RESOLUTION = 256
"""Grid resolution at which `nfc encode --target-cd` decodes each candidate (the reference decoder)
to estimate its Chamfer distance: the decoder's default, where `nfc decode` puts the surface."""

TARGET_CD_MAX_WIDTH = 128
"""The widest network `--target-cd` tries: past it each encode costs minutes and the curve has
flattened onto the fit's limit (bench/RESULTS.md, the `fast` rows at w96)."""

COLOR_RESOLUTION = 256
"""Grid resolution of the decoded surface the colour is fitted on (`--color-resolution`): the
decoder's default, so the colour is learnt where `nfc decode` puts the surface."""


@dataclass(frozen=True)
class ColorSchedule:
    """Adam on fresh points of the decoded surface every epoch (`points` of them, mini-batches of
    `batch_size`), lr cosine-decayed to 0, then QAT like the geometry's; the better of the pre- and
    post-QAT quantized networks on `validation_points` fixed surface points is kept. A network wider
    than `lr_width` learns at lr · lr_width / W (see `lr_at`), one wider than `epochs_width` for
    epochs · W / epochs_width epochs (`epochs_at`)."""

    epochs: int
    epochs_width: int
    points: int
    batch_size: int
    lr: float
    lr_width: int
    qat_epochs: int
    qat_lr: float
    validation_points: int

    def lr_at(self, width: int) -> float:
        """The learning rate of a colour network of `width`: a wider SIREN's function moves more per
        Adam step, and at 3e-3 one of width 80 or more fits worse or diverges (bench/RESULTS.md,
        "Colour: the learning rate by width")."""
        return self.lr * min(1.0, self.lr_width / width)

    def epochs_at(self, width: int) -> int:
        """The epochs of a colour network of `width`: at its lower learning rate a wide network is
        still improving after `epochs` (loot, width 80: 500 epochs +0.19 dB against G-PCC at equal
        size over 300)."""
        return round(self.epochs * max(1.0, width / self.epochs_width))


# Measured on pcl_milk_color (13.7k points, UDF w16 geometry, PSNR of 13.7k decoded points, metrics.md):
# w16: 40 epochs at 1e-3 22.50 dB, 100 epochs 23.70, 200 epochs 24.04; at 100 epochs lr 3e-4 21.63,
# 3e-3 24.28, 5e-3 24.13, 1e-2 18.51; batches of 1,000 23.55 (slower), 100k points per epoch 23.98
# (2x slower). w32 at 100 epochs: 1e-3 25.66, 3e-3 25.89, 1e-2 19.57. A constant colour scores 13.96.
# Loot with three layers of 26 at ω₀ 20: 300 epochs 30.52 dB against 100 epochs' 30.35 (two layers of 32 at
# ω₀ 30: 30.01 against 29.98); the fit takes 52 s instead of 17 s on 2 cores, the geometry's encode 27 s.
# Loot, three layers, 6 bits (2026-12-06): at 3e-3 width 64 32.14 dB at 7,849 B, 80 32.18 dB at 10,016 B, 96
# 30.09 dB at 12,382 B, 80 with 600 epochs 26.42 dB (diverged); at 1.5e-3 width 64 32.52 dB at 8,537 B; at 1e-3
# width 80 33.02 dB at 11,433 B (6e-4: 32.95 at 11,879 B), 96 33.57 dB at 15,156 B; width 48 at 1.5e-3 31.85 dB
# at 5,681 B against 3e-3's 31.76 at 5,514 B: lr · 32 / W above width 32.
# With both sides' pairs, width 80 at 1.2e-3: 300 epochs 33.41 dB at 11,620 B, 500 epochs 33.55 dB at 11,407 B
# (fit 57 -> 99 s): epochs · W / 48 above width 48.
COLOR_SCHEDULE = ColorSchedule(epochs=300, epochs_width=48, points=50_000, batch_size=2_500, lr=3e-3, lr_width=32,
                               qat_epochs=5, qat_lr=1e-5, validation_points=20_000)
