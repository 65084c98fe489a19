"""How a run ends: the stop of ``integration.until_equilibrium`` and the reason the run file
records (``stop_reason``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

#: With ``integration.until_equilibrium`` the run asks the equilibrium finder whether c and
#: H are stationary at every this many time-series outputs.
EQUILIBRIUM_CHECK_EVERY = 10


def equilibrium_reached(scenario, history: Mapping[str, Sequence[float]],
                        rows: int) -> str | None:
    """With ``integration.until_equilibrium``: the reason to stop if the equilibrium finder
    calls c and H (number- and mass-weighted) stationary after ``rows`` time-series rows,
    else None.  Checked every `EQUILIBRIUM_CHECK_EVERY` rows, so that a resumed run decides
    at the same rows.

    Parameters
    ----------
    scenario : Scenario
    history : mapping of the rows so far: ``orbits`` [orbits], ``velocity_dispersion`` and
        ``velocity_dispersion_mass_weighted`` [m/s], ``thickness`` and
        ``thickness_mass_weighted`` [m]
    rows : int
    """
    if not scenario.integration.until_equilibrium or (rows - 1) % EQUILIBRIUM_CHECK_EVERY:
        return None
    from ringsim.analysis.equilibrium import stationary_window  # the analysis layer

    h = {key: np.asarray(values) for key, values in history.items()}
    window = stationary_window(h["orbits"], h["velocity_dispersion"], h["thickness"],
                               mass_weighted=(h["velocity_dispersion_mass_weighted"],
                                              h["thickness_mass_weighted"]))
    if not window["in_equilibrium"]:
        return None
    return (f"until_equilibrium: c and H stationary (number- and mass-weighted) at orbit "
            f"{h['orbits'][-1]:.4g} ({window['reason']})")


def stop_reason(scenario, status: str, reason: str | None) -> str:
    """Why the run ended, for the file's ``stop_reason`` attribute."""
    if status == "stopped":
        return "interrupted (SIGINT/SIGTERM); continue with --resume"
    if reason:
        return reason
    orbits = scenario.integration.orbits
    if not scenario.integration.until_equilibrium:
        return f"reached integration.orbits = {orbits:g}"
    return (f"until_equilibrium: reached the maximum integration.orbits = {orbits:g} "
            "without c and H stationary")
