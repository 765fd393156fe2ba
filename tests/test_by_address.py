"""Kernels called by address (spacephys/_by_address.py): a caller holds a call through the
callee's slot, not the callee's code; results, exceptions and the cache work as for a direct
call, in fresh processes too."""
import os
import pickle
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import spacephys as sp
from spacephys import _by_address
from spacephys.kernels import collide, step

MODULE = textwrap.dedent('''
    import numpy as np
    from spacephys._jit import kernel

    @kernel(by_address=True)
    def big(x, y):
        s = 0.0
        for i in range(x.shape[0]):
            s += np.sin(x[i]) * y[i]
            y[i] = s
        if s > 1e300:
            raise ValueError("too big")
        return s

    @kernel
    def caller(x, y):
        return big(x, y) + 1.0

    @kernel
    def outer(x, y):
        return caller(x, y) * 2.0
''')

PROBE = textwrap.dedent('''
    import sys
    import numpy as np
    import probe_mod as m
    x = np.arange(10.0)
    fn = getattr(m, sys.argv[1])
    print(repr(fn(x, np.ones(10))), sum(fn.stats.cache_hits.values()))
''')


def _expected(outer):
    x, y = np.arange(10.0), np.ones(10)
    s = 0.0
    for i in range(10):
        s += np.sin(x[i]) * y[i]
    return (s + 1.0) * (2.0 if outer else 1.0)


@pytest.fixture
def probe(tmp_path):
    (tmp_path / "probe_mod.py").write_text(MODULE)
    (tmp_path / "probe.py").write_text(PROBE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))

    def run(fn):
        out = subprocess.run([sys.executable, str(tmp_path / "probe.py"), fn], env=env,
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stderr[-2000:]
        value, hits = out.stdout.split()
        return float(value), int(hits)
    return run


def test_a_cached_caller_loads_the_kernels_it_calls_by_address_first(probe):
    # compiled in one process, loaded from the cache in the next: outer, which linked
    # caller's code, needs big's slot filled before numba can load it (without the list of
    # what it calls, the load fails to resolve the slot and the process dies)
    assert probe("outer") == (_expected(True), 0)
    assert probe("outer") == (_expected(True), 1)
    # caller was compiled for outer only, without the wrapper Python calls a kernel through
    # (_jit._Dispatcher.compile): called from Python it is compiled once more with one (the
    # cached code without it would be a call through a null pointer), then loaded
    assert probe("caller") == (_expected(False), 0)
    assert probe("caller") == (_expected(False), 1)


def test_a_call_by_address_returns_and_raises_as_a_direct_call(tmp_path, monkeypatch):
    (tmp_path / "probe_mod2.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    import probe_mod2 as m
    x = np.arange(10.0)
    assert m.caller(x, np.ones(10)) == _expected(False)
    y = np.ones(10)
    m.caller(x, y)
    assert y[-1] == _expected(False) - 1.0           # the callee wrote the caller's array
    with pytest.raises(ValueError, match="too big"):
        m.caller(np.full(3, 1e308), np.full(3, 1e308))
    sig = m.caller.signatures[0]
    assert b"spacephys.by_address." in _machine_code(m.caller, sig)   # it calls the slot...
    assert m.outer(x, np.ones(10)) == _expected(True)
    # ...whose name its machine code holds, where outer's holds it through caller's code
    assert _by_address.needs(m.caller.overloads[sig].library) == {("probe_mod2", "big", sig)}
    assert _by_address.needs(m.outer.overloads[sig].library) == {("probe_mod2", "big", sig)}
    # and nothing of big is linked into caller (numba compiles what it links again), where
    # outer links caller's code (numba's own list of what it linked)
    big, caller = m.big.overloads[sig].library, m.caller.overloads[sig].library
    assert big not in caller._linking_libraries
    assert caller in m.outer.overloads[sig].library._linking_libraries


def test_the_step_kernel_calls_the_collision_pass_by_address():
    # the step kernel of a scene with collisions holds no code of the collision pass: it
    # would otherwise compile it again in every step variant (3.4 of its 3.8 s for the arena)
    w = sp.World(dim=2, gravity="none", dt=0.01)
    w.add_body(pos=(0, 0), vel=(1, 0), mass=1.0, radius=1.0)
    w.add_body(pos=(3, 0), vel=(-1, 0), mass=1.0, radius=1.0)
    w.set_collision("*", "*", "elastic")
    w.step(200)
    assert w.vel[0, 0] < 0 < w.vel[1, 0]                 # they met, through the pass
    sig = next(s for s in step.run.signatures if "RulesType" in str(s[2]))
    called = {qualname for _, qualname, _ in _by_address.needs(step.run.overloads[sig].library)}
    assert "collide_step" in called


def _machine_code(disp, sig):
    """The object code numba caches for disp's overload sig (its symbols: what it defines and
    what it calls), whether compiled here or loaded from the cache."""
    _, kind, (obj, _) = disp.overloads[sig].library.serialize_using_object_code()
    assert kind == "object"
    return obj


def test_no_kernel_is_compiled_with_a_c_wrapper(tmp_path, monkeypatch):
    # numba builds every function a wrapper callable from C unless told not to; no kernel is
    # called so, and the wrappers were 2.1 s of a Gauss-Radau scene's profiled cold start
    (tmp_path / "probe_mod3.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    import probe_mod3 as m
    assert m.outer(np.arange(10.0), np.ones(10)) == _expected(True)
    for fn in (m.outer, m.caller, m.big):
        (cres,) = fn.overloads.values()
        lib, desc = cres.library, cres.fndesc
        assert lib.get_pointer_to_function(desc.llvm_cfunc_wrapper_name) == 0
        assert lib.get_pointer_to_function(desc.llvm_func_name) != 0     # the kernel is there


LATER = textwrap.dedent('''
    import numpy as np
    from numba import types
    from spacephys._jit import kernel

    @kernel(by_address=True, returns=types.float64)
    def first(x):
        return x.sum()

    @kernel(by_address=True, returns=types.float64)
    def second(x):
        return (x * x).sum()

    @kernel(by_address=True, returns=types.int64)
    def wrong(x):
        return x.sum()

    @kernel
    def both(x):
        return first(x) + 10.0 * second(x)

    @kernel
    def mistaken(x):
        return wrong(x)
''')


def test_kernels_that_declare_what_they_return_are_typed_first_and_compiled_after(
        tmp_path, monkeypatch):
    # while deferring, a caller compiles without its callees (their slots empty); complete()
    # compiles them, one in a helper process (which hands it over through the cache), and
    # fills the slots before anything runs
    (tmp_path / "later_mod.py").write_text(LATER)
    monkeypatch.syspath_prepend(str(tmp_path))
    import later_mod as m
    x = np.arange(5.0)
    sig = (m.both.typeof_pyval(x),)
    with _by_address.deferring():
        m.both.compile(sig)
    assert not m.first.overloads and not m.second.overloads       # typed, not compiled
    _by_address.complete(helpers=1)
    assert m.both(x) == 10.0 + 10.0 * 30.0
    # the first on the list went to the helper: this process loaded it from the cache, and
    # compiled the other itself
    assert sum(m.first.stats.cache_hits.values()) == 1
    assert sum(m.second.stats.cache_misses.values()) == 1


MISTAKEN = textwrap.dedent('''
    import numpy as np
    import pytest
    from spacephys import _by_address
    import later_mod2 as m
    x = np.arange(3.0)
    with _by_address.deferring():
        m.mistaken.compile((m.mistaken.typeof_pyval(x),))
    with pytest.raises(RuntimeError, match="not compiled"):     # its slot empty: no jump
        m.mistaken(x)
    for attempt in range(2):           # refused again: its caller must never run
        with pytest.raises(TypeError, match=r"later_mod2\\.wrong returns float64 .* declares int64"):
            _by_address.complete()
        with pytest.raises(RuntimeError, match="not compiled"):  # the slot emptied again
            m.mistaken(x)
    print("refused")
''')

# the same, the caller's compile started by a call from Python (_jit.side_by_side)
MISTAKEN_CALLED = textwrap.dedent('''
    import numpy as np
    import pytest
    import later_mod7 as m
    for attempt in range(2):           # not left in numba's table: each call is refused
        with pytest.raises(TypeError, match=r"later_mod7\\.wrong returns float64 .* declares int64"):
            m.mistaken(np.arange(3.0))
    print("refused")
''')


CHAIN = textwrap.dedent('''
    from numba import types
    from spacephys._jit import kernel

    @kernel(by_address=True, returns=types.float64)
    def leaf(x):
        return (x * x).sum()

    @kernel(by_address=True, returns=types.float64)
    def mid(x):
        return leaf(x) + 1.0

    @kernel(by_address=True, returns=types.float64)
    def other(x):
        return x.sum()

    @kernel
    def top(x):
        return mid(x) + other(x)
''')


def test_a_helper_takes_kernels_as_they_are_typed_and_one_after_another(tmp_path, monkeypatch):
    # `mid` goes to a helper while `top` is still being compiled; the helper reports `leaf`,
    # which it typed from its declaration while compiling `mid`, and then takes `other` and
    # `leaf` in the same process: this process compiles none of the three
    (tmp_path / "chain_mod.py").write_text(CHAIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    started = []
    start = _by_address._start_helper
    monkeypatch.setattr(_by_address, "_start_helper", lambda payload: started.append(
        pickle.loads(pickle.loads(payload))[1]) or start(payload))
    import chain_mod as m
    x = np.arange(5.0)
    work = _by_address._WORK
    assert not (work.later or work.running or work.idle)        # none left by other tests
    with _by_address.deferring(helpers=1):
        m.top.compile((m.top.typeof_pyval(x),))
        # (the helper may already have reported `leaf`)
        assert started == ["mid"] and [job[1] for job in work.later][:1] == ["other"]
        until = time.monotonic() + 300
        while (work.later or work.running) and time.monotonic() < until:
            time.sleep(0.05)
        assert not work.later and not work.running and len(work.idle) == 1
    helper = work.idle[0]
    _by_address.complete(helpers=1)
    assert m.top(x) == 30.0 + 1.0 + 10.0
    assert started == ["mid"]
    for kernel in (m.mid, m.other, m.leaf):
        assert sum(kernel.stats.cache_hits.values()) == 1, kernel      # loaded, not compiled
        assert sum(kernel.stats.cache_misses.values()) == 0, kernel
    assert not work.idle and helper.wait(timeout=60) == 0       # ended when no longer needed


def test_a_call_from_python_compiles_declared_callees_side_by_side(tmp_path, monkeypatch):
    # a kernel's first call from Python types its declared callees from their declarations:
    # the first is handed to a helper while the caller is still being compiled
    (tmp_path / "later_mod6.py").write_text(LATER)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "1")
    import later_mod6 as m
    x = np.arange(5.0)
    assert m.both(x) == 10.0 + 10.0 * 30.0 and not _by_address.pending()
    assert sum(m.first.stats.cache_hits.values()) == 1          # the helper compiled it
    assert sum(m.first.stats.cache_misses.values()) == 0
    assert sum(m.second.stats.cache_misses.values()) == 1       # this process, meanwhile


@pytest.mark.parametrize("module, script", [("later_mod2", MISTAKEN),
                                             ("later_mod7", MISTAKEN_CALLED)])
def test_a_declared_return_type_that_is_not_the_kernels_is_refused(tmp_path, module, script):
    # in a process of its own (a jump through an empty slot would end it): the refused
    # kernel stays on the list and its slot empty, so that nothing that calls it ever runs
    (tmp_path / f"{module}.py").write_text(LATER)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(tmp_path),
                                  SPACEPHYS_COMPILE_HELPERS="0"), cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["refused"]


def test_the_helpers_are_those_asked_for_or_the_free_cores(monkeypatch):
    from spacephys import _jit
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "3")
    assert _jit.helpers() == 3
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "two")
    with pytest.raises(ValueError, match="SPACEPHYS_COMPILE_HELPERS = 'two'"):
        _jit.helpers()
    monkeypatch.delenv("SPACEPHYS_COMPILE_HELPERS")
    assert 0 <= _jit.helpers() < os.cpu_count()


def test_a_helper_that_fails_leaves_its_kernel_to_this_process(tmp_path, monkeypatch):
    (tmp_path / "later_mod3.py").write_text(LATER)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(_by_address, "_HELPER", "import sys; sys.exit(1)")
    import later_mod3 as m
    x = np.arange(5.0)
    with _by_address.deferring():
        m.both.compile((m.both.typeof_pyval(x),))
    _by_address.complete(helpers=1)
    assert m.both(x) == 10.0 + 10.0 * 30.0
    assert sum(m.first.stats.cache_misses.values()) == 1      # compiled here after all


def test_a_bad_helper_count_is_refused_before_anything_is_compiled(tmp_path, monkeypatch):
    from spacephys import steppers
    (tmp_path / "later_mod4.py").write_text(LATER)
    monkeypatch.syspath_prepend(str(tmp_path))
    import later_mod4 as m
    x = np.arange(5.0)
    sig = (m.both.typeof_pyval(x),)
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "two")
    with pytest.raises(ValueError, match="SPACEPHYS_COMPILE_HELPERS = 'two'"):
        steppers._compile(m.both, sig)
    assert not m.both.overloads and not _by_address.pending()      # nothing half-done
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "0")
    steppers._compile(m.both, sig)
    assert m.both(x) == 10.0 + 10.0 * 30.0


def test_a_compile_that_fails_midway_leaves_its_kernels_for_the_next(tmp_path, monkeypatch):
    # the caller is compiled with empty slots: until they are filled it must not run, and
    # the next step's compile fills them
    from spacephys import steppers
    (tmp_path / "later_mod5.py").write_text(LATER)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("SPACEPHYS_COMPILE_HELPERS", "0")
    import later_mod5 as m
    x = np.arange(5.0)
    sig = (m.both.typeof_pyval(x),)

    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(m.second, "compile", interrupted, raising=False)
    with pytest.raises(KeyboardInterrupt):
        steppers._compile(m.both, sig)
    assert m.both.overloads and _by_address.pending()
    monkeypatch.delattr(m.second, "compile")
    steppers._compile(m.both, sig)
    assert not _by_address.pending() and m.both(x) == 10.0 + 10.0 * 30.0
