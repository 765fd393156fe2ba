"""The study tools: the benchmarks of `spacephys bench`, most beside REBOUND (a module each,
listed in benchmarks.py), the work-precision study (tradeoff), the reference problems
(validate) and sp.recommend. They use the World's public API and one World -> REBOUND
adapter (rebound.py)."""

import math
import os
import platform
import time


def header(name, quick, rebound=None):
    """What every benchmark's results start with: its name, the machine, the versions."""
    import numba
    import numpy as np
    versions = {"numba": numba.__version__, "numpy": np.__version__}
    if rebound is not None:
        versions["rebound"] = rebound.__version__
    return {"benchmark": name, "quick": quick,
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
            "cpu": cpu_model(), "date": time.strftime("%Y-%m-%d", time.gmtime()),
            "numba_threads": numba.get_num_threads(), "versions": versions}


def cpu_model():
    """The CPU's model name ("AMD EPYC 7B13"), or the platform's word for it."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def title(results):
    """The first line of a benchmark's report, from what header() put in its results."""
    return (f"{results['benchmark']} benchmark on {results['machine']} "
            f"({results['numba_threads']} numba threads; {results['versions']})")


def best_of(fn, repeats):
    """(the least wall seconds of `repeats` calls of fn(), the last call's result)."""
    best, out = math.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out
