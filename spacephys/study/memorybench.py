"""`spacephys bench memory`: bytes per body, and the peak memory of a million bodies stepped
(test particles about a star; a Plummer sphere under the tree).
"""
import time

import numpy as np

from . import header


def _ring_world(n):
    """A star and n test particles on circular orbits 1..2 from it (3D arrays, z = 0)."""
    from ..world import World
    w = World(dim=3, dt=0.01, capacity=n + 1)
    w.add_body(1.0, (0.0, 0.0, 0.0))
    rng = np.random.default_rng(0)
    r, th = rng.uniform(1.0, 2.0, n), rng.uniform(0.0, 2 * np.pi, n)
    pos = np.c_[r * np.cos(th), r * np.sin(th), np.zeros(n)]
    vel = np.c_[-np.sin(th), np.cos(th), np.zeros(n)] / np.sqrt(r)[:, None]
    w.add_bodies(0.0, pos, vel)
    return w


def memory_used(n, steps=5):
    """(peak bytes Python and numpy allocated, World bytes held) to build a star with n test
    particles and take `steps` leapfrog steps; tracemalloc sees numpy's buffers."""
    import tracemalloc
    _ring_world(10).step(steps)            # load the kernels outside the count
    tracemalloc.start()
    try:
        w = _ring_world(n)
        w.step(steps)
        held = tracemalloc.get_traced_memory()[0]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak, held


def memory(quick=False):
    """State is O(N): bytes per body (state columns, id slots, the kernels' scratch) and the
    peak memory of a star with 10^6 test particles taking leapfrog steps; and the peak
    memory per body of a Plummer sphere of as many stars under the tree."""
    import resource
    n = 100_000 if quick else 1_000_000
    w = _ring_world(1000)
    w.step(1)
    per_body = w.bytes_per_body()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = time.perf_counter()
    peak, held = memory_used(n)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    from .treebench import memory as tree_memory
    tree_peak, tree_held = tree_memory(n)
    return {**header("memory", quick), "bodies": n,
            "bytes_per_body": per_body,
            "held_bytes": held, "peak_bytes": peak, "maxrss_growth_bytes": after - before,
            "seconds": seconds, "tree_peak_bytes_per_body": tree_peak,
            "tree_held_bytes_per_body": tree_held}


def format_memory(results):
    """The report of `spacephys bench memory` (text)."""
    per = results["bytes_per_body"]
    n = results["bodies"]
    return "\n".join([
        f"memory benchmark on {results['machine']} ({results['versions']})",
        "memory: " + ", ".join(f"{k} {v} B" for k, v in per.items()) +
        f" per body ({sum(per.values())} B)",
        f"a star and {n:,} test particles, built and stepped: held "
        f"{results['held_bytes'] / 1e6:.0f} MB ({results['held_bytes'] / n:.0f} B per "
        f"body), peak {results['peak_bytes'] / 1e6:.0f} MB "
        f"({results['peak_bytes'] / n:.0f} B per body); the process's peak resident size "
        f"grew by {results['maxrss_growth_bytes'] / 1e6:.0f} MB",
        f"a Plummer sphere of {n:,} stars under the tree (theta 0.5), built and stepped "
        f"twice (leapfrog), in a process of its own: peak resident memory "
        f"{results['tree_peak_bytes_per_body']:.0f} B per body (held: " +
        ", ".join(f"{k} {v} B" for k, v in results["tree_held_bytes_per_body"].items())
        + ")"])
