"""Bounded run lengths: the step, the output intervals and the rows they make.

A scenario's durations are checked against each other before anything runs, so that no
value inside a key's own range makes a run that never ends or writes without bound:

* ``integration.dt`` (a fixed step) gives at most `MAX_STEPS` steps over
  ``integration.orbits``;
* ``output.timeseries_every`` and ``output.snapshot_every`` hold at least a few whole
  steps (`MIN_OUTPUT_STEPS`; ``dt: auto`` counts with its longest step,
  `AUTO_DT_MAX_ORBITS`): outputs fall on step ends, so an interval shorter than a step
  repeats the same time in several rows, and one of a step or two samples the step itself;
* the run has at most `MAX_TIMESERIES_ROWS` time-series rows and `MAX_SNAPSHOTS`
  snapshots.

Each refusal is one line naming the key.
"""

from __future__ import annotations

from ringsim.config.schema import Section
from ringsim.config.sections import Integration, Output

#: Longest step of ``dt: auto`` [orbits] (the run's ``engine.timestep`` takes it from here).
AUTO_DT_MAX_ORBITS = 1e-3
#: Fewest steps in an output interval.
MIN_OUTPUT_STEPS = 3
#: Most steps of a run with a fixed ``dt`` (far beyond any run ringsim is made for).
MAX_STEPS = 10**9
#: Most time-series rows of a run (about 1 GB of rows).
MAX_TIMESERIES_ROWS = 10**6
#: Most snapshots of a run.
MAX_SNAPSHOTS = 10**4


def check_intervals(top: Section, integration: Integration, output: Output) -> None:
    """Refuse a step or output interval that makes an unbounded run (module docstring);
    ``top`` is the scenario's top-level section (for the file in the message)."""
    orbits = integration.orbits
    fixed = not isinstance(integration.dt, str)
    step = float(integration.dt) if fixed else AUTO_DT_MAX_ORBITS
    if fixed and orbits / step > MAX_STEPS:
        raise top.error("integration.dt", f"dt = {step:g} orbits makes {orbits / step:.3g} "
                        f"steps over {orbits:g} orbits",
                        f"at most {MAX_STEPS:.0e} steps: dt >= {orbits / MAX_STEPS:.3g} "
                        "orbits, or auto")
    for key, every, most in (("timeseries_every", output.timeseries_every,
                              MAX_TIMESERIES_ROWS),
                             ("snapshot_every", output.snapshot_every, MAX_SNAPSHOTS)):
        if every < MIN_OUTPUT_STEPS * step:
            what = f"dt = {step:g} orbits" if fixed else \
                f"the longest step of dt: auto ({step:g} orbits)"
            raise top.error(f"output.{key}", f"{every:g} orbits is shorter than {what}",
                            f"at least {MIN_OUTPUT_STEPS * step:g} orbits; outputs fall on "
                            "step ends")
        if orbits / every > most:
            raise top.error(f"output.{key}", f"{every:g} orbits makes {orbits / every:.3g} "
                            f"outputs over {orbits:g} orbits",
                            f"at most {most:.0e} outputs: an interval >= "
                            f"{orbits / most:.3g} orbits")
