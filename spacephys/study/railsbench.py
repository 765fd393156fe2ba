"""`spacephys bench models`, its rails part: the outer Solar System (the Sun with the inner
planets' mass, Jupiter, Saturn, Uranus and Neptune: Hairer, Lubich & Wanner's initial values)
with test asteroids among them, flown three ways with the same integrator and step — every
body integrated (the reference), the planets on Kepler rails about the (integrated) Sun, and
the Sun and the planets on an ephemeris fitted to the reference run — and the asteroids
coasting (patched conics about the Sun) among the railed planets, and what each costs per
step and gets wrong: the planets' and the asteroids' distances from the reference after 1, 10
and 100 of Jupiter's orbits.
"""
import numpy as np

from .timing import per_step, steps_for

JUPITER_YEARS = 11.862


def _scene(asteroids, integrator, dt):
    """(World, planet ids, asteroid ids): the outer Solar System and `asteroids` test
    particles on orbits 2.2..3.2 AU (seed 5)."""
    from ..orbits import elements_to_state
    from ..scenes import outer_solar_system
    w = outer_solar_system(integrator=integrator, dt=dt)
    planets = [int(i) for i in w.ids]
    rng = np.random.default_rng(5)
    a = rng.uniform(2.2, 3.2, asteroids)
    pos, vel = zip(*(elements_to_state(w.G, a[k], rng.uniform(0, 0.15),
                                       np.radians(rng.uniform(0, 10)),
                                       rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi),
                                       M=rng.uniform(0, 2 * np.pi)) for k in range(asteroids)))
    sun = w.pos[0]
    rocks = w.add_bodies(0.0, np.array(pos) + sun, np.array(vel) + w.vel[0], kind="asteroid")
    return w, planets, [int(i) for i in rocks]


def rails(quick=False):
    """Rows per way of flying: time per step and, after each span, the largest planet
    distance and the median and largest asteroid distance from the reference [AU]."""
    from ..ephemeris import Ephemeris
    integrator, dt = "yoshida4", 10.0 / 365.25
    asteroids = 20 if quick else 100
    spans = (1, 10) if quick else (1, 10, 100)
    steps = [round(k * JUPITER_YEARS / dt) for k in spans]
    ref, planets, rocks = _scene(asteroids, integrator, dt)
    eph = Ephemeris.fit(ref, planets, steps[-1] * dt + 2 * dt, tolerance=1e-10)
    ways = {}
    for way in ("integrated", "kepler rails", "kepler rails, asteroids coasting", "ephemeris"):
        w, _, rocks = _scene(asteroids, integrator, dt)
        if way.startswith("kepler rails"):
            for p in planets[1:]:
                w.set_rails(p, planets[0])
            if way.endswith("coasting"):
                w.coast(rocks)
        elif way == "ephemeris":
            for p in planets:
                w.set_rails(p, ephemeris=eph)
        ways[way] = w
    timing = {}
    repeats = 3 if quick else 5
    for way, w in ways.items():
        probe = w.copy()
        # (steps_for's two and the repeats' within the span the ephemeris was fitted over)
        n = min(steps_for(probe.step, 0.05 if quick else 0.3), (steps[-1] - 2) // repeats)
        timing[way] = per_step(probe.step, n, repeats)
    rows = []
    done = 0
    results = {way: [] for way in ways}
    for span, k in zip(spans, steps):
        for w in ways.values():
            w.step(k - done)
        done = k
        full = ways["integrated"]
        for way, w in ways.items():
            dp = np.linalg.norm(w.pos[:len(planets)] - full.pos[:len(planets)], axis=1)
            da = np.linalg.norm(w.pos[len(planets):] - full.pos[len(planets):], axis=1)
            results[way].append({"jupiter_orbits": span, "planets_max": float(dp.max()),
                                 "asteroids_median": float(np.median(da)),
                                 "asteroids_max": float(da.max())})
    for way in ways:
        rows.append({"way": way, "s_per_step": timing[way], "errors": results[way]})
    return {"integrator": integrator, "dt": dt, "asteroids": asteroids,
            "ephemeris_segments": int(eph.coef.shape[1]), "rows": rows}


def format_rails(r):
    """The rails part's table."""
    spans = [e["jupiter_orbits"] for e in r["rows"][0]["errors"]]
    head = " | ".join(f"after {s} Jupiter orbit{'s' if s > 1 else ''}: planets max / "
                      f"asteroids median, max [AU]" for s in spans)
    lines = [f"rails: the outer Solar System and {r['asteroids']} test asteroids, "
             f"{r['integrator']}, dt = 10 days; distances from the all-integrated run; the "
             f"ephemeris fitted to it to 1e-10 of each orbit ({r['ephemeris_segments']} "
             f"segments)",
             "", f"| flown | time per step | {head} |",
             "|---|---|" + "---|" * len(spans)]
    for row in r["rows"]:
        cells = " | ".join(
            "reference" if row["way"] == "integrated" else
            f"{e['planets_max']:.1e} / {e['asteroids_median']:.1e}, {e['asteroids_max']:.1e}"
            for e in row["errors"])
        lines.append(f"| {row['way']} | {row['s_per_step'] * 1e6:.1f} us | {cells} |")
    return "\n".join(lines)
