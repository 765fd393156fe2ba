"""The integrator and step a prediction chooses for itself (World.predict(..., error=)).

The error of a predicted path is the largest distance, over its samples, from the exact
path, relative to the body's distance from the body pulling it hardest at the start (the
scale a HUD draws an orbit at). For each fixed-step method of `METHODS` (orders 2 to 8) the
error at m steps a sample interval is estimated from two runs, at m and 2m steps
(Richardson: for a method of order p, E(m) = |x_m - x_2m| 2^p / (2^p - 1)); E falls as m^-p,
which gives the fewest steps that meet the error, and the method doing it with the fewest
force evaluations is chosen, then checked the same way at its own m (and m doubled until the
check holds). A choice is kept by the World's driver and reused while the scene's character
holds: the same bodies predicted, duration, samples and error, the same body pulling each
hardest, the same number of pulling bodies and each body's distance from it within a
factor of 2 of the distance the choice was made at.
"""
import math

import numpy as np

from .integrators import get_integrator
from .orbits import hardest_pulling

METHODS = ("yoshida8", "yoshida6", "yoshida4", "leapfrog")    # the highest order first
SAFETY = 0.5              # the estimate aims at half the error asked
MOST_STEPS = 1 << 16      # the most steps a sample interval the search tries


def choose(world, ids, rows, duration, points, error, coast):
    """(integrator name, dt) for World.predict(ids, duration, points=points, error=error,
    coast=coast): see the module. rows: the ids' rows."""
    interval = duration / (points - 1)
    # (asked each frame by a HUD: a kernel, and the key in bytes, not numpy's calls)
    dominant, scale, pulling = hardest_pulling(world, rows)
    if np.any(dominant < 0):           # nothing pulls: every method is exact, one step a sample
        return "leapfrog", interval
    key = (ids.tobytes(), float(duration), int(points), float(error), bool(coast),
           world.ids[dominant].tobytes(), pulling)
    kept = world.driver.choices.get(key)
    if kept is not None and all(abs(math.log2(a / b)) < 1.0
                                for a, b in zip(scale.tolist(), kept[2].tolist())):
        return kept[0], kept[1]
    best, cost = None, math.inf        # cost: force evaluations a sample interval
    for name in METHODS:
        spec = get_integrator(name)
        # a method that would need more evaluations than the best so far is given up
        most = MOST_STEPS if best is None else \
            min(MOST_STEPS, math.ceil(cost / spec.evaluations) - 1)
        m = _steps_needed(world, ids, duration, points, interval, name, spec.order, scale,
                          error, coast, most)
        if m is not None:
            best, cost = (name, m), m * spec.evaluations
    if best is None:
        raise ValueError(f"error = {error}: no fixed-step method meets it within "
                         f"{MOST_STEPS} steps a sample; give integrator= and dt= or "
                         f"tolerance=")
    name, m = best
    world.driver.choices[key] = (name, interval / m, scale)
    return name, interval / m


def _steps_needed(world, ids, duration, points, interval, name, order, scale, error, coast,
                  most):
    """The fewest steps a sample interval with which `name` meets `error`, or None when it
    needs more than `most`."""
    m = 1
    while m <= most:
        e = _estimate(world, ids, duration, points, interval, name, order, scale, coast, m)
        if e <= error:
            return m
        if math.isfinite(e) and e < 0.1:
            # E(m) ~ m^-p: the m that brings it to SAFETY * error, then checked again
            m = max(2 * m, math.ceil(m * (e / (SAFETY * error)) ** (1.0 / order)))
        else:
            m *= 8                     # far from the asymptotic regime: no rule to trust
    return None


def _estimate(world, ids, duration, points, interval, name, order, scale, coast, m):
    """The estimated error of `name` at m steps a sample (see the module): two predictions,
    at m and 2m; inf where a path ended in one and not the other or is not finite."""
    a = world.predict(ids, duration, points=points, integrator=name, dt=interval / m,
                      coast=coast)
    b = world.predict(ids, duration, points=points, integrator=name, dt=interval / (2 * m),
                      coast=coast)
    ended = np.isnan(a.pos[..., 0])
    if not np.array_equal(ended, np.isnan(b.pos[..., 0])) or ended.all():
        return math.inf                # a path ended at one step and not at the other
    gap = np.linalg.norm(a.pos - b.pos, axis=2) / scale[:, None]
    worst = float(np.nanmax(gap))
    return worst * 2.0 ** order / (2.0 ** order - 1.0) if math.isfinite(worst) else math.inf
