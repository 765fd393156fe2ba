"""Collision-heavy scenes as a game builds them, timed step by step (median, 95th percentile,
worst), split into broad phase, narrow phase, responses, guidance and the rest, on a quiet
machine and with one core kept busy by another process. Part of `spacephys bench
collisions` (the dense field) and `spacephys bench fleet` (the game's fleet battle).
"""
import subprocess
import sys
import time

import numpy as np


def dense_field(n, seed=0, boundary="open"):
    """n circles, radii uniform 0.5..2 (masses r^2), placed uniformly at random over a square they cover
    10% of (so some overlap at the start), velocities normal with sigma 1, dt 0.01; every
    pair collides elastically. boundary: "open", or the square's edges "reflect" or wrap
    ("periodic")."""
    from ..world import World
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.5, 2.0, n)
    side = float(np.sqrt(np.pi * (r ** 2).sum() / 0.10))
    w = World(dim=2, gravity="none", dt=0.01, capacity=n)
    w.set_collision("*", "*", "elastic")
    if boundary != "open":
        w.set_boundary(boundary, lo=(0.0, 0.0), hi=(side, side))
    w.add_bodies(r ** 2, rng.uniform(2.0, side - 2.0, (n, 2)), rng.normal(size=(n, 2)),
                 radius=r)                       # mass as the area (density 1 / pi)
    return w


def game_fleet(ships=200, missiles=2000, debris=50_000, seed=0):
    """A fleet battle as a game sets one up: 10 planets (radii 5..20, pulling) in a square
    6 000 wide, `ships` ships of two sides, `missiles` guided (PN) missiles launched in
    salvos of 10 from each ship in turn at an enemy (fanned out 36 degrees apart: launched on top of
    each other they would destroy each other at once), `debris` fragments of radius 0.2;
    missiles, ships and debris destroy each other on contact (ships and missiles explode into
    debris) but for debris on debris (an explosion's fragments are thrown out overlapping),
    anything meeting a planet is destroyed. dt = 1/60."""
    from ..entities import ExplosionSpec, MissileSpec, ShipSpec
    from ..world import World
    rng = np.random.default_rng(seed)
    side = 6000.0
    w = World(dim=2, dt=1 / 60, seed=seed, capacity=ships + missiles + debris + 20_000)
    for _ in range(10):
        w.add_body(rng.uniform(1e4, 1e5), rng.uniform(0.0, side, 2), radius=rng.uniform(5, 20),
                   kind="planet")
    small = ("missile", "ship", "debris")
    for a in small:
        for b in small:
            if a <= b and (a, b) != ("debris", "debris"):
                w.set_collision(a, b, "destroy_both")
        w.set_collision(a, "planet", "destroy_a")
    boom = ExplosionSpec(count=50, speed=15.0, lifetime=4.0, lifetime_spread=0.5,
                         radius=0.2)
    hull = ShipSpec(dry_mass=10.0, fuel_mass=10.0, max_thrust=200.0, exhaust_speed=300.0,
                    turn_rate=2.0, radius=4.0, explosion=boom)
    sides = [[], []]
    for k in range(ships):
        pos = rng.uniform(0.0, side, 2)
        ship = w.add_ship(hull, pos, rng.normal(scale=10.0, size=2),
                          heading=rng.uniform(-np.pi, np.pi))
        w.control(ship, throttle=rng.uniform(0.0, 0.3), turn=rng.uniform(-0.2, 0.2))
        sides[k % 2].append(ship)
    warhead = MissileSpec(mass=1.0, fuel_mass=2.0, thrust=300.0, exhaust_speed=500.0,
                          guidance="pn", turn_rate=4.0, launch_speed=20.0, lifetime=20.0,
                          arming_delay=0.5, fuse_radius=8.0, radius=1.0,
                          explosion=ExplosionSpec(count=10, speed=10.0, lifetime=2.0,
                                                  radius=0.2))
    for salvo in range(missiles // 10):         # a salvo from each ship in turn
        shooter = sides[salvo % 2][salvo // 2 % len(sides[salvo % 2])]
        target = sides[1 - salvo % 2][rng.integers(len(sides[1 - salvo % 2]))]
        fan = rng.uniform(-np.pi, np.pi)
        for k in range(10):
            w.launch(shooter, warhead, target=target, heading=fan + k * np.pi / 5)
    w.add_bodies(0.01, rng.uniform(0.0, side, (debris, 2)), rng.normal(scale=5.0,
                 size=(debris, 2)), radius=0.2, kind="debris")
    return w


def split(w, repeats=3):
    """Milliseconds of the parts of one step on w's state, each timed alone on copies (best
    of repeats): broad phase (the candidate pairs of the step's sweeps), narrow phase (their
    times of impact), responses (the whole collision pass less those two: resolving in time
    order, later passes), guidance (turning, guidance, thrust, fuses), gravity."""
    from ..events import EVENT_DTYPE
    from ..kernels import broadphase, collide, control, forces
    from ..kernels import state as kstate
    from ..kernels import step as kstep
    n = w.n
    pos, vel = np.zeros((n, 3)), np.zeros((n, 3))
    pos[:, :w.dim], vel[:, :w.dim] = w.pos, w.vel
    end = pos + w.dt * vel
    plan = w.tables()
    acc = np.empty((n, 3))
    everyone = np.arange(n, dtype=np.int64)

    def best(run):
        return 1e3 * min(run() for _ in range(repeats))

    def timed(fn):
        def run():
            start = time.perf_counter()
            fn()
            return time.perf_counter() - start
        return run

    A, B = pos.copy(), end - pos
    tb = np.zeros(n)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    rules = plan.rules
    pairs, _ = broadphase.candidate_pairs(A, B, tb, plan.alive, rules, lo, hi)
    out = {"broad_ms": best(timed(lambda: broadphase.candidate_pairs(A, B, tb, plan.alive, rules,
                                                                  lo, hi))),
           "narrow_ms": best(timed(lambda: collide.pair_contacts(A, B, tb, pairs, np.zeros(3),
                                                                  rules, None)))}

    # the whole pass on one copy of the tables, its inputs put back before each repeat (a
    # fresh copy's scratch would be paid for in page faults the real step does not see)
    copy = w.copy()
    rules = copy.tables().rules
    arrays = (end.copy(), vel.copy(), end.copy(), copy.mass.copy(), copy.ids.copy(),
              np.ones(n, np.bool_), np.empty((n, 3)), pos.copy(), vel.copy(),
              np.zeros(4096, EVENT_DTYPE), np.zeros(1, np.int64))
    state = kstate.make(**dict(zip(kstate.FIELDS, arrays + (w.dim,))))
    saved = [a.copy() for a in arrays]

    def whole():                    # (the pairs in touch: as the first repeat left them)
        for a, keep in zip(arrays, saved):
            a[...] = keep
        start = time.perf_counter()
        collide.collide_step(state, rules, w.dt, w.t)
        return time.perf_counter() - start

    out["responses_ms"] = max(0.0, best(whole) - out["broad_ms"] - out["narrow_ms"])
    if plan.actors is not None:
        def guide():
            p = w.copy().tables()
            ht = kstep.hoist(p.state, p.rules, p.actors)
            start = time.perf_counter()
            control.begin_step(p.state, ht.owner, p.actors, w.t, w.dt, (0.0, 0.0, 0.0))
            control.end_burn(ht, w.t, w.dt)
            control.after_step(p.state, p.actors, w.t, w.dt, (0.0, 0.0, 0.0))
            return time.perf_counter() - start
        out["guidance_ms"] = best(guide)
    else:
        out["guidance_ms"] = 0.0
    out["gravity_ms"] = best(timed(lambda: forces.accelerations_of(plan.forces, w.t, pos, vel, acc,
                                                                everyone, False)))
    return out


def _steps(w, steps, every):
    """Milliseconds of each of `steps` single steps, and the split every `every` steps."""
    times, splits = [], []
    for k in range(steps):
        if k % every == 0:
            splits.append(split(w))
        start = time.perf_counter()
        w.step(1)
        times.append(time.perf_counter() - start)
    return 1e3 * np.array(times), splits


def _figures(times, splits):
    parts = {key: float(np.median([s[key] for s in splits])) for key in splits[0]}
    total = float(np.median(times))
    parts["rest_ms"] = max(0.0, total - sum(parts.values()))
    return {"median_ms": total, "p95_ms": float(np.percentile(times, 95)),
            "worst_ms": float(times.max()), "split_ms": parts}


def busy_core():
    """Another process spinning on one core (stop it with .kill())."""
    return subprocess.Popen([sys.executable, "-c", "while True: pass"])


def measure(build, steps, every, warm=2, rehearse=False):
    """build() -> World, stepped `warm` steps, then timed `steps` steps: quiet, then with a
    core busy (a fresh World each). rehearse: the same steps of one more World first,
    untimed, so that the kernels of events met late (explosions, expiries) are compiled or
    loaded before the timing."""
    out = {}
    if rehearse:
        build().step(warm + steps)
    for name in ("quiet", "one core busy"):
        w = build()
        w.step(warm)
        spinner = busy_core() if name != "quiet" else None
        try:
            if spinner is not None:
                time.sleep(0.2)
            times, splits = _steps(w, steps, every)
        finally:
            if spinner is not None:
                spinner.kill()
                spinner.wait()
        out[name] = {**_figures(times, splits), "bodies": w.n}
    return out


def dense(quick=False):
    """The dense field: 100 000 and 200 000 circles (quick: 20 000 and 40 000)."""
    sizes = (20_000, 40_000) if quick else (100_000, 200_000)
    steps = 10 if quick else 20
    rows = {str(n): measure(lambda n=n: dense_field(n), steps, steps // 2) for n in sizes}
    quiet = [rows[str(n)]["quiet"]["median_ms"] for n in sizes]
    return {"sizes": list(sizes), "steps": steps, "cases": rows, "scaling": quiet[1] / quiet[0]}


def dense_scaling(quick=False):
    """The dense field's cost per body from 12 500 to 800 000 circles (quick: to 50 000),
    the median of single steps after two (the first sorts the rows; the next sort is 64
    steps on), with the rows in space order (the default: spacephys/space_order.py) and,
    alternated with it, in creation order (its sorting off): {"sizes", "steps": {n: steps},
    "space order"/"creation order": {n: ns a body}}. The smaller fields take more steps (15
    of 1.8 ms at 12 500 circles once gave a median 20 % off)."""
    from .. import space_order
    sizes = (12_500, 25_000, 50_000) if quick else \
        (12_500, 25_000, 50_000, 100_000, 200_000, 400_000, 800_000)
    base = 5 if quick else 15
    steps = {str(n): min(60, base * max(1, 100_000 // n)) for n in sizes}
    least = space_order.MIN_BODIES
    out = {"sizes": list(sizes), "steps": steps, "space order": {}, "creation order": {}}
    try:
        for n in sizes:
            for case, bound in (("creation order", 2 ** 62), ("space order", 0)):
                space_order.MIN_BODIES = bound
                w = dense_field(n)
                w.step(2)
                times = []
                for _ in range(steps[str(n)]):
                    start = time.perf_counter()
                    w.step(1)
                    times.append(time.perf_counter() - start)
                out[case][str(n)] = float(np.median(times)) / n * 1e9
                del w
    finally:
        space_order.MIN_BODIES = least
    for case in ("space order", "creation order"):
        per = [out[case][str(n)] for n in sizes]
        out[case + " spread"] = max(per) / min(per)
    return out


def fleet_game(quick=False):
    """The game's fleet battle: 200 ships, 2 000 missiles, 50 000 debris (quick: a quarter),
    300 steps (5 s at 60 Hz: the salvos arrive, ships explode)."""
    scale = 4 if quick else 1
    steps = 120 if quick else 300
    return {"steps": steps, **measure(lambda: game_fleet(200 // scale, 2000 // scale,
                                                         50_000 // scale),
                                      steps, steps // 6, rehearse=True)}


def format_rows(title, cases):
    """Lines of a table: each (label, figures) of measure()."""
    lines = [title, f"{'scene':34s} {'bodies':>7s} {'median':>8s} {'p95':>8s} {'worst':>8s}   "
                    f"split of the median: broad / narrow / responses / guidance / gravity / "
                    f"rest [ms]"]
    for label, f in cases:
        s = f["split_ms"]
        lines.append(f"{label:34s} {f['bodies']:7d} {f['median_ms']:7.1f}  {f['p95_ms']:7.1f}  "
                     f"{f['worst_ms']:7.1f}   {s['broad_ms']:.1f} / {s['narrow_ms']:.1f} / "
                     f"{s['responses_ms']:.1f} / {s['guidance_ms']:.1f} / {s['gravity_ms']:.1f} / "
                     f"{s['rest_ms']:.1f}")
    return lines
