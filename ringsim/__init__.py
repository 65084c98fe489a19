"""ringsim: collisional N-body simulations of a planetary-ring patch.

The public API (see CONTRACT.md)::

    sc = ringsim.load_scenario("scenarios/kappa0.yaml")
    path = ringsim.run(sc, output="runs/k0.h5")
    run = ringsim.open_run(path)
    eq = ringsim.equilibrium(run)
    handle = ringsim.install_resolver(sim, {"model": "dilley", "kappa": 0.1})

Names are imported on first use, so ``import ringsim`` stays light (no REBOUND, no HDF5).
"""

from importlib import import_module

__version__ = "0.1.0"

_EXPORTS = {
    "load_scenario": ("ringsim.scenario", "load_scenario"),
    "Scenario": ("ringsim.scenario", "Scenario"),
    "ScenarioError": ("ringsim.scenario", "ScenarioError"),
    "InputError": ("ringsim.errors", "InputError"),
    "run": ("ringsim.run", "run"),
    "open_run": ("ringsim.io", "open_run"),
    "equilibrium": ("ringsim.compare", "equilibrium"),
    "install_resolver": ("ringsim.resolver", "install_resolver"),
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name):
    if name in _EXPORTS:
        module, attribute = _EXPORTS[name]
        value = getattr(import_module(module), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ringsim' has no attribute {name!r}")
