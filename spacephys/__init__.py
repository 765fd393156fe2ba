"""spacephys: gravity, thrust, missiles, collisions and explosions for space games.

The whole public API, re-exported by name.
"""
from ._jit import get_threads, set_threads
from .entities import GUIDANCE, ExplosionSpec, MissileSpec, ShipSpec
from .events import EVENT_DTYPE, EVENT_KINDS
from .geometry import polygon_center_of_mass
from .integrators import INTEGRATORS, Integrator, get_integrator
from .runlog import RunLog, RunLogError
from .runs import Run, open_run, replay, resume
from .runner import RunResult, run_scenario
from .study.recommend import Recommendation, recommend
from .scenario import Scenario, ScenarioError, load_scenario
from .orbits import elements_to_state, kepler_state, period, solve_kepler
from .units import UNITS, UnitSystem, get_units
from .steppers import STEPPERS, Capabilities, capabilities
from .world import (BOUNDARIES, DEFAULT_KINDS, GRAVITY_MODELS, RESPONSES, Body,
                    InstabilityError, World)

__version__ = "0.1.0"

__all__ = [
    "World", "Body", "InstabilityError", "DEFAULT_KINDS", "GRAVITY_MODELS", "RESPONSES", "BOUNDARIES",
    "EVENT_DTYPE", "EVENT_KINDS",
    "ShipSpec", "MissileSpec", "ExplosionSpec", "GUIDANCE",
    "INTEGRATORS", "Integrator", "get_integrator", "STEPPERS", "Capabilities", "capabilities",
    "UNITS", "UnitSystem", "get_units",
    "polygon_center_of_mass",
    "RunLog", "Run", "RunLogError", "open_run", "replay", "resume",
    "Scenario", "ScenarioError", "load_scenario", "run_scenario", "RunResult",
    "recommend", "Recommendation",
    "elements_to_state", "kepler_state", "period", "solve_kepler",
    "set_threads", "get_threads",
    "__version__",
]
