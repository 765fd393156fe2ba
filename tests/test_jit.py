"""The compile notice (_jit.announced): a line on stderr while numba compiles, and only then."""
import time

from spacephys import _jit


def test_a_long_compilation_is_announced_with_where_it_is_cached(capsys):
    with _jit.announced("the test kernel", after=0.05):
        time.sleep(0.3)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == ("spacephys: compiling the test kernel with numba; this happens once "
                      f"per machine and version (machine code cache: {_jit._cache.place()})")
    assert err[1].startswith("spacephys: compiled in 0.")


def test_a_quick_load_from_the_cache_says_nothing(capsys):
    with _jit.announced("the test kernel", after=0.5):
        time.sleep(0.01)
    assert capsys.readouterr().err == ""


FORK_CHILD = r"""
import os, sys
import numpy as np
import spacephys as sp

worlds = []
for gravity in ("none", "direct", "tree"):
    for integrator in ("leapfrog", "yoshida6", "rk4", "gauss_radau", "wisdom_holman"):
        if integrator == "wisdom_holman" and gravity == "none":
            continue
        if integrator in ("gauss_radau", "wisdom_holman") and gravity == "tree":
            continue                    # they refuse the tree
        for ship in (False, True):
            w = sp.World(2, dt=0.01, gravity=gravity, integrator=integrator)
            w.add_body(1.0, [0.0, 0.0])
            w.add_body(1e-3, [1.0, 0.0], [0.0, 1.0])
            if ship:
                w.add_ship(sp.ShipSpec(dry_mass=1e-9), [1.2, 0.0], [0.0, 0.9])
            w.step(2)                   # compiled or loaded here, in the parent
            worlds.append(w)
pid = os.fork()
if pid == 0:                            # GNU OpenMP kills a child whose parent used it
    for w in worlds:
        w.step(3)
    os._exit(0)
_, status = os.waitpid(pid, 0)
print("child", os.waitstatus_to_exitcode(status))
"""


def test_a_small_scene_never_starts_the_thread_pool():
    """A 3-body scene's steps stay on the calling thread in every family and under the tree
    (its force loops are
    far below the threaded size): a process that forked after stepping one can step it again
    in the child (GNU OpenMP terminates a forked child once its parent entered a parallel
    region; a recording server forks so, tests/test_reliability.py). numba turns np.zeros and
    array expressions in a parallel kernel into parallel regions of their own, whatever their
    size (kernels/arrays.zeroed): this fails on any of them in a step kernel, and when the
    force loop is made to run threaded at any size."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", FORK_CHILD], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert "child 0" in out.stdout, out.stdout + out.stderr


def test_the_openmp_threads_spin_briefly_unless_the_user_says_otherwise():
    """spacephys sets GNU OpenMP's spin count before numba loads it (long spinning beside a
    busy process costs the step's serial part: docs/performance.md, threads), and keeps a user's value."""
    import os
    import subprocess
    import sys
    probe = "import os, spacephys; print(os.environ['GOMP_SPINCOUNT'])"
    env = {k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}
    ours = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          env=env, timeout=120)
    assert ours.stdout.strip() == "10000", ours.stderr
    theirs = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                            env={**env, "GOMP_SPINCOUNT": "123"}, timeout=120)
    assert theirs.stdout.strip() == "123", theirs.stderr


INLINED_PROBE = r"""
import sys
import spacephys as sp
from spacephys.kernels import step
w = sp.World(3, dt=1e-3, gravity="direct", integrator=sys.argv[1])
w.add_body(1.0, [0.0, 0.0, 0.0])
w.add_body(1e-3, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
w.step(2)                               # compiled here: the cache folder is new
(sig,) = step.run.overloads
print(step.run.inspect_asm(sig))
"""


def test_a_step_calls_no_function_of_its_own_per_step(tmp_path):
    """The family's step, the force contract, the kick and the direct pull's loops are inlined
    into the step kernel (_jit.kernel's forceinline): a call of one of them passes the
    tables' arrays, about 140 machine words, every step (2 bodies: 190 ns a step, 67
    inlined). The step's compiled code names none of them. In a fresh process with its own
    cache folder: numba shows no machine code it loaded from a cache."""
    import os
    import subprocess
    import sys
    # mangled function names (not NumbaEnv's globals, which inlined functions leave):
    # the length of each part, then the part
    called = tuple("_ZN9spacephys7kernels" + name for name in ("9integrate6_split", "9integrate3_rk", "6forces14_accelerations",
              "6forces4kick", "7gravity12_direct_pull", "7gravity11_pull_chunk",
              "7gravity10_pull_each", "5pairs11pull_points", "4tape7sources"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    for integrator in ("leapfrog", "rk4"):
        asm = subprocess.run([sys.executable, "-c", INLINED_PROBE, integrator], env=env,
                             capture_output=True, text=True, check=True).stdout
        assert "kernels4step3run" in asm       # the step kernel's own code is there
        assert [name for name in called if name in asm] == []


WRAPPER_MODULE = """
from spacephys._jit import kernel

@kernel
def inner(x):
    return x * 3.0

@kernel
def outer(x):
    return inner(x) + 1.0
"""


def test_a_kernel_compiled_for_kernels_has_python_s_wrapper_only_once_python_calls_it(
        tmp_path, monkeypatch):
    """numba's wrapper that Python calls a compiled function through (20-30 ms of LLVM work
    apiece) is left out of a kernel compiled for the kernels that call it; a call from
    Python compiles it with one (the bare code has none to call: a null pointer)."""
    from numba import types
    (tmp_path / "wrapper_probe.py").write_text(WRAPPER_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    import wrapper_probe as m
    assert m.outer(2.0) == 7.0
    sig = (types.float64,)
    assert not _jit._wrapped(m.inner.overloads[sig])           # compiled for outer only
    assert _jit._wrapped(m.outer.overloads[sig])
    assert m.inner(2.0) == 6.0                                 # from Python: with one
    assert _jit._wrapped(m.inner.overloads[sig])
    assert m.outer(5.0) == 16.0 and m.inner.signatures == [sig]


GC_MODULE = """
from spacephys._jit import kernel

@kernel
def tripled(x):
    return x * 3.0
"""


def test_the_collector_runs_rarely_while_kernels_compile_and_as_before_after(
        tmp_path, monkeypatch):
    """numba's compile makes about a million objects, and each collection of the older
    generations walks them all: while kernels compile the collector uses COMPILE_GC, and
    the process's own thresholds come back after."""
    import gc
    from numba.core import event
    (tmp_path / "gc_probe.py").write_text(GC_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    import gc_probe as m
    seen = []

    class During(event.Listener):
        def on_start(self, ev):
            seen.append(gc.get_threshold())

        def on_end(self, ev):
            pass
    was = gc.get_threshold()
    gc.set_threshold(555, 7, 9)
    listener = During()
    event.register("numba:compile", listener)
    try:
        assert m.tripled(2.0) == 6.0
        after = gc.get_threshold()
    finally:
        event.unregister("numba:compile", listener)
        gc.set_threshold(*was)
    # a module new to this run: compiled, not loaded
    assert seen and set(seen) == {_jit.COMPILE_GC} and after == (555, 7, 9)
