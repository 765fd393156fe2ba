"""`spacephys bench threads`: what the default thread choice ("auto") costs beside other
programs, against one thread ("never") and every thread ("always"), per step.

Three scenes big enough to thread: star_system (2 007 bodies, 6 pulling), the dense field of
circles (heavybench.dense_field: 20 000, or 5 000 with --quick) and N = 1 024 bodies under
direct gravity. Each quiet, then beside one and two busy processes (a spinning Python each,
as a game's render and audio threads, or another program), and each two ways: frames (step(1)
calls, as a game makes them, for a few seconds: "auto" tries the other choice now and then)
and one long call (step(n), as a run or a warp). The figure is the whole time over the steps
taken, trials included, the median of five runs with the modes in turn (beside two busy
processes one thread gets two thirds of a core, and one run of a mode can take twice
another). The goal: "auto" never more than 10 % slower than one thread.

Only force loops run on threads, and the dense field has no gravity: there "auto" runs one
thread's code (ThreadChoice.begin has no loop to choose for), so its auto/one is the spread
between two runs of the same code under that load, reported apart from the goal's ratio.
"""
import time

import numpy as np

from . import header, title
from .heavybench import busy_core

MODES = ("auto", "never", "always")


def _scenes(quick):
    from ..scenes import star_system, uniform_sphere
    from .heavybench import dense_field
    return {
        "star_system": (lambda: star_system(integrator="yoshida4", dt=0.002), 400),
        "dense field": (lambda: dense_field(5_000 if quick else 20_000), 20),
        "N = 1 024 direct": (lambda: uniform_sphere(1024, dt=1e-4), 40),
    }


def _fresh(build, mode):
    """A new World of the scene on `mode`, its kernels loaded and tables built (untimed)."""
    w = build()
    w.threads = mode
    w.step(2)
    return w


def _frames(w, seconds):
    """Seconds per step over step(1) calls for `seconds`."""
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        w.step(1)
        steps += 1
    return (time.perf_counter() - start) / steps


def _long(w, steps):
    start = time.perf_counter()
    w.step(steps)
    return (time.perf_counter() - start) / steps


def threads(quick=False):
    """Seconds per step of every scene × load × mode × way (see the module): the median of
    5 runs each (quick: 1)."""
    seconds, repeats = (0.3, 1) if quick else (1.5, 5)
    rows = []
    loops = {name: _force_loop(build) for name, (build, _) in _scenes(quick).items()}
    for busy in (0, 1, 2):
        spinners = [busy_core() for _ in range(busy)]
        try:
            time.sleep(0.3)
            for name, (build, long_steps) in _scenes(quick).items():
                steps = long_steps // 4 if quick else long_steps * 3
                row = {"scene": name, "busy": busy, "force_loop": loops[name]}
                runs = {}
                for _ in range(repeats):           # the modes in turn: a disturbance hits all
                    for mode in MODES:
                        runs.setdefault(f"frames_{mode}_s", []).append(
                            _frames(_fresh(build, mode), seconds))
                        runs.setdefault(f"long_{mode}_s", []).append(
                            _long(_fresh(build, mode), steps))
                row.update({key: float(np.median(v)) for key, v in runs.items()})
                for way in ("frames", "long"):
                    row[f"{way}_auto_over_one"] = row[f"{way}_auto_s"] / row[f"{way}_never_s"]
                rows.append(row)
        finally:
            for s in spinners:
                s.kill()
                s.wait()
    def worst(loop):
        return max(max(r["frames_auto_over_one"], r["long_auto_over_one"])
                   for r in rows if r["force_loop"] == loop)
    return {**header("threads", quick), "rows": rows, "worst_auto_over_one": worst(True),
            "worst_same_code": worst(False)}


def _force_loop(build):
    """Whether the scene has a force loop, the only code that may run on threads (these
    three scenes' loops, where they have one, are over the size at which they may)."""
    return build().gravity != "none"


def format_threads(results):
    us = lambda s: f"{1e6 * s:,.0f} µs"          # noqa: E731
    lines = [title(results), "", "per step, the whole time over the steps taken: auto, one "
             "thread (never), all threads (always)", "",
             "| scene | busy processes | frames: auto | one | all | auto/one | "
             "long call: auto | one | all | auto/one |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results["rows"]:
        lines.append(f"| {r['scene']} | {r['busy']} | " + " | ".join(
            [us(r[f"frames_{m}_s"]) for m in MODES] + [f"{r['frames_auto_over_one']:.2f}"] +
            [us(r[f"long_{m}_s"]) for m in MODES] + [f"{r['long_auto_over_one']:.2f}"]) + " |")
    lines += ["", f"worst auto / one thread: {results['worst_auto_over_one']:.2f} "
                  f"(goal <= 1.10); where auto runs one thread's code (no force loop), "
                  f"the same code's spread: {results['worst_same_code']:.2f}"]
    return "\n".join(lines)
