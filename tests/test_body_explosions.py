"""explosion= on add_body, add_bodies and set_body (issue 43, item 4): any body, not only
ships and missiles, can break into debris when a collision or a detonation destroys it; the
same debris every run, through from_state and a recorded replay; bad input named."""
import numpy as np
import pytest

import spacephys as sp

BOOM = sp.ExplosionSpec(count=5, speed=3.0, lifetime=1.0)


def _field(dim=2, record=None):
    """Three asteroids (the first by add_body, two by add_bodies, all with BOOM; the third's
    cleared by set_body) and a gun that shoots each with a missile."""
    w = sp.World(dim, gravity="none", dt=0.01, seed=4)
    log = None if record is None else w.record(record)
    w.set_collision("missile", "asteroid", "destroy_both")
    at = lambda x, y: np.r_[x, y, np.zeros(dim - 2)]
    rock = w.add_body(10.0, at(10, 0), radius=2, kind="asteroid", explosion=BOOM)
    rocks = w.add_bodies(10.0, [at(10, 10), at(10, -10)], radius=2, kind="asteroid",
                         explosion=BOOM)
    w.set_body(int(rocks[1]), explosion=False)
    gun = w.add_body(1.0, at(0, 0), radius=1)
    for y in (0.0, 10.0, -10.0):
        aim = np.arctan2(y, 10.0) if dim == 2 else at(10.0, y) / np.hypot(10.0, y)
        w.launch(gun, sp.MissileSpec(mass=0.1, radius=0.5, launch_speed=20.0), heading=aim)
    return w, log, [rock, *rocks.tolist()]


@pytest.mark.parametrize("dim", [2, 3])
def test_an_asteroid_breaks_into_its_debris_when_destroyed(dim):
    w, _, rocks = _field(dim)
    w.step(100)
    assert not any(r in w for r in rocks)
    kinds = [w.kinds[k] for k in w.kind]
    assert kinds.count("debris") == 2 * BOOM.count and kinds.count("body") == 1
    again, _, _ = _field(dim)
    again.step(100)
    assert again.digest() == w.digest()                # the same debris, bit for bit


def test_explosions_survive_state_files_and_replay(tmp_path):
    w, log, rocks = _field(record=tmp_path / "run.h5")
    loaded = sp.World.from_state(w.state())
    w.step(100)
    loaded.step(100)
    assert loaded.digest() == w.digest()
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok


@pytest.mark.parametrize("call, message", [
    (lambda w, b: w.add_body(1.0, (0.0, 0.0), explosion=3), "explosion = 3"),
    (lambda w, b: w.add_bodies(1.0, [(0.0, 0.0)], explosion="big"), "explosion = 'big'"),
    (lambda w, b: w.set_body(b, explosion=True), "explosion = True.*or False for none"),
    (lambda w, b: w.set_body(b, mass=-1.0, explosion=BOOM), "mass"),
])
def test_bad_explosions_are_named_and_nothing_changes(call, message):
    w = sp.World(2, gravity="none")
    body = w.add_body(1.0, (5.0, 0.0))
    before, columns = w.digest(), set(w._b.columns)
    with pytest.raises(ValueError, match=message):
        call(w, body)
    assert w.digest() == before and set(w._b.columns) == columns
