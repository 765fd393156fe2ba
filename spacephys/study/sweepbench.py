"""`spacephys bench sweep`: the throughput of a sweep on 1 and on 2 local Dask workers, beside
the same runs in a plain loop in this process (the runs themselves), and what each worker
compiled.

The runs: the shipped scenario dogfight (two ships around a planet, guided missiles, explosions)
over two guidance constants x two steps x seeds, each run about 0.1 s. Each cluster is
started and its workers given one run each before the timing (a worker's first run loads
the kernels from numba's cache): the timing is the sweep itself, its first run alone
included (that is how sp.sweep starts).
"""
import time

import numpy as np

from . import header

DOGFIGHT = "dogfight"       # the shipped scenario
VARY = {"missiles.seeker.nav_constant": [3.0, 4.0], "world.dt": [0.004, 0.008]}


def _kernels():
    """On a worker: (kernels compiled in this process, kernels loaded from the cache) over
    spacephys's numba dispatchers."""
    import sys
    compiled = loaded = 0
    for name, module in list(sys.modules.items()):
        if not name.startswith("spacephys") or module is None:
            continue
        for value in vars(module).values():
            stats = getattr(value, "stats", None)
            if stats is not None and hasattr(stats, "cache_misses"):
                compiled += len(stats.cache_misses)
                loaded += len(stats.cache_hits)
    return compiled, loaded


def _on_cluster(workers, runs):
    import logging

    from dask.distributed import Client, LocalCluster

    from ..sweeps import sweep
    start = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR,
                           env={"NUMBA_NUM_THREADS": "1"})
    client = Client(cluster)
    startup = time.perf_counter() - start
    try:
        # every worker's first run (its kernels loaded), outside the timing
        sweep(DOGFIGHT, {}, seeds=range(1000, 1000 + 2 * workers), client=client)
        start = time.perf_counter()
        table = sweep(DOGFIGHT, VARY, seeds=range(runs // 4), client=client)
        wall = time.perf_counter() - start
        kernels = client.run(_kernels)
    finally:
        client.close()
        cluster.close()
    assert table.ok.all(), table["error"][~table.ok][:3]
    return {"workers": workers, "runs": len(table), "startup_s": startup, "wall_s": wall,
            "runs_per_s": len(table) / wall, "run_s": float(np.mean(table["wall"])),
            "overhead_s": wall * workers / len(table) - float(np.mean(table["wall"])),
            "kernels": sorted(kernels.values())}


def sweep_bench(quick=False):
    """200 runs (quick: 40) on 1 and 2 workers, and in a loop here."""
    from ..sweeps import SweepRun, plan, run_one
    runs = 40 if quick else 200
    from ..scenario import load_scenario, shipped
    path = shipped()[DOGFIGHT]
    job = {"text": path.read_text(), "source": str(path), "measure": None, "setup": None,
           "logs": None}
    todo = plan(load_scenario(path), VARY, range(runs // 4))
    run_one(job, SweepRun(0, todo[0].params, 0, 0))        # kernels loaded here
    start = time.perf_counter()
    walls = [run_one(job, r)["wall"] for r in todo]
    loop = time.perf_counter() - start
    one = _on_cluster(1, runs)
    two = _on_cluster(2, runs)
    return {**header("sweep", quick), "runs": runs, "loop_s": loop,
            "loop_run_s": float(np.mean(walls)), "clusters": [one, two],
            "speedup": two["runs_per_s"] / one["runs_per_s"]}


def format_sweep(results):
    r = results
    lines = [f"sweep benchmark on {r['machine']} ({r['versions']}): {r['runs']} runs of "
             f"the scenario dogfight, local Dask workers (1 thread each)",
             f"{'where':22s} {'wall':>9s} {'runs/s':>8s} {'run':>9s} {'overhead/run':>13s} "
             f"{'start-up':>9s}  kernels compiled / loaded per worker",
             f"{'a loop, this process':22s} {r['loop_s']:8.2f}s {r['runs'] / r['loop_s']:8.1f} "
             f"{r['loop_run_s'] * 1e3:7.1f}ms {'-':>13s} {'-':>9s}"]
    for c in r["clusters"]:
        kernels = ", ".join(f"{a} / {b}" for a, b in c["kernels"])
        lines.append(f"{str(c['workers']) + ' worker' + 's' * (c['workers'] > 1):22s} "
                     f"{c['wall_s']:8.2f}s {c['runs_per_s']:8.1f} {c['run_s'] * 1e3:7.1f}ms "
                     f"{c['overhead_s'] * 1e3:11.1f}ms {c['startup_s']:8.2f}s  {kernels}")
    lines.append(f"2 workers / 1 worker: {r['speedup']:.2f}x the throughput")
    return "\n".join(lines)
