"""Declared laws and their parameters: the machinery every parameter table of ringsim uses.

A physical law the scenario can choose (a restitution law, a friction model) is declared
ONCE as a `Law`: its name, its numpy function, its integer code in the C library, and for
each parameter a `Parameter` with unit, default (or required), allowed range with open or
closed ends, C slot, one-line meaning and source.  A `LawTable` (one per scenario section:
``restitution``, ``friction``) collects the laws of a section.  Everything else is derived
from the table:

* scenario validation of the section (``ringsim.config.scenario``),
* checking and packing of the C resolver's arguments (``ringsim.engine``),
* bounds and start values of ``ringsim fit`` (``ringsim.analysis.fit``),
* units of the section's keys in sweep summaries (``ringsim.store.summary``),
* the parameter tables of ``docs/scenario.md`` (`LawTable.markdown`, checked by a test).

The C library keeps its own range check (``rs_parameters_valid``) as a guard;
tests/test_parameters.py checks that it accepts and refuses exactly at every declared
bound.  This module imports nothing from ringsim, so any layer may use it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypedDict

#: Unit of a dimensionless parameter (as HDF5 attributes and JSON carry it).
DIMENSIONLESS = "dimensionless"
#: The value of a parameter whose ``auto`` says how ringsim chooses it.
AUTO = "auto"


class Limits(TypedDict, total=False):
    """A parameter's range as the keywords of ``Section.number``: its finite ends only."""

    gt: float
    ge: float
    lt: float
    le: float


@dataclass(frozen=True)
class Parameter:
    """One parameter of a law.

    Attributes
    ----------
    name : str
        Key in the scenario section and keyword of the numpy function.
    unit : str
        SI unit (``"m/s"``) or `DIMENSIONLESS`.
    meaning : str
        One line for the docs.
    source : str
        Paper and equation the parameter (and its default) comes from.
    default : float, "auto" or None
        None: the user must give it; "auto" (only with ``auto``): chosen as ``auto`` says.
    lower, upper : float
        Allowed range; ``-inf``/``inf`` for an unbounded side.  A value must be finite.
    lower_closed, upper_closed : bool
        Whether the bound itself is allowed (meaningless for an infinite bound).
    slot : int
        Index of the C struct's ``param[]`` the value is packed into.
    example : float or None
        A typical value when there is no numeric default (start of fits, examples in the
        docs).
    auto : str
        What the value ``"auto"`` means where the key accepts it (the scenario reader's
        ``number_or_auto``); "" : numbers only.
    implicit_at_default : bool
        The resolved scenario leaves the parameter out while it has its default: a
        parameter whose default is the law as it was before the parameter existed, so that
        runs made then keep their identity (a study finds them by the hash of the resolved
        scenario).
    """

    name: str
    unit: str
    meaning: str
    source: str
    default: float | str | None = None
    lower: float = -math.inf
    upper: float = math.inf
    lower_closed: bool = False
    upper_closed: bool = False
    slot: int = 0
    example: float | None = None
    auto: str = ""
    implicit_at_default: bool = False

    def __post_init__(self) -> None:
        if not self.lower < self.upper:
            raise ValueError(f"{self.name}: declared range is empty")
        if isinstance(self.default, str):
            if self.default != AUTO:
                raise ValueError(f"{self.name}: default {self.default!r} is neither a number "
                                 f"nor {AUTO!r}")
            if not self.auto:
                raise ValueError(f"{self.name}: default 'auto' without its meaning")
        elif self.default is not None and not self.contains(self.default):
            raise ValueError(f"{self.name}: default {self.default} outside its range")
        if self.example is None and (self.default is None or self.default == AUTO):
            raise ValueError(f"{self.name}: without a numeric default it needs an example value")

    def implied(self, value: Any) -> bool:
        """Whether a resolved scenario leaves ``value`` out: the parameter is declared
        ``implicit_at_default`` and ``value`` is its default."""
        return self.implicit_at_default and value == self.default

    @property
    def required(self) -> bool:
        return self.default is None

    @property
    def typical(self) -> float:
        """The numeric default, else the example (one of them is set)."""
        if self.default is not None and self.default != AUTO:
            return float(self.default)
        if self.example is None:   # refused by __post_init__
            raise ValueError(f"{self.name}: without a numeric default it needs an example value")
        return self.example

    def contains(self, x: float) -> bool:
        """True if ``x`` is finite and inside the declared range."""
        if not math.isfinite(x):
            return False
        above = x >= self.lower if self.lower_closed else x > self.lower
        below = x <= self.upper if self.upper_closed else x < self.upper
        return above and below

    def limits(self) -> Limits:
        """The range as keywords ``gt``/``ge``/``lt``/``le`` (finite ends only)."""
        out: Limits = {}
        if math.isfinite(self.lower):
            if self.lower_closed:
                out["ge"] = self.lower
            else:
                out["gt"] = self.lower
        if math.isfinite(self.upper):
            if self.upper_closed:
                out["le"] = self.upper
            else:
                out["lt"] = self.upper
        return out

    def range_text(self) -> str:
        """'> 0', '>= 0', '[0, 1]', '(0, 0.5)' or 'any finite'."""
        lo, hi = math.isfinite(self.lower), math.isfinite(self.upper)
        if lo and hi:
            return (f"{'[' if self.lower_closed else '('}{self.lower:g}, {self.upper:g}"
                    f"{']' if self.upper_closed else ')'}")
        if lo:
            return f"{'>=' if self.lower_closed else '>'} {self.lower:g}"
        if hi:
            return f"{'<=' if self.upper_closed else '<'} {self.upper:g}"
        return "any finite"

    def check(self, value: Any) -> float:
        """``value`` as a float; ValueError starting with the parameter's name if it is not
        a finite real number inside the declared range."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                and not _is_numpy_real(value):
            raise ValueError(f"{self.name} must be a real number, got {value!r}")
        x = float(value)
        if not self.contains(x):
            unit = "" if self.unit == DIMENSIONLESS else f" [{self.unit}]"
            raise ValueError(f"{self.name} must be a finite number {self.range_text()}{unit}, "
                             f"got {x!r}")
        return x


def _is_numpy_real(value: Any) -> bool:
    """numpy integer or floating scalars (without importing numpy here)."""
    kind = getattr(getattr(value, "dtype", None), "kind", None)
    return kind in ("i", "u", "f") and getattr(value, "ndim", 1) == 0


@dataclass(frozen=True)
class MeasuredRange:
    """Where a law's parameters were measured (for a later guard on the law's range).

    Attributes
    ----------
    speeds : (float, float) or None [m/s]
        Impact speeds of the data the parameters were fitted to; None: not stated.
    sizes : (float, float) or None [m]
        Radii of curvature of the spheres; None: not stated or not a size-dependent law.
    source : str
        Where the range comes from, or why it is not stated.
    masses : (float, float) or None [kg]
        (Effective) masses of the impactors; None: not stated.
    """

    speeds: tuple[float, float] | None
    sizes: tuple[float, float] | None
    source: str
    masses: tuple[float, float] | None = None


@dataclass(frozen=True)
class Law:
    """A law of one scenario section: name, numpy function, C code, parameters.

    Attributes
    ----------
    name : str
        Value of the section's ``model`` key.
    code : int
        Integer code of the law in the C library.
    function : callable
        The numpy function; called ``function(v, R_bar, M_bar, **parameters)`` if
        ``uses_pair`` else ``function(v, **parameters)``.
    parameters : tuple of Parameter
    formula : str
        One line for the docs.
    source : str
        Paper (and equation) of the law.
    measured : MeasuredRange
    uses_pair : bool
        Whether the law depends on the reduced radius and mass of the pair.
    """

    name: str
    code: int
    function: Callable[..., Any]
    parameters: tuple[Parameter, ...]
    formula: str
    source: str
    measured: MeasuredRange
    uses_pair: bool = False

    def __getitem__(self, name: str) -> Parameter:
        for par in self.parameters:
            if par.name == name:
                return par
        raise KeyError(name)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def defaults(self) -> dict[str, float]:
        """Parameters with numeric defaults (required ones and ``auto`` ones left out)."""
        return {p.name: p.default for p in self.parameters
                if isinstance(p.default, int | float)}

    def checked(self, values: Mapping[str, Any]) -> dict[str, float]:
        """Every parameter of the law from ``values`` (defaults filled), range-checked;
        ValueError naming the first offending key (unknown, missing or out of range)."""
        for key in values:
            if key not in self.names:
                raise ValueError(f"{key}: not a parameter of model {self.name!r} "
                                 f"(allowed: {', '.join(self.names)})")
        out: dict[str, float] = {}
        for par in self.parameters:
            if par.name not in values:
                if par.default is None:
                    raise ValueError(f"{par.name}: required by model {self.name!r}")
                out[par.name] = float(par.default)
            else:
                out[par.name] = par.check(values[par.name])
        return out

    def explicit(self, values: Mapping[str, float]) -> dict[str, float]:
        """``values`` without the parameters declared ``implicit_at_default`` that have
        their default: what a resolved scenario records."""
        implied = {p.name for p in self.parameters if p.implied(values.get(p.name))}
        return {k: v for k, v in values.items() if k not in implied}

    def pack(self, values: Mapping[str, float], n_slots: int) -> tuple[float, ...]:
        """The C struct's ``param[n_slots]``: each value in its slot, unused slots 0."""
        slots = [0.0] * n_slots
        for par in self.parameters:
            slots[par.slot] = float(values[par.name])
        return tuple(slots)

    def evaluate(self, values: Mapping[str, float], v: Any, R_bar: Any, M_bar: Any) -> Any:
        """The numpy function with these parameter values at speeds v [m/s] and, for a law
        with ``uses_pair``, the pair's R_bar [m] and M_bar [kg] (ValueError if None; the
        other laws ignore them)."""
        if self.uses_pair:
            if R_bar is None or M_bar is None:
                raise ValueError(f"the {self.name} law needs the reduced radius and mass of "
                                 "the pair")
            return self.function(v, R_bar, M_bar, **values)
        return self.function(v, **values)


class LawTable:
    """The laws of one scenario section, e.g. ``restitution``.

    Parameters
    ----------
    section : str
        Name of the scenario section (and prefix of its dotted keys).
    laws : sequence of Law
        In the order the docs list them; the first is the default ``model``.
    n_slots : int
        Length of the C struct's parameter array.
    """

    def __init__(self, section: str, laws: Sequence[Law], n_slots: int):
        self.section = section
        self.laws = tuple(laws)
        self.n_slots = n_slots
        codes = [law.code for law in self.laws]
        if len(set(codes)) != len(codes) or len({law.name for law in self.laws}) != len(codes):
            raise ValueError(f"{section}: law names and codes must be unique")
        units: dict[str, str] = {}
        for law in self.laws:
            slots = [p.slot for p in law.parameters]
            if len(set(slots)) != len(slots) or any(not 0 <= s < n_slots for s in slots):
                raise ValueError(f"{section}.{law.name}: slots must be distinct in "
                                 f"0..{n_slots - 1}")
            for par in law.parameters:
                if units.setdefault(par.name, par.unit) != par.unit:
                    raise ValueError(f"{section}.{par.name}: one key, two units")
        self._units = units

    def __iter__(self) -> Iterator[Law]:
        return iter(self.laws)

    def __getitem__(self, name: str) -> Law:
        for law in self.laws:
            if law.name == name:
                return law
        raise KeyError(name)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(law.name for law in self.laws)

    @property
    def default(self) -> str:
        return self.laws[0].name

    def units(self) -> dict[str, str]:
        """Unit of every parameter key of the section (one key has one unit in all laws)."""
        return dict(self._units)

    def resolve(self, section: Mapping[str, Any]) -> tuple[Law, dict[str, float]]:
        """(law, complete checked parameters) of a section mapping; ValueError naming the
        offending key for an unknown model or an unknown, missing or out-of-range key."""
        if "model" not in section:
            raise ValueError(f"model: missing (one of {', '.join(self.names)})")
        model = section["model"]
        if model not in self.names:
            raise ValueError(f"model: unknown {self.section} model {model!r} "
                             f"(one of {', '.join(self.names)})")
        law = self[model]
        values = {k: v for k, v in section.items() if k != "model"}
        return law, law.checked(values)

    def markdown(self) -> str:
        """The section's parameter table and the table of measured ranges (Markdown)."""
        lines = ["| model | key | unit | type | default | allowed | meaning | source |",
                 "|---|---|---|---|---|---|---|---|",
                 f"| – | `model` | – | string | `{self.default}` | "
                 f"{', '.join(f'`{n}`' for n in self.names)} | which law | – |"]
        for law in self.laws:
            for par in law.parameters:
                unit = "–" if par.unit == DIMENSIONLESS else par.unit
                default = "**required**" if par.required else f"`{par.default!r}`"
                lines.append(f"| `{law.name}` | `{par.name}` | {unit} | real | {default} | "
                             f"{par.range_text()} | {par.meaning} | {par.source} |")
        lines += ["", "| model | law | source | measured speeds [m/s] | measured radii [m] | "
                  "measured masses [kg] | measured by |", "|---|---|---|---|---|---|---|"]
        for law in self.laws:
            m = law.measured
            speeds, sizes, masses = (f"{r[0]:g} – {r[1]:g}" if r else "not stated"
                                     for r in (m.speeds, m.sizes, m.masses))
            lines.append(f"| `{law.name}` | {law.formula} | {law.source} | {speeds} | "
                         f"{sizes} | {masses} | {m.source} |")
        return "\n".join(lines) + "\n"
