"""Collision groups and a missile's launcher (issue 43, item 2): category, mask and group on
add_body, add_bodies, set_body, ShipSpec, MissileSpec and launch; bodies of one group > 0
never meet; a missile never meets its launcher unless MissileSpec.hits_launcher (then once
armed). In both dimensions, through snapshots, state files and a recorded replay."""
import numpy as np
import pytest

import spacephys as sp
from spacephys import events as ev

HULL = sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=10.0, exhaust_speed=100.0,
                   radius=2.0)
SHELL = sp.MissileSpec(mass=0.1, arming_delay=0.1, radius=0.5)


def _at(dim, *v):
    return np.r_[v, np.zeros(dim - len(v))]


def _run_into_own_missile(dim=2, spec=SHELL, hull=HULL, **launch):
    """A ship launches a motionless missile dead ahead and thrusts into it (it is armed
    by then); missile-ship pairs destroy both. Returns (world, ship, missile, event kinds)."""
    w = sp.World(dim, gravity="none", dt=1 / 60)
    w.set_collision("missile", "ship", "destroy_both")
    ship = w.add_ship(hull, _at(dim, 0.0), heading=0.0 if dim == 2 else _at(3, 1.0))
    missile = w.launch(ship, spec, **launch)
    w.control(ship, throttle=1.0)
    kinds = []
    for _ in range(90):
        w.step(1)
        kinds += w.events["kind"].tolist()
    return w, ship, missile, kinds


@pytest.mark.parametrize("dim", [2, 3])
def test_a_missile_spares_its_launcher_unless_it_may_hit_it(dim):
    w, ship, missile, kinds = _run_into_own_missile(dim)
    assert ship in w and missile in w and ev.DESTROY not in kinds
    w, ship, missile, kinds = _run_into_own_missile(
        dim, sp.MissileSpec(mass=0.1, arming_delay=0.1, radius=0.5, hits_launcher=True))
    assert ship not in w and missile not in w and kinds.count(ev.DESTROY) == 2


@pytest.mark.parametrize("dim", [2, 3])
def test_bodies_of_one_group_never_meet(dim):
    spec = sp.MissileSpec(mass=0.1, arming_delay=0.1, radius=0.5, hits_launcher=True)
    # the ship's group from its spec, the missile's from the launch: the same, spared
    hull = sp.ShipSpec(**{**HULL.__dict__, "group": 7})
    w, ship, missile, kinds = _run_into_own_missile(dim, spec, hull, group=7)
    assert ship in w and missile in w and ev.DESTROY not in kinds
    assert w.group[w.index_of(ship)] == 7 and w.group[w.index_of(missile)] == 7
    # another group: they meet
    w, ship, missile, kinds = _run_into_own_missile(dim, spec, hull, group=8)
    assert ship not in w and missile not in w
    # group 0 is no group: two bodies of group 0 meet as ever
    w = sp.World(dim, gravity="none", dt=0.01)
    w.set_collision("body", "body", "destroy_both")
    a = w.add_body(1.0, _at(dim, 0.0), _at(dim, 1.0), radius=1.0)
    b = w.add_body(1.0, _at(dim, 3.0), _at(dim, -1.0), radius=1.0)
    c, d = w.add_bodies(1.0, [_at(dim, 0.0, 10.0), _at(dim, 3.0, 10.0)],
                        [_at(dim, 1.0), _at(dim, -1.0)], radius=1.0, group=[5, 5])
    w.step(100)
    assert a not in w and b not in w and c in w and d in w
    # set_body moves a body out of its group: now they meet
    w.set_body(d, group=0, vel=_at(dim, -1.0))
    w.set_body(c, vel=_at(dim, 1.0))
    w.step(300)
    assert c not in w and d not in w


def test_launch_sets_the_missiles_bits_and_a_side_filters_as_add_body_does():
    """category/mask per launch: a red missile (category 2) whose mask leaves out red ships
    flies through a red ship and hits a blue one."""
    w = sp.World(2, gravity="none", dt=1 / 60)
    w.set_collision("missile", "ship", "destroy_both")
    RED, BLUE = 2, 4
    gun = w.add_body(1.0, (0.0, 0.0), radius=1.0, kind="body")
    red = w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=1.0, category=RED), (10.0, 0.0))
    blue = w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=1.0, category=BLUE), (20.0, 0.0))
    shot = w.launch(gun, sp.MissileSpec(mass=0.1, radius=0.5, launch_speed=30.0),
                    heading=0.0, category=RED, mask=BLUE)
    assert w.category[w.index_of(shot)] == RED and w.mask[w.index_of(shot)] == BLUE
    w.step(60)
    assert red in w and blue not in w and shot not in w


def test_groups_survive_snapshots_state_files_and_replay(tmp_path):
    spec = sp.MissileSpec(mass=0.1, arming_delay=0.1, radius=0.5, hits_launcher=True)
    w = sp.World(2, gravity="none", dt=1 / 60)
    w.set_collision("missile", "ship", "destroy_both")
    assert "group" not in w._b.columns                    # a scene without groups: no column
    log = w.record(tmp_path / "run.h5")
    ship = w.add_ship(HULL, (0.0, 0.0), heading=0.0)
    snap = w.snapshot()
    w.set_body(ship, group=3)
    missile = w.launch(ship, spec, group=3)
    w.control(ship, throttle=1.0)
    w.step(45)
    loaded = sp.World.from_state(w.state())
    assert loaded.group.tolist() == w.group.tolist() == [3, 3]
    w.step(45)
    loaded.step(45)
    assert ship in w and missile in w and loaded.digest() == w.digest()
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    w2 = sp.World(2, gravity="none", dt=1 / 60)
    w2.set_collision("missile", "ship", "destroy_both")
    s2 = w2.add_ship(HULL, (0.0, 0.0), heading=0.0)
    w2.launch(s2, spec)                                   # no group: the ship is hit
    w2.control(s2, throttle=1.0)
    w2.step(90)
    assert s2 not in w2
    del snap


@pytest.mark.parametrize("dim", [2, 3])
def test_groups_and_tags_come_back_with_snapshots_state_files_and_replays(dim, tmp_path):
    """A snapshot taken before the ship had a group or a tag, one after the launch, a
    state file and a replay, in both dimensions."""
    spec = sp.MissileSpec(mass=0.1, arming_delay=0.1, radius=0.5, hits_launcher=True)

    def scene(record=None):
        w = sp.World(dim, gravity="none", dt=1 / 60)
        w.set_collision("missile", "ship", "destroy_both")
        log = w.record(record) if record else None
        ship = w.add_ship(HULL, (0.0,) * dim, heading=0.0 if dim == 2 else (1.0, 0.0, 0.0))
        return w, ship, log

    def fly(w, ship):
        w.set_body(ship, group=3, tag=7)
        missile = w.launch(ship, spec, group=3)
        w.control(ship, throttle=1.0)
        w.step(45)
        return missile

    w, ship, _ = scene()
    before = w.snapshot()
    missile = fly(w, ship)
    mid = w.snapshot()
    loaded = sp.World.from_state(w.state())
    assert loaded.group.tolist() == w.group.tolist() == [3, 3]
    assert loaded.tags.tolist() == w.tags.tolist() == [7, 0]
    w.step(45)
    after = w.digest()
    assert ship in w and missile in w                     # one group: spared
    loaded.step(45)
    assert loaded.digest() == after
    w.restore(mid)
    assert w.group.tolist() == [3, 3] and w.tags.tolist() == [7, 0]
    w.step(45)
    assert w.digest() == after
    w.restore(before)                                     # no group, no tag, no missile
    assert w.n == 1 and w.group.tolist() == [0] and w.tags.tolist() == [0]
    assert w.digest() == scene()[0].digest()
    recorded, ship, log = scene(tmp_path / "run.h5")
    fly(recorded, ship)
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok


@pytest.mark.parametrize("call, message", [
    (lambda w, s: w.add_body(1.0, (0.0, 0.0), group=-1), "group = -1"),
    (lambda w, s: w.add_body(1.0, (0.0, 0.0), group=1.5), "group = 1.5"),
    (lambda w, s: w.add_bodies(1.0, [(0.0, 0.0), (1.0, 0.0)], group=[1, -2]), "group = -2"),
    (lambda w, s: w.set_body(s, group="a"), "group = 'a'"),
    (lambda w, s: w.launch(s, SHELL, group=-3), "launch: group = -3"),
    (lambda w, s: w.launch(s, SHELL, mask=2 ** 64), "launch: mask = 18446744073709551616"),
    (lambda w, s: sp.ShipSpec(category=True), "ShipSpec category = True"),
    (lambda w, s: sp.MissileSpec(hits_launcher=1), "hits_launcher = 1"),
])
def test_bad_bits_are_named_and_nothing_changes(call, message):
    w = sp.World(2, gravity="none")
    ship = w.add_ship(HULL, (0.0, 0.0), heading=0.0)
    before = w.digest()
    with pytest.raises(ValueError, match=message):
        call(w, ship)
    assert w.digest() == before and w.n == 1
