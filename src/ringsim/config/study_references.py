"""The ``references`` of a study file: published or physical values its cases are checked
against, each with its tolerance or uncertainty and its source (docs/studies.md,
"Reference values").

A reference is given per case (or per ratio of two cases, ``NUMERATOR/DENOMINATOR``, one
of the study's ``ratios``) and per quantity, in the quantity's SI unit as the run summaries
hold it (``ringsim.quantities``), as a value with a tolerance and/or its own standard
uncertainty ``sigma``, or as a range (one end may be left open)::

    references:
      tau0.5:
        velocity_dispersion_rOmega: {low: 0.5, high: 5.0, source: "..."}
        mean_epsilon: {value: 0.5, tolerance: 1.0e-12, source: "..."}
        collision_frequency: {value: 1.8, sigma: 0.05, source: "..."}
        by_size.velocity_dispersion: {bin: 0, over_bin: -1, low: 2.0, high: 5.0,
                                      source: "..."}
      kappa0.1/kappa0:
        velocity_dispersion: {low: 1.0, source: "..."}

A per-size-bin quantity (``by_size.velocity_dispersion``, ``by_size.thickness``) names its
size bin (``bin``, 0 the smallest, negative counted from the largest) and, for the ratio of
two bins of the same case, ``over_bin``.  A case agrees with a reference when its
seed-averaged mean lies within the tolerance of the value, or inside the range, widened by
three combined standard uncertainties (the mean's and the reference's ``sigma``)
(``ringsim.study.references``).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ringsim.config.schema import Section, show

#: Keys of one reference.
REFERENCE_KEYS = ("value", "tolerance", "sigma", "low", "high", "source", "bin", "over_bin")
#: Per-size-bin quantities a reference may name: key -> the summary's ``by_size`` bin key.
BY_SIZE_QUANTITIES = {"by_size.velocity_dispersion": "velocity_dispersion",
                      "by_size.thickness": "thickness"}
#: The spin quantities of a case with friction (``study.spin``): a reference names them
#: ``spin.KEY``, the case's seed mean of the summaries' ``spin`` entry KEY.
SPIN_QUANTITIES = ("rotational_energy_fraction", "rotational_energy_fraction_random",
                   "mean_spin_z", "rms_spin", "sliding_fraction")
SPIN_REFERENCES = tuple(f"spin.{key}" for key in SPIN_QUANTITIES)
#: What a study's summaries keep beyond the equilibrium quantities when its ``keep`` names
#: it (``study.kept``): name -> the keys of the entry.  ``energy_budget``: the shear heating
#: against the counted dissipation of the equilibrium window (``analysis.spins``);
#: ``aggregation``: bound Hill-sphere and contact groups and the overlap guard's events of
#: the window (``analysis.aggregation``).  A reference names them ``NAME.KEY``.
KEPT_QUANTITIES = {
    "energy_budget": ("heating", "normal_dissipation", "tangential_dissipation", "ratio",
                      "tangential_share"),
    "aggregation": ("bound_fraction_mean", "bound_fraction_max", "bound_fraction_last",
                    "contact_fraction_last", "multi_encounter_share", "overlap_rows", "rows",
                    "max_overlapping_pairs"),
    "thermal_balance": ("growth_rate", "sigma_xy_over_xx", "sigma_yy_over_xx",
                        "sigma_zz_over_xx"),
}
KEPT_REFERENCES = tuple(f"{name}.{key}" for name, keys in KEPT_QUANTITIES.items()
                        for key in keys)
#: Separates the numerator and the denominator of a ratio's reference key.
RATIO_SEPARATOR = "/"


@dataclass(frozen=True)
class Reference:
    """What one quantity of one case (or of one ratio of two cases) is checked against.

    Attributes
    ----------
    case, quantity : str
        The case (``NUM/DEN`` for a ratio of two cases) and the quantity (a key of
        ``ringsim.analysis.equilibrium.QUANTITIES``, or of `BY_SIZE_QUANTITIES`).
    low, high : float [the quantity's SI unit; dimensionless for a ratio]
        The interval the mean must reach, widened by three combined standard
        uncertainties: ``value - tolerance`` and ``value + tolerance``, or the range given
        (``-inf`` or ``inf`` for an open end).
    value : float or None [the quantity's SI unit]
        The reference value (None for a range).
    source : str
        Where the reference comes from (a paper and its equation or table, or the physics
        argument).
    sigma : float [the quantity's SI unit]
        The reference's own standard uncertainty, combined in quadrature with the mean's.
    bin, over_bin : int or None
        For a per-size-bin quantity: the size bin, and the bin it is divided by.
    ratio : tuple of str or None
        For a ratio of two cases: (numerator, denominator).
    """

    case: str
    quantity: str
    low: float
    high: float
    value: float | None
    source: str
    sigma: float = 0.0
    bin: int | None = None
    over_bin: int | None = None
    ratio: tuple[str, str] | None = None


def _bins(ref: Section, quantity: str) -> dict:
    """``bin`` and ``over_bin`` of a per-size-bin quantity (absent for any other)."""
    if quantity not in BY_SIZE_QUANTITIES:
        for key in ("bin", "over_bin"):
            if ref.has(key):
                raise ref.error(key, f"not with {show(quantity)}",
                                "bin and over_bin go with " + ", ".join(BY_SIZE_QUANTITIES))
        return {}
    over = ref.integer("over_bin") if ref.has("over_bin") else None
    return {"bin": ref.integer("bin"), "over_bin": over}


#: What one reference may be (error messages).
ONE_REFERENCE = ("{value, tolerance and/or sigma, source} or {low and/or high, source}, or "
                 "a list of these")


def _sections(sec: Section, quantity: str) -> list[Section]:
    """The references of one quantity: a mapping, or a list of mappings."""
    given = sec.get(quantity, None, ONE_REFERENCE)
    if not isinstance(given, list):
        return [sec.section(quantity, required=True, allowed=ONE_REFERENCE)]
    if not given:
        raise sec.error(quantity, "is an empty list", ONE_REFERENCE)
    out = []
    for i, item in enumerate(given):
        if not isinstance(item, Mapping):
            raise sec.error(f"{quantity}[{i}]", f"got {show(item)}, not a mapping",
                            ONE_REFERENCE)
        out.append(Section(sec.file, f"{sec.key(quantity)}[{i}]", item))
    return out


def _one(ref: Section, case: str, quantity: str, ratio: tuple[str, str] | None) -> Reference:
    ref.check_keys(REFERENCE_KEYS, context="a reference")
    source = ref.string("source", what="where the reference comes from (paper, equation)")
    extra = {**_bins(ref, quantity), "ratio": ratio}
    if ref.has("value"):
        for key in ("low", "high"):
            if ref.has(key):
                raise ref.error(key, "not with value", "either {value, tolerance and/or "
                                "sigma} or {low and/or high}")
        if not (ref.has("tolerance") or ref.has("sigma")):
            raise ref.error("tolerance", "missing", "a value needs a tolerance, a sigma "
                            "(its standard uncertainty) or both")
        value = ref.number("value")
        tolerance = ref.number("tolerance", 0.0, ge=0.0)
        sigma = ref.number("sigma", 0.0, ge=0.0)
        return Reference(case, quantity, value - tolerance, value + tolerance, value, source,
                         sigma, **extra)
    for key in ("tolerance", "sigma"):
        if ref.has(key):
            raise ref.error(key, "without value", "{value, tolerance and/or sigma} or "
                            "{low and/or high}")
    if not (ref.has("low") or ref.has("high")):
        raise ref.error("low", "missing", "a value, or a range: low, high or both")
    low = ref.number("low") if ref.has("low") else -math.inf
    high = ref.number("high", ge=low if math.isfinite(low) else None) \
        if ref.has("high") else math.inf
    return Reference(case, quantity, low, high, None, source, **extra)


def _unknown(section: Section, key: str, what: str, known: Sequence[str], listed: str):
    close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
    return section.error(key, f"unknown {what} {show(key)}",
                         (f"did you mean {close[0]!r}? " if close else "")
                         + f"{listed}: {', '.join(known)}")


def _target(section: Section, key: str, cases: Sequence[str],
            ratios: Sequence[tuple[str, str]]) -> tuple[str, str] | None:
    """The ratio a reference key names (None for a case); ScenarioError if neither."""
    if RATIO_SEPARATOR in key:
        pair = tuple(key.split(RATIO_SEPARATOR, 1))
        if pair not in ratios:
            raise _unknown(section, key, "ratio", [RATIO_SEPARATOR.join(r) for r in ratios],
                           "the study's ratios")
        return (pair[0], pair[1])
    if key not in cases:
        raise _unknown(section, key, "case", cases, "the cases")
    return None


def read_references(top: Section, cases: Sequence[str], quantities: Sequence[str] | None,
                    ratios: Sequence[tuple[str, str]] = (),
                    ratio_quantities: Sequence[str] | None = None) -> tuple[Reference, ...]:
    """The ``references`` of a study file (empty if absent): every case among ``cases`` (or
    ratio among ``ratios``) and every quantity among ``quantities`` (``ratio_quantities``
    for a ratio; None: not checked) or `BY_SIZE_QUANTITIES`; ScenarioError naming the
    key."""
    if not top.has("references"):
        return ()
    section = top.section("references", allowed="case or NUM/DEN ratio -> quantity -> "
                          "reference")
    out = []
    for case_key, entry in section.mapping.items():
        case = str(case_key)
        ratio = _target(section, case, cases, ratios)
        by_quantity = section.section(case, required=True, allowed="quantity -> reference")
        if not isinstance(entry, Mapping) or not entry:
            raise section.error(case, "is empty", "quantity -> reference")
        known = ratio_quantities if ratio else quantities
        for quantity_key in by_quantity.mapping:
            quantity = str(quantity_key)
            allowed_here = (list(known) if known is not None else []) + \
                ([] if ratio else [*BY_SIZE_QUANTITIES, *SPIN_REFERENCES, *KEPT_REFERENCES])
            if known is not None and quantity not in allowed_here or \
                    ratio and quantity in BY_SIZE_QUANTITIES:
                raise _unknown(by_quantity, quantity, "quantity", allowed_here,
                               "an equilibrium quantity"
                               + ("" if ratio else ", by size, spin or kept"))
            out += [_one(ref, case, quantity, ratio) for ref in _sections(by_quantity, quantity)]
    return tuple(out)


def read_keep(top: Section) -> tuple[str, ...]:
    """The study's ``keep``: the entries of `KEPT_QUANTITIES` its run summaries keep (empty
    if absent); ScenarioError naming the key."""
    if not top.has("keep"):
        return ()
    allowed = "a list of distinct names among " + ", ".join(KEPT_QUANTITIES)
    value = top.get("keep", None, allowed)
    if not isinstance(value, list) or len(set(map(str, value))) != len(value):
        raise top.error("keep", f"got {show(value)}", allowed)
    for name in value:
        if name not in KEPT_QUANTITIES:
            close = difflib.get_close_matches(str(name), list(KEPT_QUANTITIES), n=1)
            raise top.error("keep", f"unknown entry {show(name)}",
                            (f"did you mean {close[0]!r}? " if close else "") + allowed)
    return tuple(str(name) for name in value)
