"""Compile ahead of time: `spacephys compile` and sp.compile(...), so that a game compiles in
its installer or behind a loading screen and its first step loads the machine code from the
cache (spacephys/cache.py says where).

What a scene needs is what its first step compiles: each target is built and stepped once on
a copy (a scenario with its whole timeline applied first: ships controlled, missiles
launched, plans set), and its energy, momentum and angular momentum are computed. Each
kernel numba compiles on the way is reported with its own seconds (numba's compile events).
"""
import os
import time
from dataclasses import dataclass, field

from numba.core import event


class Compiles(event.Listener):
    """numba's compile events, per function: kernels[name] = [compilations, own seconds] (a
    kernel's time without the functions compiled inside it)."""

    def __init__(self):
        self.stack, self.kernels = [], {}

    def on_start(self, ev):
        self.stack.append([time.perf_counter(), 0.0])

    def on_end(self, ev):
        start, inner = self.stack.pop()
        took = time.perf_counter() - start
        if self.stack:
            self.stack[-1][1] += took
        fn = getattr(ev.data["dispatcher"], "py_func", None)
        name = (f"{getattr(fn, '__module__', None) or '?'}.{fn.__qualname__}" if fn is not None
                else str(ev.data["dispatcher"]))
        k = self.kernels.setdefault(name.replace("spacephys.", ""), [0, 0.0])
        k[0] += 1
        k[1] += took - inner


@dataclass
class Compiled:
    """One target compiled: its name, the wall seconds it took, and the kernels compiled for
    it [(kernel, compilations, seconds)], the slowest first (none: all came from the
    cache)."""
    target: str
    seconds: float
    kernels: list = field(default_factory=list)


def _listening(work):
    """(work's result, its kernels) with numba's compile events recorded meanwhile."""
    listener = Compiles()
    event.register("numba:compile", listener)
    try:
        result = work()
    finally:
        event.unregister("numba:compile", listener)
    rows = sorted(((k, n, s) for k, (n, s) in listener.kernels.items()), key=lambda r: -r[2])
    return result, rows


def _exercise(w):
    """What a first step compiles, on a copy of World w."""
    w = w.copy()
    w.energy(True), w.momentum(True), w.angular_momentum(True)
    w.step(1)


def _build(kind, what):
    """A World from ("scene", name) or ("scenario", path)."""
    if kind == "scene":
        from .scenes import SCENES
        build, _, integrator, dt = SCENES[what]
        return build(integrator=integrator, dt=dt)
    from .scenario import apply, load_scenario
    sc = load_scenario(what)
    w, ids = sc.build()
    for t, action, value, path in sc.timeline:      # every action now: the types they bring
        apply(w, ids, sc.data["missiles"], action, value, path)
    return w


def _one(label, kind, what):
    """Compile one target in this process: a Compiled."""
    start = time.perf_counter()
    _, rows = _listening(lambda: _exercise(_build(kind, what)))
    return Compiled(label, time.perf_counter() - start, rows)


def targets(scene=None, scenario=None, every=False):
    """[(label, kind, what)] for `spacephys compile`: built-in scenes or shipped scenarios by
    name (one or a list; runner.resolve), a scenario file, or every shipped scenario and
    built-in scene."""
    from .runner import resolve
    from .scenario import shipped
    from .scenes import SCENES
    if every:
        names = list(shipped()) + [s for s in SCENES if s not in shipped()]
    elif scene is not None:
        names = [scene] if isinstance(scene, str) else list(scene)
    elif scenario is not None:
        return [(os.fspath(scenario), "scenario", os.fspath(scenario))]
    else:
        raise ValueError("nothing to compile: give a world, a scene, a scenario or every=True")
    return [(name, *resolve(name)) for name in names]


def compile(world=None, *, scene=None, scenario=None, every=False, jobs=1, progress=None):
    """Compile what stepping a World needs, ahead of time; returns [Compiled], one per target.

    world : a World (a copy of it is stepped once; the World itself is not changed), or
    scene : a built-in scene or shipped scenario by name (or a list of names), or
    scenario : a scenario file, or
    every : every shipped scenario and built-in scene. jobs : worker processes compiling
    targets side by side (numba compiles on one core per process); progress : a file to
    draw a progress bar and each target's kernels on (None: quiet). Later processes load
    the machine code from the cache (spacephys cache info says where).
    """
    from . import _validate as check
    jobs = check.count("jobs", jobs, minimum=1)
    if world is not None:
        start = time.perf_counter()
        _, rows = _listening(lambda: _exercise(world))
        done = [Compiled("world", time.perf_counter() - start, rows)]
        _report(progress, done[0], 1, 1)
        return done
    todo = targets(scene, scenario, every)
    if jobs == 1 or len(todo) == 1:
        done = []
        for k, target in enumerate(todo):
            _bar(progress, k, len(todo), target[0])
            done.append(_one(*target))
            _report(progress, done[-1], k + 1, len(todo))
        return done
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    done = {}
    with ProcessPoolExecutor(min(jobs, len(todo)),
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(_one, *target): k for k, target in enumerate(todo)}
        _bar(progress, 0, len(todo), "")
        for future in as_completed(futures):
            done[futures[future]] = future.result()
            _report(progress, done[futures[future]], len(done), len(todo))
    return [done[k] for k in range(len(todo))]


def _bar(progress, k, total, what):
    if progress is not None and progress.isatty():
        from .runner import draw_bar
        draw_bar(progress, k, total, f"{k}/{total} {what}")


def _report(progress, c, k, total):
    """One target's line, then each kernel that took 0.1 s or more."""
    if progress is None:
        return
    if progress.isatty():
        print("\r" + " " * 78 + "\r", end="", file=progress)
    compiled = sum(s for _, _, s in c.kernels)
    print(f"[{k}/{total}] {c.target}: {c.seconds:.1f} s, {len(c.kernels)} kernels compiled "
          f"({compiled:.1f} s)" + ("" if c.kernels else ": all from the cache"), file=progress)
    for name, n, s in c.kernels:
        if s >= 0.1:
            print(f"    {s:6.2f} s  {name}" + (f" ({n} variants)" if n > 1 else ""),
                  file=progress)
    progress.flush()
