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
