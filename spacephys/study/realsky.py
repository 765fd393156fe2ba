"""The real sky: the Sun, the eight planets and the Moon started from JPL's DE421 at
2000 January 1.5 (TDB), integrated for ten years with Gauss-Radau as Newtonian point masses,
then with general relativity's first post-Newtonian correction for the Sun
(spacephys.userforces.gr), and each body's distance from DE421's place, year by year. What
the rest of DE421's model adds (the asteroids, the Moon's and the Earth's figures, tides)
is what remains.

The masses are DE421's (GM in km^3/s^2: Folkner, Williams & Boggs 2008, "The Planetary and
Lunar Ephemeris DE 421", JPL IOM 343R-08-003), the Earth and the Moon from the Earth-Moon
barycentre's GM and their mass ratio.
"""
import numpy as np

from ..ephemeris import J2000, de421_path

# GM [km^3/s^2] of DE421
GM = {"sun": 132712440040.944, "mercury": 22032.09, "venus": 324858.592,
      "mars": 42828.375214, "jupiter": 126712764.8, "saturn": 37940585.2,
      "uranus": 5794548.6, "neptune": 6836535.0}
GM_EARTH_MOON = 403503.235502
EARTH_MOON_RATIO = 81.30056907419062
C_KM_S = 299792.458                                    # the speed of light [km/s]
BODIES = ("sun", "mercury", "venus", "earth", "moon", "mars", "jupiter", "saturn", "uranus",
          "neptune")
HEADER = """# The real sky: the Solar System against DE421

Regenerate with `spacephys validate --real-sky --markdown docs/realsky.md`. The Sun, the
eight planets (Mars and the outer planets as their systems' barycentres) and the Moon start
from JPL's DE421 at 2000 January 1.5 TDB with DE421's masses and are integrated for ten
years with Gauss-Radau (default tolerance, dt = 1 day), as Newtonian point masses and then
with general relativity's first post-Newtonian correction for the Sun
(`spacephys.userforces.gr`); each body's distance from DE421's place after one and ten
years. What remains with the correction is the rest of DE421's model: the asteroids
(several km for every body: the Sun itself is 6 km off), and for the Moon the Earth's and
the Moon's figures and tides.

"""


def _mass(name):
    if name == "earth":
        return GM_EARTH_MOON * EARTH_MOON_RATIO / (1.0 + EARTH_MOON_RATIO)
    if name == "moon":
        return GM_EARTH_MOON / (1.0 + EARTH_MOON_RATIO)
    return GM[name]


def _perihelion(sun_pos, sun_vel, pos, vel):
    """Mercury's longitude of perihelion (Omega + omega) [rad] about the Sun."""
    from ..orbits import state_to_elements
    el = state_to_elements(GM["sun"] + GM["mercury"], pos - sun_pos, vel - sun_vel)
    return el.Omega + el.omega


def realsky(years=10, relativity=True, dt_days=1.0):
    """({body: (years,) distances [km] from DE421 at the end of each year}, Mercury's
    perihelion turned ahead of DE421's at the end [arcsec]); relativity: add
    userforces.gr for the Sun."""
    from ..ephemeris import Ephemeris
    from ..userforces import gr
    from ..world import World
    span = 365.25 * years
    eph = Ephemeris.from_spk(de421_path(), list(BODIES), start=J2000, end=J2000 + span + 1)
    w = World(3, G=1.0, integrator="gauss_radau", dt=dt_days * 86400.0)
    ids = {}
    for name in BODIES:
        code = eph.ids[BODIES.index(name)]
        p, v = eph.state(code, 0.0)
        ids[name] = w.add_body(_mass(name), p, v)
    if relativity:
        w.add_force(gr, [ids["sun"], GM["sun"], C_KM_S])
    out = {name: [] for name in BODIES}
    per_year = round(365.25 / dt_days)
    for _ in range(years):
        w.step(per_year)
        for k, name in enumerate(BODIES):
            want, _ = eph.state(eph.ids[k], w.t)
            out[name].append(float(np.linalg.norm(w.pos[w.index_of(ids[name])] - want)))
    sun, mercury = BODIES.index("sun"), BODIES.index("mercury")
    ours = _perihelion(w.pos[w.index_of(ids["sun"])],
                       w.vel[w.index_of(ids["sun"])], w.pos[w.index_of(ids["mercury"])],
                       w.vel[w.index_of(ids["mercury"])])
    theirs = _perihelion(*eph.state(eph.ids[sun], w.t),
                         *eph.state(eph.ids[mercury], w.t))
    turned = (ours - theirs + np.pi) % (2 * np.pi) - np.pi
    return {name: np.array(d) for name, d in out.items()}, float(np.degrees(turned) * 3600)


def format_realsky(newton, einstein):
    """A markdown table: each body's distance from DE421 after 1 and 10 years, both ways
    (realsky's first results)."""
    lines = ["| body | Newton, 1 year | Newton, 10 years | + GR (Sun), 1 year | "
             "+ GR (Sun), 10 years |", "|---|---|---|---|---|"]
    for name in BODIES:
        a, b = newton[name], einstein[name]
        lines.append(f"| {name} | {a[0]:.3g} km | {a[-1]:.3g} km | {b[0]:.3g} km | "
                     f"{b[-1]:.3g} km |")
    return "\n".join(lines)
