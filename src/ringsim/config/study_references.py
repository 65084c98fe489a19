"""The ``references`` of a study file: published or physical values its cases are checked
against, each with its tolerance and source (docs/studies.md, "Reference values").

A reference is given per case and per equilibrium quantity, in the quantity's SI unit as
the run summaries hold it (``ringsim.quantities``), as a value with a tolerance or as a
range::

    references:
      tau0.5:
        velocity_dispersion_rOmega: {low: 0.5, high: 5.0, source: "..."}
        mean_epsilon: {value: 0.5, tolerance: 1.0e-12, source: "..."}

A case agrees with a reference when its seed-averaged mean lies within the tolerance of the
value, or inside the range, widened by three standard errors of the mean
(``ringsim.study.references``).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ringsim.config.schema import Section, show

#: Keys of one reference.
REFERENCE_KEYS = ("value", "tolerance", "low", "high", "source")


@dataclass(frozen=True)
class Reference:
    """What one quantity of one case is checked against.

    Attributes
    ----------
    case, quantity : str
        The case and the equilibrium quantity (a key of ``ringsim.analysis.equilibrium
        .QUANTITIES``).
    low, high : float [the quantity's SI unit]
        The interval the case's mean must reach, widened by three of its standard errors:
        ``value - tolerance`` and ``value + tolerance``, or the range given.
    value : float or None [the quantity's SI unit]
        The reference value (None for a range).
    source : str
        Where the reference comes from (a paper and its equation or table, or the physics
        argument).
    """

    case: str
    quantity: str
    low: float
    high: float
    value: float | None
    source: str


def _one(sec: Section, case: str, quantity: str) -> Reference:
    ref = sec.section(quantity, required=True, allowed="{value, tolerance, source} or "
                      "{low, high, source}")
    ref.check_keys(REFERENCE_KEYS, context="a reference")
    source = ref.string("source", what="where the reference comes from (paper, equation)")
    if ref.has("value"):
        for key in ("low", "high"):
            if ref.has(key):
                raise ref.error(key, "not with value", "either {value, tolerance} or "
                                "{low, high}")
        value = ref.number("value")
        tolerance = ref.number("tolerance", ge=0.0)
        return Reference(case, quantity, value - tolerance, value + tolerance, value, source)
    if ref.has("tolerance"):
        raise ref.error("tolerance", "without value", "{value, tolerance} or {low, high}")
    low = ref.number("low")
    high = ref.number("high", ge=low)
    return Reference(case, quantity, low, high, None, source)


def read_references(top: Section, cases: Sequence[str],
                    quantities: Sequence[str] | None) -> tuple[Reference, ...]:
    """The ``references`` of a study file (empty if absent), every case among ``cases`` and
    every quantity among ``quantities`` (None: not checked); ScenarioError naming the key."""
    if not top.has("references"):
        return ()
    section = top.section("references", allowed="case -> quantity -> reference")
    out = []
    for case_key, entry in section.mapping.items():
        case = str(case_key)
        if case not in cases:
            close = difflib.get_close_matches(case, cases, n=1, cutoff=0.6)
            raise section.error(case, f"unknown case {show(case)}",
                                (f"did you mean {close[0]!r}? " if close else "")
                                + f"the cases: {', '.join(cases)}")
        by_quantity = section.section(case, required=True,
                                      allowed="equilibrium quantity -> reference")
        if not isinstance(entry, Mapping) or not entry:
            raise section.error(case, "is empty", "equilibrium quantity -> reference")
        for quantity_key in by_quantity.mapping:
            quantity = str(quantity_key)
            if quantities is not None and quantity not in quantities:
                close = difflib.get_close_matches(quantity, quantities, n=1, cutoff=0.6)
                raise by_quantity.error(quantity, f"unknown quantity {show(quantity)}",
                                        (f"did you mean {close[0]!r}? " if close else "")
                                        + "an equilibrium quantity: "
                                        + ", ".join(quantities))
            out.append(_one(by_quantity, case, quantity))
    return tuple(out)
