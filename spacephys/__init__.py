"""spacephys: gravity, thrust, missiles, collisions and explosions for space games.

The whole public API, re-exported by name. The run logs, scenarios and study tools are
imported on first use (they bring h5py, TOML and REBOUND's adapter): `import spacephys`
stays cheap for a game.
"""
import importlib

from ._jit import get_threads, set_threads
from . import entities
from .entities import *  # noqa: F401,F403 (entities.__all__: the specs)
from .errors import InstabilityError, PrecisionWarning
from .events import EVENT_DTYPE, EVENT_KINDS
from .geometry import polygon_center_of_mass
from .integrators import INTEGRATORS, Integrator, get_integrator
from .orbits import (Elements, elements_to_state, kepler_state, period, solve_kepler,
                     state_from_elements, state_to_elements, true_anomaly)
from .plans import Burn, hohmann
from .steppers import STEPPERS, Capabilities, capabilities
from .units import UNITS, UnitSystem, get_units
from .world import BOUNDARIES, DEFAULT_KINDS, GRAVITY_MODELS, RESPONSES, Body, World

__version__ = "0.1.0"

# name -> the module that defines it, imported on first use
_LAZY = {
    "RunLog": "runlog", "RunLogError": "runlog",
    "Run": "runs", "open_run": "runs", "replay": "runs", "resume": "runs",
    "RunResult": "runner", "run_scenario": "runner",
    "Scenario": "scenario", "ScenarioError": "scenario", "load_scenario": "scenario",
    "Recommendation": "study.recommend", "recommend": "study.recommend",
    "lambert": "lambert_problem", "Prediction": "predict", "Hits": "queries", "RayHits": "queries",
    "Filter": "queries",
    "sweep": "sweeps", "read_sweep": "sweeps", "Sweep": "sweeps", "SweepRun": "sweeps",
    "compile": "precompile", "Compiled": "precompile",
    "Ephemeris": "ephemeris",
}

__all__ = [
    "World", "Body", "InstabilityError", "PrecisionWarning", "DEFAULT_KINDS", "GRAVITY_MODELS", "RESPONSES", "BOUNDARIES",
    "EVENT_DTYPE", "EVENT_KINDS",
    *entities.__all__,
    "INTEGRATORS", "Integrator", "get_integrator", "STEPPERS", "Capabilities", "capabilities",
    "UNITS", "UnitSystem", "get_units",
    "polygon_center_of_mass",
    "RunLog", "Run", "RunLogError", "open_run", "replay", "resume",
    "Scenario", "ScenarioError", "load_scenario", "run_scenario", "RunResult",
    "recommend", "Recommendation",
    "Elements", "elements_to_state", "state_from_elements", "state_to_elements",
    "true_anomaly", "kepler_state", "period", "solve_kepler",
    "Burn", "hohmann", "lambert", "Prediction", "Hits", "RayHits", "Filter", "Ephemeris",
    "sweep", "read_sweep", "Sweep", "SweepRun",
    "set_threads", "get_threads",
    "__version__",
]


def __getattr__(name):
    if name in ("netplay", "draw", "portable"):   # imported on first use
        return importlib.import_module(f".{name}", __name__)
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'spacephys' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
