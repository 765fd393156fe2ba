"""Who is `a` and who is `b` in each kind of event, as docs/guide/collisions.md's table says
(destroy_both's two destroy events included)."""
import spacephys as sp

HIT = dict(radius=1.0)


def _kinds_ab(w, steps=200):
    out = []
    for _ in range(steps):
        w.step(1)
        out += [(sp.EVENT_KINDS[int(e["kind"])], int(e["a"]), int(e["b"])) for e in w.events]
    return out


def _pair(response, masses=(1.0, 2.0), **options):
    """Two bodies of kind "body" (ids 0 and 1) meeting head on under `response`."""
    w = sp.World(2, gravity="none", dt=0.01)
    w.set_collision("body", "body", response, **options)
    w.add_body(masses[0], (0.0, 0.0), (1.0, 0.0), **HIT)
    w.add_body(masses[1], (3.0, 0.0), (-1.0, 0.0), **HIT)
    return _kinds_ab(w)


def test_pairs_destroys_and_merges():
    assert _pair("bounce", restitution=0.5) == [("bounce", 0, 1)]
    assert _pair("sensor")[:1] == [("sensor_begin", 0, 1)]
    assert _pair("destroy_a") == [("destroy", 0, 1)]
    assert _pair("destroy_b") == [("destroy", 1, 0)]
    assert _pair("destroy_both") == [("destroy", 0, 1), ("destroy", 1, 0)]   # one each
    assert _pair("break_b") == [("bounce", 0, 1), ("destroy", 1, 0)]
    assert _pair("merge") == [("merge", 1, 0)]                 # the heavier remains
    assert _pair("merge", masses=(2.0, 1.0)) == [("merge", 0, 1)]


def test_walls_and_the_actors_events():
    w = sp.World(2, gravity="none", dt=0.01)
    w.add_plane((2.0, 0.0), (-1.0, 0.0))
    w.add_body(1.0, (0.0, 0.0), (1.0, 0.0), radius=0.5)
    assert _kinds_ab(w)[:1] == [("wall", 0, -1)]
    w = sp.World(2, gravity="none", dt=0.01)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=1.0), (0.0, 0.0), heading=0.0)
    prey = w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=1.0), (10.0, 0.0))
    missile = w.launch(ship, sp.MissileSpec(mass=0.1, fuel_mass=0.01, thrust=1.0,
                                            exhaust_speed=10.0, radius=0.5,
                                            launch_speed=10.0, fuse_radius=2.0,
                                            burn_time=0.05), heading=0.0, target=prey)
    assert _kinds_ab(w) == [("launch", missile, ship), ("burnout", missile, -1),
                            ("detonation", missile, prey)]


def test_events_name_their_bodies_kinds_and_tags_even_once_they_are_gone():
    """Each event carries kind_a/kind_b (codes; -1 no body) and tag_a/tag_b (w.tags; 0
    none), read while the bodies lived: both of destroy_both's, a merge's body merged
    away, a wall's missing b; a launch's missile and its launcher (tagged by set_body)."""
    w = sp.World(2, gravity="none", dt=0.01)
    w.set_collision("body", "asteroid", "destroy_both")
    w.set_collision("asteroid", "asteroid", "merge")
    rock = w.kinds.index("asteroid")
    body = w.add_body(1.0, (0.0, 0.0), (1.0, 0.0), radius=1.0, tag=11)
    target = w.add_body(1.0, (3.0, 0.0), (-1.0, 0.0), radius=1.0, kind="asteroid", tag=-22)
    big, small = w.add_bodies([2.0, 1.0], [(0.0, 10.0), (3.0, 10.0)],
                              [(1.0, 0.0), (-1.0, 0.0)], radius=1.0, kind="asteroid",
                              tag=[5, 6])
    w.add_plane((0.0, -5.0), (0.0, 1.0))
    faller = w.add_body(1.0, (0.0, -3.0), (0.0, -1.0), radius=0.5)
    w.step(200)
    e = w.events
    got = {(sp.EVENT_KINDS[int(r["kind"])], int(r["a"])): (int(r["kind_a"]), int(r["kind_b"]),
                                                           int(r["tag_a"]), int(r["tag_b"]))
           for r in e}
    assert got[("destroy", body)] == (0, rock, 11, -22)
    assert got[("destroy", target)] == (rock, 0, -22, 11)
    assert got[("merge", big)] == (rock, rock, 5, 6)          # small is gone, its tag kept
    assert got[("wall", faller)] == (0, -1, 0, 0)
    assert small not in w and list(w.tags) == [5, 0]
    w = sp.World(2, gravity="none", dt=0.01)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=1.0), (0.0, 0.0), heading=0.0)
    w.set_body(ship, tag=7)
    missile = w.launch(ship, sp.MissileSpec(mass=0.1, radius=0.5, launch_speed=1.0))
    w.step(1)
    launch = w.events[0]
    assert (int(launch["a"]), int(launch["b"])) == (missile, ship)
    assert (int(launch["kind_a"]), int(launch["kind_b"])) == \
        (w.kinds.index("missile"), w.kinds.index("ship"))
    assert (int(launch["tag_a"]), int(launch["tag_b"])) == (0, 7)


def test_events_of_an_earlier_format_read_with_unknown_bodies():
    """sp.events.upgrade: events written before kinds and tags were fields (state files,
    run logs) read with kinds -1 and tags 0, every other field kept."""
    import numpy as np
    old_dtype = np.dtype([(n, sp.EVENT_DTYPE[n]) for n in sp.events.FIRST_FIELDS])
    old = np.zeros(2, old_dtype)
    old["kind"], old["a"], old["b"], old["speed"] = 3, [4, 5], [5, 4], 2.5
    new = sp.events.upgrade(old)
    assert new.dtype == sp.EVENT_DTYPE
    assert new["a"].tolist() == [4, 5] and new["speed"].tolist() == [2.5, 2.5]
    assert new["kind_a"].tolist() == [-1, -1] and new["tag_b"].tolist() == [0, 0]
    assert sp.events.upgrade(new) is not None and sp.events.upgrade(new).dtype == new.dtype
