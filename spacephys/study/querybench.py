"""`spacephys bench queries`: the World's spatial queries beside scipy's cKDTree on the same
bodies and queries, the grid (ours) and the tree (theirs) built inside every timing, and the
same answers checked; and a frame's queries: 20 batches of 10 radius queries among 4 000
bodies, the grid built by the first (World keeps it while nothing moves) and the tree once.

Bodies: point bodies uniform in a square (2D) or cube (3D) of side 1 000; queries uniform in
the same region. Radius queries use the r that holds about 10 bodies on average. Rays (no
peer): from the query points in random directions, 100 long, among the same bodies given a
radius of 0.5.
"""
import math
import time

import numpy as np

from . import best_of, header


def _median(fn, repeats=9):
    """The median wall seconds of `repeats` calls of fn() (the issue's measure for the
    radius queries and the rays)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _case(dim, n, nq, repeats):
    from scipy.spatial import cKDTree
    from ..world import World
    rng = np.random.default_rng(dim)
    side = 1000.0
    w = World(dim=dim, gravity="none", capacity=n)
    w.add_bodies(1.0, rng.uniform(0.0, side, (n, dim)))
    centres = rng.uniform(0.0, side, (nq, dim))
    ball = math.pi if dim == 2 else 4.0 / 3.0 * math.pi
    r = (10.0 / (n / side ** dim) / ball) ** (1.0 / dim)
    rows = []

    # radius queries
    w.query_radius(centres[:2], r)
    t_ours, hits = best_of(lambda: _fresh(w).query_radius(centres, r), repeats)
    t_theirs, found = best_of(lambda: cKDTree(w.pos).query_ball_point(centres, r), repeats)
    same = all(sorted(hits[q][0].tolist()) == sorted(found[q]) for q in range(nq))
    rows.append({"case": f"{nq} radius queries, {dim}D", "bodies": n, "queries": nq,
                 "mean_found": float(hits.counts().mean()), "spacephys_s": t_ours,
                 "spacephys_median_s": _median(lambda: _fresh(w).query_radius(centres, r)),
                 "scipy_s": t_theirs, "ratio": t_theirs / t_ours, "same_answers": bool(same)})
    # nearest
    for k in (1, 10):
        w.nearest(centres[:2], k=k)
        t_ours, (ids, d) = best_of(lambda: _fresh(w).nearest(centres, k=k), repeats)
        t_theirs, (dd, ii) = best_of(lambda: cKDTree(w.pos).query(centres, k=k), repeats)
        ii = ii.reshape(nq, k)
        same = bool(np.array_equal(ids, w.ids[ii]) and
                    np.allclose(d, dd.reshape(nq, k), rtol=1e-12, atol=0))
        rows.append({"case": f"{nq} nearest (k = {k}), {dim}D", "bodies": n, "queries": nq,
                     "spacephys_s": t_ours, "scipy_s": t_theirs, "ratio": t_theirs / t_ours,
                     "same_answers": same})
    # rays: the nearest body along each, up to 100, among bodies of radius 0.5 (no peer)
    shapes = World(dim=dim, gravity="none", capacity=n)
    shapes.add_bodies(1.0, w.pos, radius=0.5)
    dirs = rng.normal(size=(nq, dim))
    shapes.raycast(centres[:2], dirs[:2], 100.0)
    for first in (True, False):
        t_ours, hits = best_of(lambda: _fresh(shapes).raycast(centres, dirs, 100.0, first=first),
                               repeats)
        rows.append({"case": f"{nq} rays ({'nearest' if first else 'every'} hit), {dim}D",
                     "bodies": n, "queries": nq, "mean_found": float(hits.counts().mean()),
                     "spacephys_s": t_ours, "spacephys_median_s": _median(
                         lambda: _fresh(shapes).raycast(centres, dirs, 100.0, first=first)), "scipy_s": None, "ratio": None,
                     "same_answers": None})
    # boxes of the same area/volume as the balls (no peer)
    half = 0.5 * (ball ** (1.0 / dim)) * r
    w.query_box(centres[:2] - half, centres[:2] + half)
    t_ours, hits = best_of(lambda: _fresh(w).query_box(centres - half, centres + half),
                           repeats)
    rows.append({"case": f"{nq} box queries, {dim}D", "bodies": n, "queries": nq,
                 "mean_found": float(hits.counts().mean()), "spacephys_s": t_ours,
                 "scipy_s": None, "ratio": None, "same_answers": None})
    return rows


def _fresh(w):
    """w without the grid its last queries kept (queries._grid): built inside the timing."""
    w.driver.grids.clear()
    return w


def _frame(dim, repeats, n=4000, batches=20, per=10):
    """A frame's queries: `batches` calls of `per` radius queries (about 10 bodies each)
    among n bodies, from a step's end (the grid built by the first call) against a cKDTree
    built once and queried as many times."""
    from scipy.spatial import cKDTree
    from ..world import World
    rng = np.random.default_rng(10 + dim)
    side = 1000.0
    w = World(dim=dim, gravity="none", capacity=n)
    w.add_bodies(1.0, rng.uniform(0.0, side, (n, dim)))
    ball = math.pi if dim == 2 else 4.0 / 3.0 * math.pi
    r = (10.0 / (n / side ** dim) / ball) ** (1.0 / dim)
    centres = rng.uniform(0.0, side, (batches, per, dim))

    def ours():
        _fresh(w)
        return [w.query_radius(c, r) for c in centres]

    def theirs():
        tree = cKDTree(w.pos)
        return [tree.query_ball_point(c, r) for c in centres]
    ours()
    t_ours, hits = best_of(ours, repeats)
    t_theirs, found = best_of(theirs, repeats)
    same = all(sorted(h[q][0].tolist()) == sorted(f[q]) for h, f in zip(hits, found)
               for q in range(per))
    return {"case": f"{batches} x {per} radius queries, {dim}D", "bodies": n,
            "queries": batches * per, "spacephys_s": t_ours, "scipy_s": t_theirs,
            "ratio": t_theirs / t_ours, "same_answers": bool(same)}


def queries(quick=False):
    """Radius, nearest and box queries on 10^5 bodies (quick: 2 x 10^4), 10^4 queries each
    (quick: 2 000), in 2D and 3D, beside cKDTree."""
    import scipy
    n, nq, repeats = (20_000, 2_000, 3) if quick else (100_000, 10_000, 5)
    cases = _case(2, n, nq, repeats) + _case(3, n, nq, repeats)
    cases += [_frame(2, 3 * repeats), _frame(3, 3 * repeats)]
    return {**header("queries", quick), "scipy_version": scipy.__version__, "cases": cases}


def format_queries(results):
    lines = [f"queries benchmark on {results['machine']} ({results['numba_threads']} numba "
             f"threads; {results['versions']}, scipy {results['scipy_version']}); the grid "
             f"and cKDTree built inside every timing",
             f"{'case':34s} {'bodies':>8s} {'spacephys':>12s} {'cKDTree':>12s} "
             f"{'speed-up':>9s} {'same answers':>13s}"]
    for c in results["cases"]:
        theirs = "-" if c["scipy_s"] is None else f"{c['scipy_s'] * 1e3:9.2f} ms"
        ratio = "-" if c["ratio"] is None else f"{c['ratio']:8.1f}x"
        same = "-" if c["same_answers"] is None else str(c["same_answers"])
        found = f" ({c['mean_found']:.1f} found)" if "mean_found" in c else ""
        lines.append(f"{c['case'] + found:34s} {c['bodies']:8d} "
                     f"{c['spacephys_s'] * 1e3:9.2f} ms {theirs:>12s} {ratio:>9s} {same:>13s}")
    return "\n".join(lines)
