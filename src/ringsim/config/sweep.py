"""Sweep files: a base scenario and a grid of dotted scenario keys -> lists of values."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from ringsim.config.scenario import Scenario, load_scenario, with_overrides
from ringsim.config.schema import ScenarioError, Section, parse_yaml, read_text, show
from ringsim.errors import clip


@dataclass(frozen=True)
class Sweep:
    """A grid of scenarios: a base scenario and dotted keys -> lists of values.

    Attributes
    ----------
    base : Scenario
    base_path : str
        The base scenario's file (resolved relative to the sweep file).
    grid : tuple of (dotted key, tuple of values)
        In file order; the last key varies fastest.
    source : str
        The sweep file.
    """

    base: Scenario
    base_path: str
    grid: tuple[tuple[str, tuple[Any, ...]], ...]
    source: str
    source_text: str | None = field(default=None, compare=False, repr=False)

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(key for key, _ in self.grid)

    def __len__(self) -> int:
        return math.prod(len(values) for _, values in self.grid)

    def parameter_sets(self) -> Iterator[dict[str, Any]]:
        """The grid points as {dotted key: value}, Cartesian product, last key fastest."""
        for combo in itertools.product(*(values for _, values in self.grid)):
            yield dict(zip(self.keys, combo, strict=True))

    def points(self) -> Iterator[tuple[dict[str, Any], Scenario]]:
        """(parameters, scenario) for every grid point, in `parameter_sets` order."""
        for params in self.parameter_sets():
            try:
                yield params, with_overrides(self.base, params)
            except ScenarioError as exc:
                point = ", ".join(f"{k}={v!r}" for k, v in params.items())
                raise ScenarioError(self.source, "grid",
                                    f"point {point}: {exc.key}: {exc.problem}",
                                    exc.allowed) from None


def load_sweep(path: str | PathLike) -> Sweep:
    """Read a sweep file (``base``: scenario path relative to it; ``grid``: dotted key ->
    list) and check every value and every grid point against the base scenario."""
    source = str(path)
    text = read_text(path)
    data = parse_yaml(text, source)
    if not isinstance(data, Mapping):
        raise ScenarioError(source, "<yaml>", "the top level is not a mapping",
                            "a YAML mapping with keys base and grid")
    top = Section(source, "", data)
    top.check_keys(("base", "grid"))
    base_name = top.string("base", what="a scenario file path, relative to the sweep file")
    base_path = Path(source).parent / base_name
    base = load_scenario(base_path)
    grid_sec = top.section("grid", required=True)
    allowed = "a non-empty list of values"
    if not grid_sec.mapping:
        raise top.error("grid", "is empty", "dotted scenario keys -> lists of values")
    grid = []
    for key, values in grid_sec.mapping.items():
        if not isinstance(values, list) or not values:
            raise grid_sec.error(str(key), f"got {show(values)}", allowed)
        for value in values:
            try:
                with_overrides(base, {key: value})
            except ScenarioError as exc:
                # the base file's message inside the sweep's, kept to one short line
                raise grid_sec.error(str(key), f"value {show(value)} is invalid for "
                                     f"{exc.file}: {exc.key}: {exc.problem}",
                                     clip(exc.allowed, 160)) from None
        grid.append((str(key), tuple(values)))
    sweep = Sweep(base=base, base_path=str(base_path), grid=tuple(grid), source=source,
                  source_text=text)
    for _ in sweep.points():  # combinations can clash even if each value is fine alone
        pass
    return sweep
