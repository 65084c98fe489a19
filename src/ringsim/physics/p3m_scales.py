"""The length scales of the P3M self-gravity solver: the split scale r_s and the multiples
of it that set the pair sum's cutoff, the mesh's cells and its layers; the split that
``sheet.p3m_split: auto`` takes from the layer's height span; the fixed ladder of layer
counts the mesh is padded to.  Declared once here; the solver (``gravity.p3m``), its mesh
(``physics.p3m_mesh.P3MMesh``), the scenario key (``physics.gravity_solvers``), the
benchmarks and the docs derive from these (docs/gravity.md, section 4b).  Pure functions.
"""

from __future__ import annotations

import math

#: P3M split scale r_s as a multiple of the mean particle radius, and the pair-sum cutoff,
#: horizontal mesh cell and layer spacing as multiples of r_s: the cheapest setting with
#: < 1 % rms force error on a tau = 0.5 sheet (docs/gravity.md, 4b, "Defaults").  The
#: short-range rest left out beyond the cutoff is 1 - L(5 r_s) = 5.85e-3 of the pair force
#: (``physics.p3m_mesh.long_range_fraction``).  GADGET-2 uses r_s = 1.25 cells and
#: r_c = 4.5 r_s.
P3M_SPLIT_RADII = 3.0
P3M_CUTOFF_SPLITS = 5.0
P3M_CELL_SPLITS = 1.0
P3M_LAYER_SPLITS = 0.75
#: ``sheet.p3m_split: auto`` (the default): the split scale follows the layer's height span
#: Z at every force evaluation.  The mesh costs ~ (L / r_s)^2 Z / r_s and the pair sum (a
#: horizontal cell list) ~ N n (2.5 r_c)^2, n the number of particles per unit area, so the
#: cheapest split is r_s = C (Z / n^2)^(1/5).  C is the measured optimum of one force
#: evaluation (docs/gravity.md, 4b, "The split in thick rings").
P3M_AUTO_SPLIT_COEFFICIENT = 0.77
#: Ratio of successive split scales ("rungs") of ``auto``, from P3M_SPLIT_RADII mean radii
#: up: the choice moves one rung when Z changes by a factor 2^(5/4) = 2.4.
P3M_SPLIT_RUNG = 2.0 ** 0.25
#: The pair sum's cell list needs 2 cells per cutoff and 5 columns (rs_p3m.c,
#: RS_P3M_CELLS_PER_CUTOFF), i.e. r_c <= min(Lx, Ly) / 2.5; a wider cutoff falls back to
#: all pairs over 3 x 3 images, many times slower (docs/gravity.md, 4b), so ``auto`` stays
#: below it.
P3M_CELL_LIST_CUTOFFS = 2.5
#: Layer counts of the mesh are padded (empty layers on top) to the next of a fixed ladder
#: of counts (ratio P3M_LAYER_BUCKET, from P3M_MIN_LAYERS): the vertical kernel tables, one
#: per layer count, are then shared by every step whose layers fall in one bucket, where a
#: hot ring's height span would otherwise ask for a new table at nearly every step
#: (docs/gravity.md, 4b, "Layer counts on a fixed ladder").
P3M_LAYER_BUCKET = 1.25
P3M_MIN_LAYERS = 8
#: ``sheet.p3m_tail_fraction`` (the default): the mesh's layers span only the heights that
#: hold all but this fraction of the particles (half above, half below), widened on each
#: side by the larger of P3M_TAIL_MARGIN_SPLITS r_s and P3M_TAIL_MARGIN_SCALES robust
#: scales of the heights (interquartile range / 1.349, sigma for a Gaussian); the particles
#: beyond are on the mesh at its limits (their pair forces within r_c and the mean vertical
#: field stay exact).  A ring's heights have a long sparse tail, so the mesh is then a
#: fraction of the layers that span every particle, at the same force error; the margin in
#: scales keeps a ring with a Gaussian, dense edge (the B-ring preset) at its error
#: (docs/gravity.md, 4b, "The sparse high tail apart").
P3M_TAIL_FRACTION = 0.08
P3M_TAIL_MARGIN_SPLITS = 4.0
P3M_TAIL_MARGIN_SCALES = 1.5
#: ``sheet.p3m_core_min_radius``: the heights of the particles of at least that radius set
#: the core only where those particles hold at least P3M_CORE_MIN_MASS_SHARE of the sheet's
#: mass (the mesh's field is the mass's) and number at least P3M_CORE_MIN_COUNT and 2 /
#: the tail fraction (so that the order statistics leave a tail apart and the quartiles
#: are those of a sample, not of a few particles); otherwise every particle's height does.
#: A core of a few particles' heights leaves most of the sheet beyond it, at a large force
#: error (docs/gravity.md, "The core of the pair-summed particles").
P3M_CORE_MIN_MASS_SHARE = 0.5
P3M_CORE_MIN_COUNT = 16
#: Kernel tables a mesh keeps (least recently used dropped): 2 x 8193 x about 2 nz doubles each,
#: 105 MB at nz = 400.
P3M_TABLES = 4


def layer_bucket(nz: int) -> int:
    """The number of layers [-] a mesh of ``nz`` occupied layers is padded to: the smallest
    of ceil(P3M_MIN_LAYERS P3M_LAYER_BUCKET^k), k = 0, 1, ..., that is >= nz.  A pure
    function of nz, so that the padding (and with it every bit of the field) depends on the
    state only, never on the run's history."""
    bucket = float(P3M_MIN_LAYERS)
    while math.ceil(bucket) < nz:
        bucket *= P3M_LAYER_BUCKET
    return int(math.ceil(bucket))


def p3m_auto_split(first_split: float, height_span: float, n_particles: int, Lx: float,
                   Ly: float) -> float:
    """The split scale r_s [m] of ``sheet.p3m_split: auto`` for the current layer.

    r_s = P3M_AUTO_SPLIT_COEFFICIENT (Z / n^2)^(1/5), n = N / (Lx Ly), rounded down to a rung
    first_split P3M_SPLIT_RUNG^k (k >= 0), and at most the largest rung whose cutoff keeps
    the pair sum's cell list (P3M_CELL_LIST_CUTOFFS); never below the first rung (the
    scenario's P3M_SPLIT_RADII mean radii: the fixed default, whose accuracy is measured,
    docs/gravity.md 4b).  A pure function of the state: a resumed run chooses as the run
    it continues.

    Parameters
    ----------
    first_split : float [m]
    height_span : float [m]
        zmax - zmin of the particles (``rs_p3m_height_span``).
    n_particles : int
    Lx, Ly : float [m]
    """
    floor = first_split
    n = n_particles / (Lx * Ly)
    ideal = P3M_AUTO_SPLIT_COEFFICIENT * (max(height_span, 0.0) / n**2) ** 0.2
    cap = min(Lx, Ly) / (P3M_CELL_LIST_CUTOFFS * P3M_CUTOFF_SPLITS)
    best = min(ideal, cap)
    if best <= floor:
        return floor
    k = math.floor(math.log(best / floor) / math.log(P3M_SPLIT_RUNG) + 1e-9)
    split = floor * P3M_SPLIT_RUNG**k
    while split > cap and k > 0:     # round-off at a rung exactly on the cap
        k -= 1
        split = floor * P3M_SPLIT_RUNG**k
    return split


def p3m_first_split(p3m_split: float | str, mean_radius: float) -> float:
    """The (first) split scale r_s [m] of ``sheet.p3m_split``: the number given, or, for
    "auto", P3M_SPLIT_RADII mean radii, the smallest split auto chooses.

    Parameters
    ----------
    p3m_split : float [m] or "auto"
    mean_radius : float [m]
    """
    return P3M_SPLIT_RADII * mean_radius if p3m_split == "auto" else float(p3m_split)
