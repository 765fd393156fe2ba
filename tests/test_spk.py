"""sp.Ephemeris.from_spk: JPL's DE421 (shipped by skyfield-data) read through jplephem, against
jplephem's own evaluation and skyfield's, and flown as rails in a World."""
import os
import warnings

import numpy as np
import pytest

import spacephys as sp

with warnings.catch_warnings():
    warnings.simplefilter("ignore")          # skyfield-data warns of its Earth-rotation file
    from skyfield_data import get_skyfield_data_path
from jplephem.spk import SPK

DE421 = os.path.join(get_skyfield_data_path(), "de421.bsp")
# (name, NAIF id, the segments from the barycentre)
BODIES = [("sun", 10, [(0, 10)]), ("earth", 399, [(0, 3), (3, 399)]),
          ("moon", 301, [(0, 3), (3, 301)]), ("mars", 499, [(0, 4), (4, 499)]),
          ("jupiter", 5, [(0, 5)])]


@pytest.fixture(scope="module")
def de421():
    """The five bodies over 2000-2010, in kilometres and seconds."""
    return sp.Ephemeris.from_spk(DE421, [b[0] for b in BODIES], start=2451545.0 - 30,
                                 end=2451545.0 + 3660)


def test_it_agrees_with_jplephems_own_evaluation(de421):
    kernel = SPK.open(DE421)
    jd = np.linspace(2451545.0 - 29.5, 2451545.0 + 3659.5, 2001)
    try:
        for name, code, chain in BODIES:
            x = sum(kernel[p].compute_and_differentiate(jd)[0] for p in chain).T
            v = sum(kernel[p].compute_and_differentiate(jd)[1] for p in chain).T / 86400.0
            p, u = de421.state(code, de421.time(jd))
            scale = np.sqrt((x ** 2).sum(axis=1)).max()
            assert np.abs(p - x).max() <= 1e-12 * scale, name          # measured 5e-14
            assert np.abs(u - v).max() <= 1e-10 * np.sqrt((v ** 2).sum(axis=1)).max(), name
    finally:
        kernel.close()


def test_it_agrees_with_skyfield(de421):
    from skyfield.api import load, load_file
    planets = load_file(DE421)
    ts = load.timescale(builtin=True)
    jd = np.array([2451545.0, 2453000.25, 2455197.5])
    for name, code, _ in BODIES:
        target = planets["jupiter barycenter" if name == "jupiter" else name]
        want = target.at(ts.tdb_jd(jd)).position.km.T
        got, _ = de421.state(code, de421.time(jd))
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max(), name


def test_units_and_flying_the_real_solar_system():
    """In AU and Julian years: the Earth about 1 AU from the barycentre; a World in those
    units at J2000 flies the Sun, the Earth and the Moon on it."""
    eph = sp.Ephemeris.from_spk(DE421, ["sun", "earth", "moon"], units="au-msun-yr",
                                start=2451545.0, end=2451545.0 + 400)
    x, _ = eph.state(399, eph.time(2451545.0))
    assert 0.98 < np.linalg.norm(x) < 0.99                     # 2000 Jan 1: near perihelion
    w = sp.World(3, units="au-msun-yr", dt=1e-4)
    masses = {10: 1.0, 399: 3.0035e-6, 301: 3.69e-8}
    ids = {}
    for code, m in masses.items():
        p, v = eph.state(code, 0.0)
        ids[code] = w.add_body(m, p, v)
        w.set_rails(ids[code], ephemeris=eph, entry=code)
    probe = w.add_body(0.0, x + (0.01, 0.0, 0.0), eph.state(399, 0.0)[1])
    w.step(1000)
    for code in masses:
        np.testing.assert_allclose(w.pos[w.index_of(ids[code])], eph.state(code, w.t)[0],
                                   rtol=0, atol=1e-15)
    assert np.isfinite(w.pos[w.index_of(probe)]).all()


@pytest.mark.parametrize("call, message", [
    (lambda: sp.Ephemeris.from_spk(DE421, ["vulcan"]), "'vulcan' is not a body name"),
    (lambda: sp.Ephemeris.from_spk(DE421, [606]), "NAIF id 606 is not in"),
    (lambda: sp.Ephemeris.from_spk(DE421, ["earth"], units="game"), "units = 'game'"),
    (lambda: sp.Ephemeris.from_spk(DE421, ["earth"], start=2400000.5), "the file covers"),
])
def test_bad_requests_are_named(call, message):
    with pytest.raises(ValueError, match=message):
        call()
