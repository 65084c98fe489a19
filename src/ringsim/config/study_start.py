"""The case key ``start`` of a study file: a case whose runs start from another case's run.

``start: {case: NAME, seed: SEED, snapshot: -1, tile: [n_x, n_y]}`` sets
``sheet.initial_state`` of the case's runs to a snapshot of the run of case ``NAME`` made
in the same form (full or quick) and with the same variant, tiled ``n_x`` by ``n_y``.
``seed`` is optional: without it each run starts from the referenced case's run of its own
seed (the replicas stay independent); with it every run starts from that one seed's run.

The referenced run gives the particles and the box, so the keys a run-file start replaces
(`FILE_KEYS`) act on the started case only through it: a case that starts from a run may
not set them (nor ``sheet.initial_state``) itself, and the study's, ``quick``'s and the
variants' overrides of them reach the started run through the referenced one, where they
apply.  The run file's name is left to the study (``ringsim.study.runs``): it is the
referenced run's hash, so the started run's identity holds that hash, never a path.
See docs/studies.md.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ringsim.config.initial_state import MAX_TILE
from ringsim.config.scenario import MAX_SEED, Scenario, scenario_from_dict
from ringsim.config.schema import Section, show

#: The ``sheet.initial_state.file`` of a started run until the study names it after the
#: referenced run's hash.
START_FILE = "start.h5"
#: Keys of ``start``.
START_KEYS = ("case", "seed", "snapshot", "tile")
#: Scenario keys (dotted) that a start from a run file replaces: the file gives the
#: particles and the box.
FILE_KEYS = ("sheet.optical_depth", "sheet.n_particles", "sheet.aspect",
             "sheet.initial_dispersion", "sheet.initial_toomre_q")


@dataclass(frozen=True)
class Start:
    """Where a case's runs start (the case key ``start``).

    Attributes
    ----------
    case : str
        The case whose run they start from.
    seed : int or None
        That run's seed (None: the seed of the run being made).
    snapshot : int
        The snapshot of that run (negative counts from the end).
    tile : (int, int)
        Copies of that snapshot's sheet radially and azimuthally.
    """

    case: str
    seed: int | None = None
    snapshot: int = -1
    tile: tuple[int, int] = (1, 1)

    def to_dict(self) -> dict[str, Any]:
        """The key as the report shows it."""
        return {"case": self.case, "seed": self.seed, "snapshot": self.snapshot,
                "tile": list(self.tile)}


def read_start(cases: Section, name: str, value: Any, names: Sequence[str]) -> Start:
    """``cases.NAME.start`` checked against the study's case names."""
    allowed = ("a mapping {case: NAME, seed: SEED, snapshot: -1, tile: [n_x, n_y]} "
               "(seed, snapshot and tile optional)")
    if not isinstance(value, Mapping):
        raise cases.error(f"{name}.start", f"got {show(value)}", allowed)
    sec = Section(cases.file, cases.key(f"{name}.start"), value)
    sec.check_keys(START_KEYS)
    case = sec.get("case", None, allowed)
    if case not in names:
        close = difflib.get_close_matches(str(case), names, n=1, cutoff=0.6)
        raise sec.error("case", f"unknown case {show(case)}",
                        (f"did you mean {close[0]!r}? " if close else "")
                        + f"the cases: {', '.join(names)}")
    if case == name:
        raise sec.error("case", f"{name!r} starts from itself", "another case")
    seed = sec.integer("seed", None, ge=0, le=MAX_SEED) if sec.has("seed") else None
    tile_allowed = f"a list of two integers [n_x, n_y], each 1 ... {MAX_TILE}"
    tile = sec.get("tile", [1, 1], tile_allowed)
    if (not isinstance(tile, list) or len(tile) != 2
            or not all(isinstance(n, int) and not isinstance(n, bool) for n in tile)
            or not all(1 <= n <= MAX_TILE for n in tile)):
        raise sec.error("tile", f"got {show(tile)}", tile_allowed)
    return Start(case=str(case), seed=seed, snapshot=sec.integer("snapshot", -1),
                 tile=(tile[0], tile[1]))


def check_case_keys(cases: Section, name: str, overrides: Mapping) -> None:
    """A case that starts from a run sets neither ``sheet.initial_state`` nor a key the
    run file replaces (`FILE_KEYS`)."""
    for dotted in overrides:
        key = str(dotted)
        if key == "sheet" or key.startswith("sheet.initial_state") or key in FILE_KEYS:
            raise cases.error(f"{name}.{key}", "given with start, which takes the particles "
                              "and the box from the referenced case's run",
                              f"remove the key (or start): a start replaces "
                              f"sheet.initial_state and {', '.join(FILE_KEYS)}")


def check_cycles(cases: Section, starts: Mapping[str, Start]) -> None:
    """Refuse a case that starts, through other cases, from itself."""
    for name in starts:
        seen = [name]
        here = starts[name].case
        while here in starts and here not in seen:
            seen.append(here)
            here = starts[here].case
        if here == name:
            raise cases.error(f"{name}.start", "the starts form a cycle: "
                              + " -> ".join([*seen, here]),
                              "each chain of starts ends at a case without start")


def without_file_keys(overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``overrides`` without the keys a run-file start replaces (they act on a started run
    through the run it starts from)."""
    return {k: v for k, v in overrides.items() if k not in FILE_KEYS}


def started(scenario: Scenario, file: str, start: Start) -> Scenario:
    """``scenario`` starting from ``file``'s snapshot ``start.snapshot`` tiled
    ``start.tile``: without the keys the file replaces.  ScenarioError as for any scenario
    (e.g. ``integration.until_equilibrium`` with a tiled start)."""
    d = scenario.to_dict()
    sheet = d["sheet"]
    for dotted in FILE_KEYS:
        sheet.pop(dotted.split(".", 1)[1], None)
    sheet["initial_state"] = {"file": file, "snapshot": start.snapshot,
                              "tile": list(start.tile)}
    return scenario_from_dict(d, scenario.source)
