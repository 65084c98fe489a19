"""The small validation framework of ringsim's YAML files: one-line errors naming the key.

Files are read as YAML 1.2 (ruamel.yaml's safe loader, `parse_yaml`): numbers are numbers as
users write them (``3.7931e16``, ``1e8``), ``yes``/``no``/``on``/``off`` are text (only
``true``/``false`` are booleans), ``010`` is ten (octal is ``0o10``), and a key given twice
is an error.

`Section` wraps one mapping of a file being validated, with its dotted-key prefix, and
reads typed values from it (`Section.number`, `Section.integer`, ...), raising
`ScenarioError` ``"<file>: <dotted.key>: <what is wrong> (<allowed range or type>)"``.
"""

from __future__ import annotations

import copy
import difflib
import math
import numbers
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any

import numpy as np
from ruamel.yaml import YAML
from ruamel.yaml.error import MarkedYAMLError, YAMLError

from ringsim.config.bounds import MAX_TEXT_CHARS, BoundError, check_events
from ringsim.errors import InputError, excerpt

REQUIRED = object()


# --- errors -----------------------------------------------------------------------------------

class ScenarioError(InputError):
    """A scenario or sweep file is unreadable or invalid.

    ``str(error)`` is the single line ``"<file>: <key>: <problem> (<allowed>)"``.

    Attributes
    ----------
    file : str
        The file (or the ``source`` name given to `scenario_from_text`).
    key : str
        Dotted key of the offending value (e.g. ``particles.size_distribution.r_min``),
        or ``<file>`` (cannot read the file) or ``<yaml>`` (syntax error, not a mapping).
    problem : str
        What is wrong.
    allowed : str
        The allowed range or type.
    """

    def __init__(self, file: str, key: str, problem: str, allowed: str):
        problem = " ".join(str(problem).split())
        allowed = " ".join(str(allowed).split())
        super().__init__(str(file), str(key), f"{problem} ({allowed})")
        self.problem = problem
        self.allowed = allowed

    def __reduce__(self):
        # Exceptions are pickled via their args; ours has four (sweeps run in processes).
        return (type(self), (self.file, self.key, self.problem, self.allowed))


def show(value: Any) -> str:
    """A short one-line rendering of a user's value for an error message (a bounded
    excerpt: its cost does not grow with the value, `ringsim.errors.excerpt`)."""
    return excerpt(value, 60)


def _is_real(value: Any) -> bool:
    """True for int/float (and numpy numbers), False for bool, str, None."""
    return (isinstance(value, numbers.Real)
            and not isinstance(value, (bool, np.bool_)))


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


class Section:
    """One mapping of the scenario being validated, with its dotted-key prefix."""

    def __init__(self, file: str, prefix: str, mapping: Mapping):
        self.file = file
        self.prefix = prefix
        self.mapping = mapping

    def key(self, name: str) -> str:
        return f"{self.prefix}.{name}" if self.prefix else name

    def error(self, name: str, problem: str, allowed: str) -> ScenarioError:
        return ScenarioError(self.file, self.key(name), problem, allowed)

    def check_keys(self, allowed: Sequence[str], context: str = "") -> None:
        """Reject keys not in ``allowed``, suggesting the closest valid one; ``context``
        ("the dilley model") says whose keys they are."""
        for raw_key in self.mapping:
            name = str(raw_key)
            if raw_key in allowed:
                continue
            close = difflib.get_close_matches(name, allowed, n=1, cutoff=0.6)
            if not close:  # case slips, e.g. "omega" for "Omega"
                lower = {a.lower(): a for a in allowed}
                close = [lower[name.lower()]] if name.lower() in lower else []
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise self.error(name, f"unknown key {show(name)}" + (f" for {context}" if context
                                                                else ""),
                             f"{hint}allowed here: {', '.join(allowed)}")

    def has(self, name: str) -> bool:
        return name in self.mapping

    def get(self, name: str, default: Any, allowed: str) -> Any:
        """The raw value, ``default`` if absent; raise if required or given empty."""
        if name not in self.mapping:
            if default is REQUIRED:
                raise self.error(name, f"missing required key {name!r}", allowed)
            return default
        value = self.mapping[name]
        if value is None:
            raise self.error(name, "no value given", allowed)
        return value

    def number(self, name: str, default: Any = REQUIRED, *, unit: str = "",
               gt: float | None = None, ge: float | None = None,
               lt: float | None = None, le: float | None = None) -> float:
        """A finite real number in the given interval (bool and strings are not numbers)."""
        allowed = _range_text("a finite real number", unit, gt, ge, lt, le)
        value = self.get(name, default, allowed)
        if isinstance(value, (bool, np.bool_)):
            raise self.error(name, f"got a boolean ({value}), not a number", allowed)
        if isinstance(value, str):
            raise self.error(name, f"got the string {show(value)}, not a number"
                             + _string_number_hint(value), allowed)
        if not _is_real(value):
            raise self.error(name, f"got {type(value).__name__} {show(value)}, not a number",
                             allowed)
        x = float(value)
        if not math.isfinite(x):
            raise self.error(name, f"{x} is not finite", allowed)
        if ((gt is not None and not x > gt) or (ge is not None and not x >= ge)
                or (lt is not None and not x < lt) or (le is not None and not x <= le)):
            raise self.error(name, f"{x:g}{' ' + unit if unit else ''} is out of range",
                             allowed)
        return x

    def integer(self, name: str, default: Any = REQUIRED, *, ge: int | None = None,
                le: int | None = None) -> int:
        allowed = _range_text("an integer", "", None, ge, None, le)
        value = self.get(name, default, allowed)
        if not _is_integer(value):
            kind = ("a boolean" if isinstance(value, (bool, np.bool_))
                    else f"{type(value).__name__} {show(value)}")
            raise self.error(name, f"got {kind}, not an integer", allowed)
        n = int(value)
        if (ge is not None and n < ge) or (le is not None and n > le):
            raise self.error(name, f"{n} is out of range", allowed)
        return n

    def boolean(self, name: str, default: Any = REQUIRED) -> bool:
        allowed = "true or false"
        value = self.get(name, default, allowed)
        if isinstance(value, str) and value.lower() in _YAML11_BOOLEANS:
            raise self.error(name, f"got the text {show(value)}, not a boolean (YAML 1.2 "
                             "reads only true and false as booleans)", allowed)
        if not isinstance(value, (bool, np.bool_)):
            raise self.error(name, f"got {type(value).__name__} {show(value)}", allowed)
        return bool(value)

    def string(self, name: str, default: Any = REQUIRED,
               choices: Sequence[str] | None = None, what: str = "a non-empty string",
               allow_empty: bool = False) -> str:
        allowed = f"one of: {', '.join(choices)}" if choices else what
        value = self.get(name, default, allowed)
        if not isinstance(value, str):
            raise self.error(name, f"got {type(value).__name__} {show(value)}, not a string",
                             allowed)
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, choices, n=1, cutoff=0.6)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise self.error(name, f"unknown value {show(value)}", hint + allowed)
        if not allow_empty and not value.strip():
            raise self.error(name, "is empty", allowed)
        return value

    def number_or_auto(self, name: str, default: Any, **limits) -> float | str:
        """The string ``"auto"`` or a number obeying ``limits`` (see `number`)."""
        if self.mapping.get(name, default) == "auto":
            return "auto"
        try:
            return self.number(name, default, **limits)
        except ScenarioError as exc:
            raise self.error(name, exc.problem, f"auto, or {exc.allowed}") from None

    def section(self, name: str, required: bool = False, allowed: str | None = None,
                keys: Sequence[str] | None = None) -> Section:
        """A nested mapping (empty if absent and not required); ``keys`` (the keys it may
        hold) describe it in the error message."""
        if allowed is None:
            allowed = f"a mapping with keys: {', '.join(keys)}" if keys else "a mapping"
        value = self.get(name, REQUIRED if required else {}, allowed)
        if not isinstance(value, Mapping):
            raise self.error(name, f"got {type(value).__name__} {show(value)}, "
                             "not a mapping", allowed)
        return Section(self.file, self.key(name), value)


#: Words that YAML 1.1 (PyYAML) read as booleans and YAML 1.2 reads as text.
_YAML11_BOOLEANS = frozenset({"yes", "no", "on", "off", "y", "n"})


def _string_number_hint(text: str) -> str:
    """Why a number-looking string was read as text, and the fix (YAML 1.2 reads every
    unquoted number as a number, so only quotes make one text)."""
    try:
        x = float(text)
    except ValueError:
        return ""
    return "; remove the quotes" if math.isfinite(x) else ""


def _range_text(kind: str, unit: str, gt, ge, lt, le) -> str:
    """'a finite real number > 0 [m]', 'an integer >= 2', 'a finite real number in (0, 3]'."""
    def fmt(x) -> str:
        return str(x) if isinstance(x, int) else f"{x:g}"

    low = (f"({fmt(gt)}", gt) if gt is not None else (f"[{fmt(ge)}", ge) if ge is not None \
        else None
    high = (f"{fmt(lt)})", lt) if lt is not None else (f"{fmt(le)}]", le) if le is not None \
        else None
    if low and high:
        text = f"{kind} in {low[0]}, {high[0]}"
    elif low:
        text = f"{kind} {'>' if gt is not None else '>='} {fmt(low[1])}"
    elif high:
        text = f"{kind} {'<' if lt is not None else '<='} {fmt(high[1])}"
    else:
        text = kind
    return f"{text} [{unit}]" if unit else text


def plain(value: Any) -> Any:
    """A deep copy with every mapping a dict and every list/tuple a list."""
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return copy.deepcopy(value)


def read_text(path: str | PathLike) -> str:
    """The file's text, or ScenarioError with key "<file>"."""
    try:
        with open(path, "rb") as stream:
            data = stream.read(4 * MAX_TEXT_CHARS + 1)   # UTF-8: at most 4 bytes a character
        if len(data) > 4 * MAX_TEXT_CHARS:
            raise ScenarioError(str(path), "<file>", "the file is too large for a YAML file",
                                f"at most {MAX_TEXT_CHARS} characters")
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(str(path), "<file>", f"not UTF-8 text ({exc.reason})",
                            "a UTF-8 YAML text file") from None
    except OSError as exc:
        raise ScenarioError(str(path), "<file>", f"cannot read: {exc.strerror or exc}",
                            "an existing, readable YAML file") from None


def parse_yaml(text: str, source: str) -> Any:
    """YAML 1.2 text -> plain Python data (dicts, lists, str, int, float, bool, None).

    Safe loading only (no Python objects from tags); a syntax error or a duplicated key
    raises `ScenarioError` with key ``"<yaml>"`` and the line and column.  The text is
    checked first for bounded work (`config.bounds`: size, nesting, expanded aliases,
    integer digits, string lengths), each refusal naming its dotted key.
    """
    loader = YAML(typ="safe", pure=True)
    try:
        check_events(text)
        return loader.load(text)
    except BoundError as exc:
        raise ScenarioError(source, exc.key, exc.problem, exc.allowed) from None
    except YAMLError as exc:
        mark = None
        if isinstance(exc, MarkedYAMLError):
            mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = (getattr(exc, "problem", None) or str(exc)).splitlines()[0]
        raise ScenarioError(source, "<yaml>", f"invalid YAML{where}: {problem}",
                            "YAML syntax: 'key: value' lines, nesting by indentation") from None
