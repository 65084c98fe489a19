"""Measured coefficients of restitution for `ringsim fit`: the CSV format, read and checked.

Header names carry units (docs/fit.md): ``v_m_s``, ``epsilon``; ``R_bar_m`` or ``R1_m`` and
``R2_m``; ``M_bar_kg`` or ``M1_kg`` and ``M2_kg`` (``inf`` for a wall or a brick, reduced by
``restitution.reduced_radius`` / ``reduced_mass``); optional ``sigma``.  Every bad cell is
bad input (exit status 2) naming the file, the column and the line.
"""

from __future__ import annotations

import csv
import difflib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringsim.errors import InputError, excerpt
from ringsim.physics import restitution as rs

_COLUMNS = ("v_m_s", "R_bar_m", "R1_m", "R2_m", "M_bar_kg", "M1_kg", "M2_kg", "epsilon",
            "sigma")
_HEADER_HELP = ("v_m_s, epsilon; R_bar_m or R1_m and R2_m; M_bar_kg or M1_kg and M2_kg; "
                "optional sigma")


# --- data ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RestitutionData:
    """Measured coefficients of restitution.

    Attributes
    ----------
    v : array [m/s]
        Normal impact speed.
    R_bar : array [m] or None
        Reduced radius of each pair (None if the file gives no radii).
    M_bar : array [kg] or None
        Reduced mass of each pair (None if the file gives no masses).
    epsilon : array [dimensionless]
        Measured coefficient of restitution.
    sigma : array [dimensionless] or None
        1-sigma error of epsilon; None: unknown (unit weights).
    source : str
        The file (for messages and the JSON).
    """

    v: np.ndarray
    R_bar: np.ndarray | None
    M_bar: np.ndarray | None
    epsilon: np.ndarray
    sigma: np.ndarray | None = None
    source: str = "<data>"

    def __len__(self) -> int:
        return int(self.v.size)

    @property
    def has_sizes(self) -> bool:
        return self.R_bar is not None and self.M_bar is not None

    def law_epsilon(self, restitution: Mapping[str, object]) -> np.ndarray:
        """epsilon [dimensionless] of a restitution law (a scenario's ``restitution``
        section) at the data's speeds (and reduced radii and masses), through the one
        dispatch ``restitution.epsilon_for_pair``."""
        return np.asarray(rs.epsilon_for_pair(restitution, self.v, self.R_bar, self.M_bar),
                          dtype=float)


def _parse_cell(path: str, column: str, line: int, text: str, allow_inf: bool) -> float:
    """One CSV cell as a float, or InputError naming the file, column and line."""
    text = text.strip()
    if not text:
        raise InputError(path, column, f"line {line}: empty value")
    try:
        value = float(text)
    except ValueError:
        raise InputError(path, column, f"line {line}: {excerpt(text)} is not a number") from None
    if math.isnan(value) or (math.isinf(value) and not (allow_inf and value > 0)):
        allowed = "a finite number or inf" if allow_inf else "a finite number"
        raise InputError(path, column, f"line {line}: {excerpt(text)} is not {allowed}")
    return value


def _check_range(path: str, column: str, lines: np.ndarray, values: np.ndarray,
                 bad: np.ndarray, what: str) -> None:
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(path, column, f"line {lines[i]}: {values[i]:g} is out of range "
                         f"({what})")


def _read_rows(path: str) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """Header and (line number, cells) of the data rows; comments and blank lines skipped."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(path, "<file>", f"not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise InputError(path, "<file>", f"cannot read: {exc.strerror or exc}") from None
    header: list[str] | None = None
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = next(csv.reader([line]))
        if header is None:
            header = [c.strip() for c in cells]
            continue
        rows.append((number, cells))
    if header is None:
        raise InputError(path, "<header>", f"the file has no header line (columns: "
                         f"{_HEADER_HELP})")
    return header, rows


def _check_header(path: str, header: list[str], need_sizes: bool) -> None:
    seen = set()
    for name in header:
        if name not in _COLUMNS:
            close = difflib.get_close_matches(name, _COLUMNS, n=1, cutoff=0.6)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise InputError(path, name or "<header>", f"unknown column {excerpt(name)} ({hint}"
                             f"columns: {_HEADER_HELP})")
        if name in seen:
            raise InputError(path, name, "the column appears twice")
        seen.add(name)
    for name in ("v_m_s", "epsilon"):
        if name not in seen:
            raise InputError(path, name, f"missing column (columns: {_HEADER_HELP})")
    for bar, pair, what in (("R_bar_m", ("R1_m", "R2_m"), "radius"),
                            ("M_bar_kg", ("M1_kg", "M2_kg"), "mass")):
        given = [name for name in pair if name in seen]
        if bar in seen and given:
            raise InputError(path, given[0], f"give either {bar} or {pair[0]} and {pair[1]}, "
                             "not both")
        if len(given) == 1:
            missing = pair[1] if given[0] == pair[0] else pair[0]
            raise InputError(path, missing, f"missing column ({given[0]} needs {missing}; "
                             f"use inf for a wall or brick)")
        if need_sizes and bar not in seen and not given:
            raise InputError(path, bar, f"missing column: the dilley model needs the reduced "
                             f"{what} ({bar}, or {pair[0]} and {pair[1]})")


def read_data(path: str | Path, need_sizes: bool = True) -> RestitutionData:
    """Read and check a CSV of measured coefficients of restitution (see the module doc).

    Parameters
    ----------
    path : CSV file
    need_sizes : bool
        Require radius and mass columns (the Dilley law uses them).

    Raises
    ------
    InputError
        Naming the file and the column (and the line) of the first problem: missing or
        unknown columns, non-numeric values, epsilon outside [0, 1], sizes, masses, speeds
        or sigmas that are not positive.
    """
    path = str(path)
    header, rows = _read_rows(path)
    _check_header(path, header, need_sizes)
    if not rows:
        raise InputError(path, "<rows>", "the file has a header but no data rows")
    columns: dict[str, list[float]] = {name: [] for name in header}
    lines = []
    for number, cells in rows:
        if len(cells) != len(header):
            raise InputError(path, "<rows>", f"line {number}: {len(cells)} values for "
                             f"{len(header)} columns")
        for name, cell in zip(header, cells, strict=True):
            allow_inf = name in ("R1_m", "R2_m", "M1_kg", "M2_kg")
            columns[name].append(_parse_cell(path, name, number, cell, allow_inf))
        lines.append(number)
    lines_arr = np.array(lines)
    arrays = {name: np.array(values, dtype=float) for name, values in columns.items()}

    v = arrays["v_m_s"]
    _check_range(path, "v_m_s", lines_arr, v, ~(v > 0), "an impact speed > 0 m/s")
    eps = arrays["epsilon"]
    _check_range(path, "epsilon", lines_arr, eps, (eps < 0) | (eps > 1), "0 <= epsilon <= 1")
    sigma = arrays.get("sigma")
    if sigma is not None:
        _check_range(path, "sigma", lines_arr, sigma, ~(sigma > 0), "sigma > 0")

    def reduced(bar: str, first: str, second: str, unit: str, reduce: Callable):
        if bar in arrays:
            x = arrays[bar]
            _check_range(path, bar, lines_arr, x, ~(x > 0), f"> 0 {unit}")
            return x
        if first not in arrays:
            return None
        a, b = arrays[first], arrays[second]
        _check_range(path, first, lines_arr, a, ~(a > 0), f"> 0 {unit}, or inf")
        _check_range(path, second, lines_arr, b, ~(b > 0), f"> 0 {unit}, or inf")
        _check_range(path, second, lines_arr, b, np.isinf(a) & np.isinf(b),
                     f"{first} and {second} cannot both be inf")
        return np.asarray(reduce(a, b), dtype=float)

    R_bar = reduced("R_bar_m", "R1_m", "R2_m", "m", rs.reduced_radius)
    M_bar = reduced("M_bar_kg", "M1_kg", "M2_kg", "kg", rs.reduced_mass)
    return RestitutionData(v=v, R_bar=R_bar, M_bar=M_bar, epsilon=eps, sigma=sigma,
                           source=path)


