"""Bounded work on any YAML text: size, nesting, aliases, integers and strings are limited
before anything is built from it.

ringsim reads YAML from scenario, sweep and study files, from the ``scenario_yaml`` a run
file stores, and from ``ringsim epsilon --restitution``.  A hostile or broken text must end
in a one-line error quickly, whatever it holds; `check_events` walks the parser's events
(no Python objects are built, no recursion) and refuses, naming the dotted key:

* a text longer than `MAX_TEXT_CHARS` characters;
* nesting deeper than `MAX_DEPTH` mappings and lists (a scenario needs five);
* more than `MAX_VALUES` values once every alias is expanded (an "alias bomb" of ten
  levels of ten-fold aliases is 10^10 values from a few hundred characters);
* an integer of more than `MAX_INTEGER_DIGITS` digits (a seed is below 2^32, a count
  below 2^63);
* a key or string longer than `MAX_KEY_CHARS` or `MAX_STRING_CHARS` characters.

The limits are far above what any scenario, sweep or study needs and far below what
costs time or memory.
"""

from __future__ import annotations

import re
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.events import (
    AliasEvent,
    CollectionEndEvent,
    CollectionStartEvent,
    MappingStartEvent,
    ScalarEvent,
)

#: Longest YAML text read [characters] (a scenario is about 2 000).
MAX_TEXT_CHARS = 1_000_000
#: Deepest nesting of mappings and lists (a mixture's component radius is at depth 5).
MAX_DEPTH = 20
#: Most values (scalars, mappings and lists) once every alias is expanded.
MAX_VALUES = 100_000
#: Most digits of an integer.
MAX_INTEGER_DIGITS = 30
#: Longest key [characters].
MAX_KEY_CHARS = 200
#: Longest string value [characters] (a description, a path).
MAX_STRING_CHARS = 10_000

#: Longest dotted key named in an error message [characters].
_SHOWN_KEY_CHARS = 120
_INTEGER = re.compile(r"[-+]?(?:0o|0x)?([0-9a-fA-F_]+)")
_DECIMAL_OR_PREFIXED = re.compile(r"[-+]?(?:[0-9_]+|0o[0-7_]+|0x[0-9a-fA-F_]+)")


class BoundError(Exception):
    """A YAML text out of bounds: the dotted ``key``, the ``problem`` and what is
    ``allowed`` (`config.schema.parse_yaml` turns it into a ScenarioError)."""

    def __init__(self, key: str, problem: str, allowed: str):
        super().__init__(f"{key}: {problem} ({allowed})")
        self.key, self.problem, self.allowed = key, problem, allowed


class _Frame:
    """One open mapping or list: its dotted key, its values so far and its height."""

    def __init__(self, key: str, is_mapping: bool, anchor: str | None):
        self.key, self.is_mapping, self.anchor = key, is_mapping, anchor
        self.items = 0          # events inside (keys and values)
        self.values = 1         # expanded values, itself included
        self.height = 1         # nesting below, itself included
        self.current = ""       # the key whose value comes next (mappings)


def _child_key(frame: _Frame | None) -> str:
    if frame is None:
        return ""
    if frame.is_mapping:
        return f"{frame.key}.{frame.current}" if frame.key else frame.current
    return f"{frame.key}[{frame.items}]"


def _scalar_problem(event: ScalarEvent, is_key: bool) -> tuple[str, str] | None:
    """(what is wrong, what is allowed) of one scalar, or None."""
    text = event.value
    limit, what = (MAX_KEY_CHARS, "key") if is_key else (MAX_STRING_CHARS, "string")
    if len(text) > limit:
        return (f"a {what} of {len(text)} characters ({text[:20]!r}...)",
                f"a {what} of at most {limit} characters")
    if event.style is None and _DECIMAL_OR_PREFIXED.fullmatch(text):
        match = _INTEGER.fullmatch(text)
        digits = len(match.group(1).replace("_", "")) if match else 0
        if digits > MAX_INTEGER_DIGITS:
            return (f"an integer of {digits} digits ({text[:20]}...)",
                    f"an integer of at most {MAX_INTEGER_DIGITS} digits")
    return None


class _Walk:
    """The state of `check_events`: open collections, anchors and the expanded count."""

    def __init__(self) -> None:
        self.stack: list[_Frame] = []
        self.anchors: dict[str, tuple[int, int]] = {}   # anchor -> (values, height)
        self.total = 0

    @staticmethod
    def refuse(key: str, problem: str, allowed: str) -> BoundError:
        if len(key) > _SHOWN_KEY_CHARS:   # deep or long keys: their start and end
            key = key[:_SHOWN_KEY_CHARS // 2 - 3] + "..." + key[-_SHOWN_KEY_CHARS // 2:]
        return BoundError(key or "<yaml>", problem, allowed)

    def add(self, values: int, height: int, key: str, new: int) -> None:
        """A finished value of ``values`` expanded values (``new`` of them not counted
        yet) and ``height`` levels below it."""
        self.total += new
        if self.total > MAX_VALUES:
            raise self.refuse(key, f"more than {MAX_VALUES} values once the YAML aliases "
                              "(*name) are expanded", "a YAML text without alias bombs")
        if self.stack:
            parent = self.stack[-1]
            parent.values += values
            parent.height = max(parent.height, height + 1)
            if len(self.stack) + height > MAX_DEPTH:
                raise self.refuse(key, f"nested deeper than {MAX_DEPTH} levels",
                                  f"at most {MAX_DEPTH} levels of mappings and lists")
            parent.items += 1
            if parent.is_mapping and parent.items % 2 == 0:
                parent.current = ""

    def event(self, event: Any) -> None:
        parent = self.stack[-1] if self.stack else None
        is_key = parent is not None and parent.is_mapping and parent.items % 2 == 0
        key = _child_key(parent)
        if isinstance(event, ScalarEvent):
            problem = _scalar_problem(event, is_key)
            if problem:
                where = key if not is_key else (parent.key if parent else "")
                raise self.refuse(where, *problem)
            if is_key and parent is not None:
                parent.current = event.value
            if event.anchor:
                self.anchors[event.anchor] = (1, 0)
            self.add(1, 0, key, 1)
        elif isinstance(event, AliasEvent):
            values, height = self.anchors.get(event.anchor, (1, 0))
            if is_key and parent is not None:
                parent.current = f"*{event.anchor}"
            self.add(values, height, key, values)
        elif isinstance(event, CollectionStartEvent):
            if len(self.stack) + 1 > MAX_DEPTH:
                raise self.refuse(key, f"nested deeper than {MAX_DEPTH} levels",
                                  f"at most {MAX_DEPTH} levels of mappings and lists")
            self.stack.append(_Frame(key if not is_key else f"{key}<key>",
                                     isinstance(event, MappingStartEvent), event.anchor))
        elif isinstance(event, CollectionEndEvent):
            frame = self.stack.pop()
            if frame.anchor:
                self.anchors[frame.anchor] = (frame.values, frame.height)
            self.add(frame.values, frame.height, frame.key, 1)   # its children counted


def check_events(text: str) -> None:
    """Refuse a YAML text whose size, nesting, expanded aliases, integers or strings are
    out of bounds (module docstring) with `BoundError` naming the dotted key.

    Syntax errors (ruamel's YAMLError) propagate as they come.
    """
    walk = _Walk()
    if len(text) > MAX_TEXT_CHARS:
        raise walk.refuse("<file>", f"{len(text)} characters of YAML",
                          f"at most {MAX_TEXT_CHARS} characters")
    for event in YAML(typ="safe", pure=True).parse(text):
        walk.event(event)
