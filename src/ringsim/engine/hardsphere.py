"""REBOUND's built-in hard-sphere resolver in a ringsim run (``integration.resolver:
rebound_hardsphere``), the reference ringsim's own resolver is compared with.

REBOUND's ``reb_collision_resolve_hardsphere`` finds the overlapping, approaching pairs of
its tree search at the end of each step and applies the normal impulse of a coefficient
of restitution it asks from ``coefficient_of_restitution(sim, v)`` with the signed normal
speed v alone; it keeps ``minimum_collision_velocity``, and adds to ``collisions_plog``
and ``collisions_log_n`` as ringsim's resolver does.  `HardsphereHandle` installs it with
the scenario's law (a law of the impact speed alone: the scenario refuses the others) and
counts, in that callback, what can be counted outside the resolver: the collisions, their
mean eps and mean normal impact speed.  The rest of what ringsim's C resolver tallies is
not measured: those time series are left out of the run file (`ABSENT_TIMESERIES`), and
the run file's attribute ``absent_statistics`` names them.

`install_scenario_resolver` installs the resolver a scenario asks for: ringsim's
(``engine.resolver``) or this one.  The handle has the methods of ``ResolverHandle`` that
the run loop and its checkpoints use.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import rebound

from ringsim.engine.resolver import ResolverHandle, install_resolver
from ringsim.physics import restitution as rs

#: The run file's time series that ringsim's C resolver tallies and REBOUND's resolver
#: does not (with ``rebound_hardsphere`` they are not written).
ABSENT_TIMESERIES = ("multi_encounters", "law_outside_speeds", "law_outside_sizes",
                     "law_speeds_below", "law_speeds_above", "law_sizes_below",
                     "law_sizes_above", "law_masses_below", "law_masses_above",
                     "law_critically_damped", "law_inside_all", "one_minus_epsilon_histogram",
                     "impact_speed_histogram", "normal_dissipation")

#: The counters a checkpoint saves (``/checkpoint_statistics``): collisions, sum of eps,
#: sum of the normal impact speeds [m/s].
_STATE_FIELDS = ("count", "sum_epsilon", "sum_vn")


class HardsphereHandle:
    """REBOUND's hard-sphere resolver with a law of the impact speed, and its tallies.

    Parameters
    ----------
    restitution : mapping
        The scenario's ``restitution`` section, a law whose ``uses_pair`` is False
        (``physics.restitution.RESTITUTION``).
    """

    friction = None      # smooth spheres: REBOUND's resolver has no spins
    log_capacity = 0     # no collision log

    def __init__(self, restitution: Mapping[str, Any]):
        model, params = rs.model_parameters(restitution)
        law = rs.RESTITUTION[model]
        if law.uses_pair:
            raise ValueError(f"restitution: REBOUND's hard-sphere resolver cannot apply the "
                             f"{model} law (it depends on the pair's radius and mass)")
        self.model = model
        self.parameters = dict(params)
        self._function = law.function
        self._sim: rebound.Simulation | None = None
        self.reset_stats()

    def _coefficient(self, sim_pointer: Any, v: float) -> float:
        """eps of the signed normal speed v [m/s] REBOUND passes; tallied."""
        speed = abs(v)
        eps = float(self._function(speed, **self.parameters))
        self._count += 1
        self._sum_epsilon += eps
        self._sum_vn += speed
        return eps

    def reinstall(self, sim: rebound.Simulation) -> HardsphereHandle:
        """Put REBOUND's hard-sphere resolver with this law into ``sim`` (after a
        checkpoint is loaded or the box is enlarged: REBOUND keeps no function pointers)."""
        if sim.collision != "tree":
            raise ValueError(f"REBOUND's hard-sphere resolver runs here with the tree search, "
                             f"the simulation has {sim.collision!r}")
        sim.collision_resolve = "hardsphere"
        sim.coefficient_of_restitution = self._coefficient
        self._sim = sim
        return self

    def close(self) -> None:
        """Forget the simulation (nothing is allocated outside Python)."""
        self._sim = None

    # -- statistics -----------------------------------------------------------------------

    def stats(self) -> dict[str, Any]:
        """``count``, ``mean_epsilon``, ``mean_vn`` [m/s] (NaN before the first collision),
        ``sum_epsilon`` and ``sum_vn`` [m/s] since creation or the last reset."""
        count = self._count
        return {"count": count, "sum_epsilon": self._sum_epsilon, "sum_vn": self._sum_vn,
                "mean_epsilon": self._sum_epsilon / count if count else math.nan,
                "mean_vn": self._sum_vn / count if count else math.nan}

    def reset_stats(self) -> None:
        """Zero the tallies."""
        self._count = 0
        self._sum_epsilon = 0.0
        self._sum_vn = 0.0

    def stats_state(self) -> dict[str, np.ndarray]:
        """The tallies as 0-d arrays, for a checkpoint (`set_stats` restores them)."""
        return {"count": np.asarray(self._count, dtype=np.int64),
                "sum_epsilon": np.asarray(self._sum_epsilon, dtype=np.float64),
                "sum_vn": np.asarray(self._sum_vn, dtype=np.float64)}

    def set_stats(self, state: Mapping[str, Any]) -> None:
        """Restore `stats_state`; ValueError naming a missing or non-scalar field."""
        for name in _STATE_FIELDS:
            if name not in state or np.shape(state[name]) != ():
                raise ValueError(f"statistics: {name} must be a number")
        self._count = int(state["count"])
        self._sum_epsilon = float(state["sum_epsilon"])
        self._sum_vn = float(state["sum_vn"])


def install_scenario_resolver(sim: rebound.Simulation, scenario: Any
                              ) -> ResolverHandle | HardsphereHandle:
    """The scenario's resolver (``integration.resolver``) installed in ``sim``."""
    if scenario.integration.resolver == "rebound_hardsphere":
        return HardsphereHandle(scenario.restitution_dict()).reinstall(sim)
    return install_resolver(sim, scenario.restitution_dict(), scenario.friction_dict(),
                            scenario.particles.inertia_factor,
                            log_capacity=scenario.output.log_collisions,
                            collision_detection=scenario.integration.collision_detection)


def resolver_attributes(handle: ResolverHandle | HardsphereHandle) -> dict[str, Any]:
    """Run-file attributes of the resolver: with REBOUND's, ``absent_statistics`` (the
    time series it does not tally, `ABSENT_TIMESERIES`, separated by ", ")."""
    if isinstance(handle, HardsphereHandle):
        return {"absent_statistics": ", ".join(ABSENT_TIMESERIES)}
    return {}
