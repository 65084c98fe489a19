"""ringsim: collisional N-body simulations of a planetary-ring patch.

The public API (see docs/interface.md)::

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
    "load_scenario": ("ringsim.config.scenario", "load_scenario"),
    "Scenario": ("ringsim.config.scenario", "Scenario"),
    "ScenarioError": ("ringsim.config.schema", "ScenarioError"),
    "InputError": ("ringsim.errors", "InputError"),
    "run": ("ringsim.engine.runner", "run"),
    "open_run": ("ringsim.store.runfile", "open_run"),
    "equilibrium": ("ringsim.analysis.equilibrium", "equilibrium"),
    "install_resolver": ("ringsim.engine.resolver", "install_resolver"),
}
#: Modules of the public API reachable as ``from ringsim import restitution``.
_MODULES = {"restitution": "ringsim.physics.restitution"}

__all__ = ["__version__", *_EXPORTS, *_MODULES]


def __getattr__(name):
    if name in _MODULES:
        module = import_module(_MODULES[name])
        globals()[name] = module
        return module
    if name in _EXPORTS:
        module, attribute = _EXPORTS[name]
        value = getattr(import_module(module), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'ringsim' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
