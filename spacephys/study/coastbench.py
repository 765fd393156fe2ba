"""`spacephys bench models`, its coasting part (World.coast, patched conics, time warp):

- warp: a planet with three moons on Kepler rails and ships coasting on orbits about it,
  some crossing the moons' spheres of influence; what a frame (1/60 s) costs at warp x10^6,
  and what integrating the same ships for that frame would cost (their time per step with
  the moons on rails, times the steps a frame holds);
- transfer: a Hohmann transfer from Earth's orbit to Mars's (the Sun, Earth and Mars on
  rails; Earth 0.3 rad behind the ship at its start, Mars 0.05 rad ahead of it on arrival:
  no sphere is crossed), flown coasting (on the Sun's conic) and integrated (Gauss-Radau,
  pulled by all three), and how far apart the two ships are on arrival (the coasting one
  drops Earth's and Mars's pulls);
- lunar flyby: a ship from a 200 km Earth orbit at nearly escape speed, timed to pass the
  Moon (on rails), flown coasting (patched conics: the Moon's sphere entered and left) and
  integrated, and how far apart they are a set time after the flyby;
- lunar free return: the launch speed and the Moon's lead for which the coasting flight
  comes back to a 300 km perigee after the flyby, then flown integrated from the same start:
  where and when each comes back.
"""
import math
import time

import numpy as np

from ..kernels.codes import EV_DESTROY, EV_SOI_ENTER, EV_SOI_EXIT

AU = 1.495978707e11
DAYS = 14                  # the free return's flight [days]


def _warp_scene(ships, seed=2):
    """(World, ship ids): the planet (fixed) with three moons on rails and `ships` on
    orbits from 1.1 to 16 planet radii, 10 % of them reaching the moons' orbits; one that
    comes down to a surface is integrated and destroyed on contact."""
    import spacephys as sp
    rng = np.random.default_rng(seed)
    w = sp.World(3, units="si", dt=1.0)
    for kind in ("moon", "craft"):
        w.add_kind(kind)
    w.set_collision("craft", "planet", "destroy_a")
    w.set_collision("craft", "moon", "destroy_a")
    M = 5.97e24
    planet = w.add_body(M, (0.0, 0.0, 0.0), fixed=True, radius=6.4e6, kind="planet")
    for k, (a, m) in enumerate([(1.5e8, 1e21), (3.8e8, 7.3e22), (6e8, 5e21)]):
        ang = 2.1 * k
        v = math.sqrt(w.G * M / a)
        moon = w.add_body(m, (a * math.cos(ang), a * math.sin(ang), 0.0),
                          (-v * math.sin(ang), v * math.cos(ang), 0.0), radius=1e5,
                          kind="moon")
        w.set_rails(moon, planet)
    r = rng.uniform(7e6, 1e8, ships)
    ang = rng.uniform(0, 2 * np.pi, ships)
    boost = np.where(rng.uniform(size=ships) < 0.1, rng.uniform(1.2, 1.3, ships),
                     rng.uniform(1.0, 1.1, ships))
    v = np.sqrt(w.G * M / r) * boost
    pos = np.stack([r * np.cos(ang), r * np.sin(ang), rng.uniform(-1e5, 1e5, ships)], 1)
    vel = np.stack([-v * np.sin(ang), v * np.cos(ang), np.zeros(ships)], 1)
    ids = w.add_bodies(1e4, pos, vel, radius=10.0, kind="craft")
    return w, [int(i) for i in ids]


def warp(ships=1000, frames=600, warp_factor=1e6):
    """A frame's cost at the warp, the events in the run, and the integrated equivalent."""
    from .timing import per_step, steps_for
    integrated, _ = _warp_scene(ships)
    integrated.step(2)               # (compiled here: a ship coming down is integrated)
    step = per_step(integrated.step, steps_for(integrated.step, 0.2), 3)
    w, ids = _warp_scene(ships)
    w.coast(ids)
    rehearsal = w.copy()              # the same frames once, untimed: every kernel their
    for _ in range(frames + 1):       # events reach (a ship coming down, a moon's sphere)
        rehearsal.advance(1 / 60, warp=warp_factor)     # is compiled before the timing
    w.advance(1 / 60, warp=warp_factor)            # searched once
    events = destroyed = capped = 0
    t0 = time.perf_counter()
    for _ in range(frames):
        w.advance(1 / 60, warp=warp_factor)
        events += int(np.sum(w.events["kind"] >= EV_SOI_ENTER))
        destroyed += int(np.sum(w.events["kind"] == EV_DESTROY))
        capped += w.warp.reason is not None
    per_frame = (time.perf_counter() - t0) / frames
    steps = warp_factor / 60 / w.dt
    return {"ships": ships, "warp": warp_factor, "frames": frames,
            "days": w.t / 86400.0, "s_per_frame": per_frame, "events": events,
            "destroyed": destroyed, "capped_frames": capped,
            "coasting_at_end": int(len(w.coasting)), "granted": w.warp.granted,
            "integrated_s_per_step": step, "integrated_s_per_frame": step * steps}


def _pair(build, duration, dt_coast):
    """(coasting World, integrated World, ship id) built by build(coast) and flown
    `duration`; the integrated one with Gauss-Radau."""
    a, ship = build("leapfrog", dt_coast)
    a.coast(ship)
    b, _ = build("gauss_radau", dt_coast)
    for w in (a, b):                  # their kernels compiled or loaded before the timing
        w.copy().step(1)
    t0 = time.perf_counter()
    a.step(round(duration / a.dt))
    t_coast = time.perf_counter() - t0
    t0 = time.perf_counter()
    b.step(round(duration / b.dt))
    t_full = time.perf_counter() - t0
    return a, b, ship, t_coast, t_full


def _hohmann(integrator, dt):
    import spacephys as sp
    from ..orbits import elements_to_state
    w = sp.World(3, units="si", dt=dt, integrator=integrator, tolerance=1e-12)
    sun = w.add_body(1.989e30, (0.0, 0.0, 0.0), fixed=True, radius=7e8)
    mu = w.G * 1.989e30
    a_e, a_m = 1.0 * AU, 1.524 * AU
    t_transfer = math.pi * math.sqrt(((a_e + a_m) / 2) ** 3 / mu)
    n_m = math.sqrt(mu / a_m ** 3)
    earth = w.add_body(5.97e24, *elements_to_state(w.G * 1.989e30, a_e, 0.0, 0.0, 0.0, 0.0,
                                                   M=-0.3), radius=6.4e6)
    mars = w.add_body(6.42e23, *elements_to_state(w.G * 1.989e30, a_m, 0.0, 0.0, 0.0, 0.0,
                                                  M=math.pi - n_m * t_transfer + 0.05),
                      radius=3.4e6)
    for p in (earth, mars):
        w.set_rails(p, sun)
    v_peri = math.sqrt(mu * (2 / a_e - 2 / (a_e + a_m)))
    ship = w.add_body(1e4, (a_e, 0.0, 0.0), (0.0, v_peri, 0.0), radius=10.0)
    return w, ship


def _flyby(integrator, dt, speed=0.9995, lead=0.02):
    """(World, ship id): a ship from a 200 km Earth orbit at `speed` x the escape speed,
    the Moon (on rails) `lead` rad ahead of where the ship crosses its orbit."""
    import spacephys as sp
    w = sp.World(3, units="si", dt=dt, integrator=integrator, tolerance=1e-12)
    M = 5.972e24
    earth = w.add_body(M, (0.0, 0.0, 0.0), fixed=True, radius=6.371e6)
    a_moon = 3.844e8
    mu = w.G * M
    r0 = 6.571e6
    v0 = math.sqrt(2 * mu / r0) * speed            # apogee near the Moon's distance
    a = 1 / (2 / r0 - v0 * v0 / mu)
    # the time to reach the Moon's distance on this ellipse (Kepler's equation)
    e = 1 - r0 / a
    E = math.acos((1 - a_moon / a) / e)
    t_moon = (E - e * math.sin(E)) * math.sqrt(a ** 3 / mu)
    nu = 2 * math.atan(math.sqrt((1 + e) / (1 - e)) * math.tan(E / 2))
    n = math.sqrt(mu / a_moon ** 3)
    phase = nu - n * t_moon + lead                   # the Moon a little ahead there
    v_moon = math.sqrt(mu / a_moon)
    moon = w.add_body(7.342e22, (a_moon * math.cos(phase), a_moon * math.sin(phase), 0.0),
                      (-v_moon * math.sin(phase), v_moon * math.cos(phase), 0.0),
                      radius=1.737e6)
    w.set_rails(moon, earth)
    ship = w.add_body(1e4, (r0, 0.0, 0.0), (0.0, v0, 0.0), radius=10.0)
    return w, ship


def _perigee_after_flyby(speed, lead, days=12):
    """Coasting: (perigee, apogee) [m] of the ship's Earth orbit after it left the Moon's
    sphere, or None (no flyby, it came down, or it escapes)."""
    w, ship = _flyby("leapfrog", 10.0, speed, lead)
    w.coast(ship)
    left = False
    for _ in range(days * 4):
        w.step(2160)                                 # 6 hours
        left |= bool(np.any(w.events["kind"] == EV_SOI_EXIT))
        if not len(w.coasting):
            return None
        if left:
            break
    row = w.rails[w.rails["id"] == ship][0]
    if not left or row["about"] != 0 or row["e"] >= 1:
        return None
    return float(row["a"] * (1 - row["e"])), float(row["a"] * (1 + row["e"]))


def free_return(target=6.671e6):
    """A lunar free return found with coasting: of a grid of launch speeds (apogees just
    past the Moon) and Moon leads, the one whose Earth orbit after the flyby comes back
    (apogee under 600 000 km) with its perigee nearest `target` (300 km up); then flown
    coasting and integrated (Gauss-Radau) for 14 days: their first perigees after the
    flyby (sampled every 10 minutes), and how far apart the two ships are by then."""
    best = None
    for speed in np.linspace(0.9922, 0.9928, 7):
        for lead in np.linspace(-0.25, -0.05, 21):
            got = _perigee_after_flyby(float(speed), float(lead))
            if got is not None and got[1] < 6e8 and (
                    best is None or abs(got[0] - target) < abs(best[0] - target)):
                best = (got[0], float(speed), float(lead))
    if best is None:
        return None
    _, speed, lead = best
    out = {"speed": speed, "lead": lead}
    for way, integrator in (("coasting", "leapfrog"), ("integrated", "gauss_radau")):
        w, ship = _flyby(integrator, 10.0, speed, lead)
        if way == "coasting":
            w.coast(ship)
        w.copy().step(60)                            # its kernels loaded before the timing
        t0 = time.perf_counter()
        rows, times = [], []
        for k in range(DAYS * 144):                  # every 10 minutes
            w.step(60)
            if ship not in w or (way == "coasting" and not len(w.coasting)):
                break
            rows.append(w.pos[w.index_of(ship)].copy())
            times.append(w.t)
        spent = time.perf_counter() - t0
        d = np.linalg.norm(rows, axis=1)
        # the first apogee (past the Moon), then the first perigee after it: the return
        far = next(k for k in range(1, len(d) - 1) if d[k - 1] < d[k] >= d[k + 1])
        k = next(k for k in range(far + 1, len(d) - 1) if d[k - 1] > d[k] <= d[k + 1])
        out[way] = {"perigee_m": float(d[k]), "perigee_day": times[k] / 86400, "s": spent,
                    "path": rows}
    a, b = np.array(out["coasting"].pop("path")), np.array(out["integrated"].pop("path"))
    k = round(144 * max(out["coasting"]["perigee_day"], out["integrated"]["perigee_day"]))
    out["apart_m"] = float(np.linalg.norm(a[:k] - b[:k], axis=1).max())
    return out


def trips(quick=False):
    """The transfer and the flyby, each flown coasting and integrated."""
    out = []
    for name, build, duration, dt in (
            ("Hohmann transfer Earth -> Mars", _hohmann, 258.9 * 86400, 3600.0),
            ("lunar flyby", _flyby, 8 * 86400, 10.0)):
        a, b, ship, t_coast, t_full = _pair(build, duration, dt)
        i, j = a.index_of(ship), b.index_of(ship)
        apart = float(np.linalg.norm(a.pos[i] - b.pos[j]))
        out.append({"trip": name, "days": duration / 86400, "apart_m": apart,
                    "distance_m": float(np.linalg.norm(b.pos[j])),
                    "coasting_s": t_coast, "integrated_s": t_full,
                    "events": [str(k) for k in _kinds(a)]})
    return out


def _kinds(w):
    from ..events import kind_name
    return [kind_name(k) for k in w.events["kind"]]


def coasting(quick=False):
    return {"warp": warp(200 if quick else 1000, 120 if quick else 600),
            "trips": trips(quick), "free_return": free_return()}


def format_coasting(r):
    """The coasting part's lines."""
    wr = r["warp"]
    lines = [f"coasting: {wr['ships']} ships about a planet with three moons on rails, "
             f"warp x{wr['warp']:.0e}, frames of 1/60 s: {wr['s_per_frame'] * 1e3:.2f} ms a "
             f"frame ({wr['days']:.0f} days in {wr['frames']} frames, {wr['events']} "
             f"sphere changes, {wr['destroyed']} come down and destroyed, "
             f"{wr['capped_frames']} frames capped); integrating them instead: "
             f"{wr['integrated_s_per_step'] * 1e6:.0f} us a step, "
             f"{wr['integrated_s_per_frame']:.1f} s a frame", "",
             "| trip | days | coasting vs integrated, apart | distance | coasting | "
             "integrated (Gauss-Radau) |", "|---|---|---|---|---|---|"]
    for t in r["trips"]:
        lines.append(f"| {t['trip']} | {t['days']:.1f} | {t['apart_m'] / 1e3:,.0f} km | "
                     f"{t['distance_m'] / 1e3:,.0f} km | {t['coasting_s'] * 1e3:.1f} ms | "
                     f"{t['integrated_s'] * 1e3:.1f} ms |")
    f = r.get("free_return")
    if f:
        c, g = f["coasting"], f["integrated"]
        lines += ["", f"lunar free return (found coasting: {f['speed']:.4f} of the escape "
                      f"speed, the Moon {f['lead']:+.3f} rad ahead): back at perigee "
                      f"{c['perigee_m'] / 1e3:,.0f} km from the Earth's centre on day "
                      f"{c['perigee_day']:.2f} coasting ({c['s'] * 1e3:.0f} ms), "
                      f"{g['perigee_m'] / 1e3:,.0f} km on day {g['perigee_day']:.2f} "
                      f"integrated ({g['s'] * 1e3:.0f} ms); up to "
                      f"{f['apart_m'] / 1e3:,.0f} km apart by then"]
    return "\n".join(lines)
