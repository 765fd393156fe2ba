"""Run a scene for a duration and summarise it: steps, wall time, conservation errors."""
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .events import EVENT_KINDS
from .forces import MUTUAL
from .scenes import SCENES
from .world import World


@dataclass
class RunResult:
    """What a run did: the World at the end and the figures of the summary."""
    world: World
    scene: str
    steps: int
    wall: float              # seconds spent stepping, compile excluded
    compile_wall: float      # seconds of the first step (numba compile or cache load)
    t0: float
    energy0: float
    energy: float
    momentum_error: float    # |P - P0| / sum |m v|
    angular_momentum0: float
    angular_momentum: float
    events: dict             # event kind name -> how many happened
    bodies0: int = 0         # bodies at the start
    names: dict = None       # a scenario's names -> body ids (spawns and named launches too)

    @property
    def energy_error(self):
        """|E - E0| / |E0|: the relative change of the total energy over the run."""
        return abs(self.energy - self.energy0) / abs(self.energy0) if self.energy0 else abs(self.energy)

    @property
    def angular_momentum_error(self):
        """|L - L0| / |L0|: the relative change of the angular momentum's size."""
        L0 = self.angular_momentum0
        return abs(self.angular_momentum - L0) / abs(L0) if L0 else abs(self.angular_momentum)

    def summary(self):
        """The run's summary as printed by spacephys run: a str of labelled lines."""
        w = self.world
        spec = w.integrator_spec
        pulls = int(np.count_nonzero(w.pulls)) if w.gravity in MUTUAL else 0
        rate = self.steps / self.wall if self.wall > 0 else float("inf")
        return "\n".join([
            f"scene         {self.scene} ({w.dim}D, {w.n} bodies: {pulls} pulling, "
            f"{w.n - pulls} feeling only; gravity {w.gravity})",
            f"integrator    {spec.name} (order {spec.order}, "
            f"{'symplectic' if spec.symplectic else 'not symplectic'}), dt = {w.dt:g}",
            f"steps         {self.steps} in {self.wall:.3f} s ({rate:,.0f} steps/s); "
            f"first step incl. compile/cache load {self.compile_wall:.2f} s",
            f"time          {self.t0:g} -> {w.t:g}",
            f"energy        {self.energy0:.12g} -> {self.energy:.12g}, "
            f"relative error {self.energy_error:.2e} (of the pulling bodies, which conserve it)",
            f"momentum      error {self.momentum_error:.2e} of sum |m v|",
            f"ang. momentum relative error {self.angular_momentum_error:.2e}",
            "events        " + (", ".join(f"{k} {v}" for k, v in self.events.items()) or "none"),
            f"bodies        {self.bodies0} at the start, {w.n} alive at the end",
        ])


def _norm_L(w):
    return float(np.linalg.norm(w.angular_momentum(True)))


def run_scene(name="star_system", *, integrator=None, dt=None, duration=None, progress=None,
              out=None):
    """Build the scene `name` of scenes.SCENES and run it for `duration` [time].

    integrator, dt : override the scene's; progress : a file to draw a progress bar on;
    out : record the run into this HDF5 log (see World.record).
    """
    if name not in SCENES:
        raise ValueError(f"scene {name!r} is not known; valid: {', '.join(SCENES)}")
    build, default_duration, default_integrator, default_dt = SCENES[name]
    w = build(integrator=integrator or default_integrator, dt=default_dt if dt is None else dt)
    duration = default_duration if duration is None else float(duration)
    return _run_world(w, name, duration, [], {}, {}, progress, out, None)


def run_scenario(scenario, *, integrator=None, dt=None, duration=None, progress=None,
                 out=None, setup=None):
    """Run a scenario (a path, its text, or a loaded Scenario) for its duration; its timeline
    is carried out at the first step at or after each entry's time. Returns a RunResult.

    integrator, dt, duration : override the scenario's; out : an HDF5 log path (default: the
    scenario's [log] path, if it has one); progress : a file to draw a progress bar on;
    setup(world, names) : called once the World is built, before its first step (names:
    the scenario's name -> id).
    """
    from .scenario import Scenario, load_scenario
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    w, ids = sc.build(**{k: v for k, v in (("integrator", integrator), ("dt", dt))
                         if v is not None})
    if setup is not None:
        setup(w, ids)
    log = sc.log or {}
    out = out if out is not None else log.get("path")
    every = {"every": log["every"]} if log.get("every") else \
        {"every_time": log["every_time"]} if log.get("every_time") else {}
    return _run_world(w, sc.title or os.path.basename(sc.source), sc.duration if duration is None
                      else float(duration), sc.timeline, ids, sc.data["missiles"], progress,
                      out, sc.text, every)


def _run_world(w, name, duration, timeline, ids, missiles, progress, out, text, every=None):
    if not math.isfinite(duration) or duration <= 0:
        raise ValueError(f"duration = {duration}: must be > 0")
    if duration < w.dt:
        raise ValueError(f"duration = {duration:g} is shorter than one step (dt = {w.dt:g})")
    with np.errstate(over="ignore"):
        ratio = duration / w.dt
    if not ratio <= 1e12:
        raise ValueError(f"duration / dt = {ratio:.3g} steps: too many (max 1e12)")
    total = round(ratio)
    # the timeline as step counts: each entry at the first step at or after its time
    plan = [(max(0, math.ceil(t / w.dt - 1e-9)), action, value, path)
            for t, action, value, path in timeline]
    log = None
    if out is not None:
        every = _log_schedule(w, out, total, duration, every)
        log = w.record(out, scenario=text, **every)
    try:
        return _run_steps(w, name, total, plan, ids, missiles, progress, log)
    except Exception as e:
        # a breakdown keeps its log (to look at); bad input found while running (a timeline
        # entry) leaves none: no log of a run that never was
        if log is not None:
            log.close()
            if isinstance(e, ValueError):
                os.remove(out)
        raise


# a log of a run says nothing finer than this many frames unless asked
FRAMES_PER_RUN = 1000


def _log_schedule(w, out, total, duration, every):
    """The frame schedule of a recorded run: the one given, or a frame every
    total // FRAMES_PER_RUN steps; refused if its log would not fit where it goes (the
    schedule and the expected size printed on stderr)."""
    from .runlog import expected_size, room
    if not every:
        every = {"every": max(1, total // FRAMES_PER_RUN)}
    frames = (total // every["every"] if "every" in every else
              int(duration / every["every_time"])) + 2
    size, free = expected_size(w.n, w.dim, frames), room(out)
    schedule = (f"a frame every {every['every']} steps" if "every" in every else
                f"a frame every {every['every_time']:g} time units")
    if size > free:
        raise ValueError(f"out = {out!r}: {schedule} ({frames} frames of {w.n} bodies) "
                         f"makes a log of about {size / 1e6:.0f} MB, and {free / 1e6:.0f} MB "
                         f"are free: record less often (the scenario's [log] every = ...)")
    print(f"spacephys: recording {out}: {schedule}, {frames} frames, about "
          f"{size / 1e6:.1f} MB", file=sys.stderr)
    return every


def _run_steps(w, name, total, plan, ids, missiles, progress, log):
    from .scenario import apply
    # the conserved quantities: with massive passive bodies (ships) those of the pulling ones
    t0, E0, P0, L0 = w.t, w.energy(True), w.momentum(True), _norm_L(w)
    bodies0 = w.n
    scale = float(np.sum(w.mass * w.pulls * np.linalg.norm(w.vel, axis=1))) or 1.0

    counts = {}

    def tally():
        kinds, number = np.unique(w.events["kind"], return_counts=True)
        for k, c in zip(kinds, number):
            counts[EVENT_KINDS[int(k)]] = counts.get(EVENT_KINDS[int(k)], 0) + int(c)

    def act(upto):
        while plan and plan[0][0] <= upto:
            _, action, value, path = plan.pop(0)
            apply(w, ids, missiles, action, value, path)

    act(0)
    start = time.perf_counter()
    w.step(1)
    compile_wall = time.perf_counter() - start
    tally()
    done, chunks = 1, 50
    start = time.perf_counter()
    for c in range(1, chunks + 1):
        goal = total * c // chunks
        while done < goal:
            act(done)
            n = min(goal, plan[0][0] if plan else goal) - done
            n = max(n, 1)
            w.step(n)
            tally()
            done += n
        if progress is not None:
            draw_bar(progress, c, chunks, f"{100 * c // chunks:3d}%  t = {w.t:.4g}")
    wall = time.perf_counter() - start
    if progress is not None:
        print(file=progress)
    if log is not None:
        log.close()
    return RunResult(w, name, done, wall, compile_wall, t0, E0, w.energy(True),
                     float(np.linalg.norm(w.momentum(True) - P0)) / scale, L0, _norm_L(w),
                     dict(sorted(counts.items())), bodies0, ids)


def resolve(scene):
    """("scenario", path) for a scenario file or the name of a shipped scenario, ("scene",
    name) for a built-in scene; ValueError listing the known ones otherwise."""
    from .scenario import shipped
    path, known = Path(scene), shipped()
    if not path.suffix and scene in known:
        return "scenario", known[scene]              # a shipped scenario first
    if path.suffix != ".toml" and scene in SCENES:
        return "scene", scene
    if path.suffix != ".toml" or not path.exists():
        names = sorted(set(SCENES) | set(known))
        raise ValueError(f"{scene!r} is neither a scenario file (.toml) nor a known scene "
                         f"or scenario: {', '.join(names)}")
    return "scenario", path


def draw_bar(progress, k, total, text):
    """Redraw, on one line of the file `progress`, a bar for k of total done, then text."""
    bar = "#" * (30 * k // total)
    print(f"\r[{bar:<30}] {text}", end="", file=progress, flush=True)


def default_progress():
    return sys.stderr if sys.stderr.isatty() else None
