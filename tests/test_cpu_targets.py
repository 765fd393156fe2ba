"""The golden digests (test_golden.py) compiled for other CPUs: in subprocesses whose kernels
numba compiles for another target (NUMBA_CPU_NAME), the recorded digests, bit for bit. A
change that made the rounding depend on the vector width (a fastmath flag letting LLVM split
a sum into partial sums) or on fused multiply-adds fails here on any x86-64 machine.

x86-64 (SSE2: two lanes, no FMA) differs from every host in both respects and runs the cases
of each kind of sum and step; x86-64-v3 (AVX2, FMA: four lanes) and, where this CPU runs it,
x86-64-v4 (AVX-512: eight) run the force sums. All 50 cases were compared under the three
targets on an AVX-512 host when the digests were recorded: the same bits; the cluster
scene's (pairs taken once) were added later and compared under the three as well.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

import llvmlite.binding as llvm
import pytest

import spacephys as sp
from test_golden import _load, fingerprint

# direct gravity with its test particles on threads, pairs taken once, the tree, the collision
# pass, ships and missiles with explosions, drag, and the two integrators with the most
# arithmetic of their own
EVERY_KIND = ("gravity/leapfrog", "gravity/gauss_radau", "gravity/wisdom_holman_corrected",
              "cluster/leapfrog", "tree/leapfrog", "collisions/leapfrog", "actors/leapfrog",
              "drag/leapfrog")
SUMS = ("gravity/leapfrog", "cluster/leapfrog", "tree/leapfrog")

RUN = """
import json, sys
sys.path.insert(0, sys.argv[1])
import test_golden as g
print(json.dumps({case: g.digest(*case.split("/"))[0] for case in sys.argv[2:]}))
"""


def targets():
    """{target: its cases} besides the host's: x86-64, x86-64-v3, and x86-64-v4 when this
    CPU can run its code. (Empty on another architecture: see the test below.)"""
    features = llvm.get_host_cpu_features()
    if not features.get("sse2"):
        return {}
    out = {"x86-64": EVERY_KIND, "x86-64-v3": SUMS}
    if all(features.get(f) for f in ("avx512f", "avx512vl", "avx512bw", "avx512dq")):
        out["x86-64-v4"] = SUMS
    return out


def test_the_machine_is_one_the_targets_cover():
    assert targets(), f"{llvm.get_host_cpu_name()}: not x86-64, no other targets to check"


def _compiled_for(cpu, tmp_path_factory):
    """The environment of a process whose kernels numba compiles for `cpu`, in a cache folder
    of its own (kept between runs of the suite)."""
    from spacephys import cache
    if cache.FOLDER is not None:
        folder = Path(cache.FOLDER)
    elif cache.ENABLED:                       # beside the package
        folder = Path(sp.__file__).parent / "__pycache__"
    else:
        folder = tmp_path_factory.mktemp("cache")
    # with a helper process compiling parts of each step side by side (_by_address.complete),
    # whatever the load: the digests then also show that its machine code is the same
    return dict(os.environ, NUMBA_CPU_NAME=cpu, NUMBA_CPU_FEATURES="",
                NUMBA_CACHE_DIR=str(folder / "targets" / cpu), SDL_VIDEODRIVER="dummy",
                SPACEPHYS_COMPILE_HELPERS="1")


@pytest.mark.parametrize("cpu", list(targets()))
def test_the_digests_are_the_same_compiled_for_another_cpu(cpu, tmp_path_factory):
    """The target's cases in a process that compiles for it: the recorded digests."""
    env = _compiled_for(cpu, tmp_path_factory)
    cases = targets()[cpu]
    run = subprocess.run([sys.executable, "-c", RUN, str(Path(__file__).parent), *cases],
                         env=env, capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0, run.stderr[-3000:]
    got = json.loads(run.stdout.strip().splitlines()[-1])
    recorded = _load()[fingerprint()]
    assert got == {case: recorded[case] for case in cases}


def test_a_match_recorded_on_one_cpu_replays_on_another(tmp_path, tmp_path_factory):
    """A duel the computer flies on both sides (ships, missiles, explosions), recorded by a
    process compiled for x86-64 (no FMA, two lanes), replays bit for bit on this CPU."""
    path = tmp_path / "match.h5"
    play = [sys.executable, "-m", "spacephys", "play"]
    done = subprocess.run(play + ["duel", "--players", "0", "--frames", "300", "--headless",
                                  "--record", str(path)], capture_output=True, text=True,
                          env=_compiled_for("x86-64", tmp_path_factory), timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    again = subprocess.run(play + ["--replay", str(path), "--headless"], capture_output=True,
                           text=True, env=dict(os.environ, SDL_VIDEODRIVER="dummy"),
                           timeout=1800)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "300 frames drawn" in again.stdout and "bit for bit" in again.stdout



def _words_hash():
    """kernels/digest.rows of 5 000 random words in two spans, with id slots and free ids."""
    import numpy as np
    from spacephys.kernels import digest as kd
    words = np.random.default_rng(1).integers(0, 2**63, 5000, dtype=np.int64).view(np.uint64)
    return int(kd.rows(np.uint64(7), words, np.array([0, 800], np.int64),
                       np.array([3, 80], np.int64), 211, 1, 37, 5, np.arange(9, dtype=np.int64)))


@pytest.mark.parametrize("cpu", list(targets()))
def test_the_state_hash_is_the_same_compiled_for_another_cpu(cpu, tmp_path_factory):
    """World.digest's kernel (integer sums the compiler spreads over as many vector lanes as
    the target has) gives this process's number for the same words."""
    code = "import sys; sys.path.insert(0, sys.argv[1]); import test_cpu_targets as t; " \
           "print(t._words_hash())"
    run = subprocess.run([sys.executable, "-c", code, str(Path(__file__).parent)],
                         capture_output=True, text=True,
                         env=_compiled_for(cpu, tmp_path_factory), timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert int(run.stdout.split()[-1]) == _words_hash()


# ------------------------------------------------------- the Python that builds a state

# what spacephys computes in Python (not in kernels) when it builds or changes a state:
# orbital elements both ways, Kepler rails and spheres of influence, Lambert and Hohmann,
# headings, the moment of inertia of a compound shape, the game's spawns and pilots; each
# over many random inputs, so that a function whose last bit depends on the CPU shows it
PROBE = """
import hashlib, os, sys
os.environ["SDL_VIDEODRIVER"] = "dummy"
import numpy as np
import spacephys as sp
from spacephys import rails
from spacephys.game import make_mode
from spacephys.game.loop import play

rng = np.random.default_rng(11)
out = []
for _ in range(300):
    r, v = rng.uniform(-2, 2, 3), rng.uniform(-1, 1, 3)
    e = sp.orbits.state_to_elements(1.3, r, v)
    out += [e.a, e.e, e.i, e.Omega, e.omega, e.f, e.M, e.period]
    out += list(rails.elements(r, v, 1.3, 0.25))
    out += list(sp.orbits.elements_to_state(1.3, 1.0 + rng.random(), 0.8 * rng.random(),
                                            rng.random(), rng.random(), rng.random(),
                                            M=rng.uniform(-3, 3))[0])
    out.append(sp.Circles(rng.uniform(-1, 1, (3, 3)), rng.uniform(0.1, 1, 3)).gyration())
for _ in range(100):
    v1, v2 = sp.lambert(rng.uniform(0.5, 2, 3), rng.uniform(-2, -0.5, 3), rng.uniform(0.5, 5),
                        1.0)
    out += list(v1) + list(v2)
w = sp.World(dim=3, G=1.0)
star = w.add_body(1.0, (0, 0, 0), (0, 0, 0), fixed=True)
for k in range(40):
    moon = w.add_body(rng.uniform(1e-6, 1e-2), rng.uniform(-3, 3, 3), rng.uniform(-0.3, 0.3, 3))
    w.set_orbit(moon, about=star, a=1 + k / 10, e=0.3 * rng.random(), i=rng.random(),
                Omega=rng.random(), omega=rng.random(), M=rng.uniform(-3, 3))
    w.set_rails(moon, about=star)
ship = w.add_ship(sp.ShipSpec(), (0.9, 0.1, 0), (0.1, 1.0, 0.1),
                  heading=rng.uniform(-1, 1, 3))
w.coast([ship])
out += list(w._coasting.spheres())                  # Laplace's radii (m / M)^(2/5)
w.step(50)
out.append(float(w.digest()))
for name in ("duel", "arena"):
    m = make_mode(name, players=0, seed=3)
    play(m, frames=240, headless=True)
    out.append(float(m.world.digest()))
print(hashlib.sha256(np.array(out, float).tobytes()).hexdigest())
"""


def _lowered_env():
    """This process's environment with numpy's SIMD loops, OpenBLAS's kernels and the C
    library's FMA variants taken down to the x86-64 baseline (numba still compiles for
    the host: its targets are the tests above)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    off = [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]
    env = dict(os.environ, OPENBLAS_CORETYPE="Prescott",
               GLIBC_TUNABLES="glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX512F,-AVX")
    if off:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(off)
    return env


def test_what_python_builds_is_the_same_with_numpy_blas_and_libc_lowered():
    """The probe on this CPU, then with numpy, OpenBLAS and glibc picking their baseline
    code: the same bits (numpy's power, sin and cos, BLAS's dot products and glibc's
    pow, sin, cos, atan2 and exp give other last bits there: none of them may build a
    state)."""
    runs = [subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                           env=env, timeout=900) for env in (dict(os.environ), _lowered_env())]
    for run in runs:
        assert run.returncode == 0, run.stderr[-3000:]
    host, lowered = (run.stdout.split()[-1] for run in runs)
    assert host == lowered
