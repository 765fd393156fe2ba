"""`spacephys bench compile`: what a scene waits for before its first step, and what it compiles.

Every shipped scenario runs in a fresh process with an empty numba cache
(NUMBA_CACHE_DIR pointed at a new folder): the seconds to import spacephys, to build the
scenario's World, and to its first step (what `spacephys run` does before it: the energy and
momentum it reports, the timeline's entries at t = 0, then step(1)), and the kernels numba
compiled on the way, each with its own seconds (numba's "numba:compile" events, the time of
the callees it compiled on the way taken out). Then "every kernel": every integrator on a
gravity-only scene, then again with collisions and ships, in one cold process; and the warm
start: the default scene's import and first step with the cache filled.
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from . import header

DEFAULT = "star_system"

# numba's compile events, per kernel (precompile.Compiles), from the first compilation on:
# registered after the import, which compiles nothing
_LISTENER = """
from numba.core import event
from spacephys.precompile import Compiles
_compiles = Compiles()
event.register("numba:compile", _compiles)
"""

_SCENARIO_PROBE = """
import json, sys, time
start = time.perf_counter()
import numpy as np
import spacephys as sp
imported = time.perf_counter()
""" + _LISTENER + """
from spacephys.scenario import apply, load_scenario
sc = load_scenario(sys.argv[1])
w, ids = sc.build()
built = time.perf_counter()
w.energy(True), w.momentum(True), w.angular_momentum(True)
for t, action, value, path in sc.timeline:
    if t <= 0.0:
        apply(w, ids, sc.data["missiles"], action, value, path)
w.step(1)
first = time.perf_counter()
print(json.dumps({"import_s": imported - start, "build_s": built - imported,
                  "first_step_s": first - start, "kernels": _compiles.kernels}))
"""

_EVERY_PROBE = """
import json, time
start = time.perf_counter()
import spacephys as sp
""" + _LISTENER + """
from spacephys.scenes import uniform_sphere
for name in sp.INTEGRATORS:
    w = uniform_sphere(64, dt=1e-3)
    w.integrator = name
    w.step(1)
w.energy()
gravity = time.perf_counter()
for name in sp.INTEGRATORS:
    w = uniform_sphere(16, dt=1e-3, softening=0.05)
    w.integrator = name
    w.set_collision("*", "*", "merge")
    w.add_ship(sp.ShipSpec(fuel_mass=1.0, max_thrust=1.0, exhaust_speed=10.0), (5.0, 0.0, 0.0))
    w.step(1)
print(json.dumps({"gravity_s": gravity - start, "all_s": time.perf_counter() - start,
                  "kernels": _compiles.kernels}))
"""

# the floor: any numba program's start, importing numpy and numba and calling one cached kernel
_FLOOR_MODULE = "import numba\n\n@numba.njit(cache=True)\ndef total(a):\n    return a.sum()\n"
_FLOOR_PROBE = """
import json, time
start = time.perf_counter()
import numpy as np
import floor_probe
floor_probe.total(np.ones(3))
print(json.dumps(time.perf_counter() - start))
"""

# A program whose environment has only spacephys's own dependencies: without scipy (the
# bench and test extras bring it), whose linear algebra numba's first call imports when it
# is installed, looking for a BLAS (0.16 s; no kernel of spacephys uses one). Put before a
# probe, before its clock starts: importing scipy then fails as if it were not installed.
_NO_SCIPY = """
import sys
class _NoScipy:
    def find_spec(self, name, path=None, target=None):
        if name == "scipy" or name.startswith("scipy."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, _NoScipy())
"""


def scenarios():
    """The shipped scenarios' names, sorted."""
    from ..scenario import shipped
    return list(shipped())


def _env(cache):
    """A fresh Python's environment with numba's cache in `cache`, and Python's bytecode
    cached as an installed package has it (PYTHONDONTWRITEBYTECODE, where set, would add the
    compiling of spacephys's source, 0.07 s, to every warm start)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache),
               PYTHONPATH=os.pathsep.join([str(cache), os.environ.get("PYTHONPATH", "")]))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _probe(code, cache, *args, scipy=True):
    """Run `code` in a fresh Python with numba's cache in `cache`; its last line, parsed.
    scipy=False: as if scipy were not installed (_NO_SCIPY)."""
    env = _env(cache)
    code = code if scipy else _NO_SCIPY + code
    out = subprocess.run([sys.executable, "-c", code, *args], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def _kernels(raw):
    """[{kernel, compilations, seconds}], the slowest first."""
    rows = [{"kernel": k, "compilations": n, "seconds": s} for k, (n, s) in raw.items()]
    return sorted(rows, key=lambda r: -r["seconds"])


def cold_scenario(name):
    """A shipped scenario in a fresh process with an empty cache: its start's seconds
    and the kernels it compiled."""
    with tempfile.TemporaryDirectory() as cache:
        r = _probe(_SCENARIO_PROBE, cache, name)
    return {"scenario": name, "import_s": r["import_s"], "build_s": r["build_s"],
            "first_step_s": r["first_step_s"], "compile_s": sum(s for _, s in r["kernels"].values()),
            "kernels": _kernels(r["kernels"])}


def every_kernel():
    """Every integrator, gravity only then with collisions and ships, in one cold process."""
    with tempfile.TemporaryDirectory() as cache:
        r = _probe(_EVERY_PROBE, cache)
    return {"gravity_s": r["gravity_s"], "all_s": r["all_s"], "kernels": _kernels(r["kernels"])}


def warm_start(repeats=3):
    """The default scene's import and first step with the cache filled (the least of
    `repeats` fresh processes), and the floor: importing numpy and numba and calling one
    cached numba function. Measured in this environment, and again as if only spacephys's
    own dependencies were installed ("installed": no scipy, see _NO_SCIPY), as a game that
    depends on spacephys has them."""
    with tempfile.TemporaryDirectory() as cache:
        Path(cache, "floor_probe.py").write_text(_FLOOR_MODULE)
        _probe(_SCENARIO_PROBE, cache, DEFAULT)                 # fills the cache
        _probe(_FLOOR_PROBE, cache)                             # compiles the floor's function
        out = {}
        for scipy in (True, False):
            # alternated, so that a slower spell of the machine falls on both
            warm, floor = [], []
            for _ in range(repeats):
                warm.append(_probe(_SCENARIO_PROBE, cache, DEFAULT, scipy=scipy))
                floor.append(_probe(_FLOOR_PROBE, cache, scipy=scipy))
            out[scipy] = {"import_s": min(w["import_s"] for w in warm),
                          "first_step_s": min(w["first_step_s"] for w in warm),
                          "kernels_compiled": max(len(w["kernels"]) for w in warm),
                          "floor_s": min(floor)}
    return {**out[True], "installed": out[False]}


def compile_bench(quick=False):
    """The benchmark (see the module); quick: the default scene and two_body only, no
    'every kernel'."""
    names = [DEFAULT, "two_body"] if quick else scenarios()
    rows = [cold_scenario(name) for name in names]
    return {**header("compile", quick), "scenarios": rows, "warm": warm_start(),
            "every_kernel": None if quick else every_kernel()}


def format_compile(r, top=3):
    lines = [f"compile benchmark on {r['machine']} ({r['versions']}): fresh processes, each "
             f"with an empty numba cache", "",
             "| scenario | import | first step (import and compile included) | compiled "
             "| kernels | slowest kernels (own seconds) |", "|---|---|---|---|---|---|"]
    for s in r["scenarios"]:
        slow = ", ".join(f"{k['kernel']} {k['seconds']:.1f}" for k in s["kernels"][:top])
        lines.append(f"| {s['scenario']} | {s['import_s']:.2f} s | {s['first_step_s']:.1f} s | "
                     f"{s['compile_s']:.1f} s | {len(s['kernels'])} | {slow} |")
    w, i = r["warm"], r["warm"]["installed"]
    lines += ["", f"warm cache, {DEFAULT}: import {w['import_s']:.2f} s, import + first step "
              f"{w['first_step_s']:.2f} s ({w['kernels_compiled']} kernels compiled); the floor "
              f"(import numpy and numba, call one cached numba function) {w['floor_s']:.2f} s",
              f"  with spacephys's own dependencies only (no scipy): import {i['import_s']:.2f} "
              f"s, import + first step {i['first_step_s']:.2f} s "
              f"({i['kernels_compiled']} kernels compiled); the floor {i['floor_s']:.2f} s"]
    e = r["every_kernel"]
    if e is not None:
        slow = ", ".join(f"{k['kernel']} {k['seconds']:.1f}" for k in e["kernels"][:6])
        lines += [f"every kernel, cold: every integrator gravity only {e['gravity_s']:.1f} s, "
                  f"then with collisions and ships {e['all_s']:.1f} s in all "
                  f"({len(e['kernels'])} kernels; slowest: {slow})"]
    return "\n".join(lines)
