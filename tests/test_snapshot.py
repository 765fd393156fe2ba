"""World.snapshot(), restore() and digest() (worldstate.Snapshot, worldstate.digest,
kernels/digest.py): back to every bit, then on as if it had never left."""
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

import spacephys as sp
from spacephys import events as ev

sys.path.insert(0, os.path.dirname(__file__))
from test_fuzz_world import _same as _same_state  # noqa: E402  (bit for bit, NaN = NaN)

ALL = list(sp.INTEGRATORS)
HULL = sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=30.0, exhaust_speed=300.0,
                   turn_rate=3.0, radius=2.0,
                   explosion=sp.ExplosionSpec(count=12, speed=20.0, lifetime=0.4,
                                              lifetime_spread=0.5))
TORPEDO = sp.MissileSpec(mass=0.01, fuel_mass=0.01, thrust=1.0, exhaust_speed=100.0,
                         launch_speed=80.0, lifetime=1.0, radius=1.0, arming_delay=0.05,
                         guidance="pursuit",
                         explosion=sp.ExplosionSpec(count=5, speed=10.0, lifetime=0.3))


def _duel(integrator="leapfrog", dim=2):
    """Two ships about a star (fixed for the families that hold bodies fixed), torpedoes
    destroying what they hit, debris from every ship or torpedo destroyed; the ships come
    back (new ids) when destroyed."""
    w = sp.World(dim, dt=1 / 60, seed=3, integrator=integrator)
    fixed = w.stepper.capabilities.fixed_bodies and integrator != "gauss_radau"
    w.add_body(2e5, np.zeros(dim), radius=8.0, kind="star", fixed=fixed)
    for a, b in (("missile", "ship"), ("ship", "ship"), ("missile", "missile")):
        w.set_collision(a, b, "destroy_both")
    w.set_collision("*", "star", "destroy_a")
    return w, [w.add_ship(HULL, *_start(dim, side)) for side in (-1, 1)]


def _start(dim, side):
    """Where a ship starts, or comes back: on a circular orbit, 50 from the other, its
    engine toward it."""
    a = np.pi / 2 + 0.4 * side
    pos, vel = np.zeros(dim), np.zeros(dim)
    pos[:2] = 65.0 * np.cos(a), 65.0 * np.sin(a)
    vel[:2] = 55.5 * -np.sin(a), 55.5 * np.cos(a)
    return pos, vel, -side * np.eye(dim)[0]


def _inputs(w, ships, frame):
    """Frame `frame`'s scripted inputs: turns, throttles, a torpedo every 7 frames each at
    where the other ship will be."""
    for k, ship in enumerate(ships):
        if ship not in w:
            if frame % 10 == 0:
                ships[k] = w.add_ship(HULL, *_start(w.dim, 2 * k - 1))
            continue
        w.control(ship, throttle=(frame // 5 + k) % 2 * 0.8,
                  turn=0.0 if w.dim == 3 else ((frame // 3 + k) % 3 - 1) * 0.7)
        other = ships[1 - k]
        if frame % 7 == 3 * k and other in w:
            a, b = w.get(ship), w.get(other)
            lead = b.pos + (b.vel - a.vel) * np.linalg.norm(b.pos - a.pos) / 80.0 - a.pos
            w.launch(ship, TORPEDO, target=other, heading=lead)


def _play(w, ships, first, frames):
    """Frames first.. of scripted inputs, 2 steps a frame; the digest after each."""
    out = []
    for frame in range(first, first + frames):
        _inputs(w, ships, frame)
        w.step(2)
        out.append(w.digest())
    return out


class _Game:
    """The World and the ship ids the game keeps (a ship destroyed comes back as a new
    id): a game rolls back both."""

    def __init__(self, w, ships):
        self.w, self.ships = w, ships

    def save(self):
        return self.w.snapshot(), list(self.ships)

    def back(self, saved):
        self.w.restore(saved[0])
        self.ships[:] = saved[1]


@pytest.mark.parametrize("integrator", ALL)
def test_restore_then_step_gives_the_bits_of_never_having_left(integrator):
    w, ships = _duel(integrator)
    game = _Game(w, ships)
    _play(w, ships, 0, 20)
    snap, digest, state = game.save(), w.digest(), w.state()
    ahead = _play(w, ships, 20, 40)
    assert w.digest() != digest
    game.back(snap)
    assert w.digest() == digest
    _same_state(w.state(), state)
    again = _play(w, ships, 20, 40)
    assert again == ahead
    # the same frames never left: the same bits; and they held what the test claims
    # (launches, torpedoes and ships destroyed, debris thrown and expiring)
    played, ships = _duel(integrator)
    seen = []
    for frame in range(60):
        _inputs(played, ships, frame)
        played.step(2)
        seen += played.events["kind"].tolist()
    assert played.digest() == again[-1]
    assert seen.count(ev.LAUNCH) >= 6 and seen.count(ev.DESTROY) >= 8 and \
        seen.count(ev.EXPIRY) >= 20


def test_a_snapshot_restores_as_often_as_asked_and_keeps_the_kernel_tables():
    w, ships = _duel()
    game = _Game(w, ships)
    _play(w, ships, 0, 10)
    snap = game.save()
    tables = w.driver.plan
    first = _play(w, ships, 10, 6)
    for _ in range(3):
        game.back(snap)
        assert w.driver.plan is tables         # the same bodies, settings and arrays
        assert _play(w, ships, 10, 6) == first


def test_restore_after_the_bodies_outgrew_their_arrays():
    w, ships = _duel()
    game = _Game(w, ships)
    _play(w, ships, 0, 4)
    snap, digest = game.save(), w.digest()
    capacity = w.driver.capacity
    ahead = _play(w, ships, 4, 5)
    w.add_bodies(np.ones(3 * capacity), np.random.default_rng(1).uniform(
        500, 900, (3 * capacity, 2)), kind="debris")
    assert w.driver.capacity > capacity
    game.back(snap)
    assert w.digest() == digest and w.driver.capacity == capacity
    assert _play(w, ships, 4, 5) == ahead


@pytest.mark.parametrize("change", [
    lambda w: w.set_collision("ship", "star", "bounce", 0.5),
    lambda w: w.add_kind("station"),
    lambda w: setattr(w, "integrator", "yoshida4"),
    lambda w: setattr(w, "softening", 0.5),
    lambda w: w.add_plane((0.0, -90.0), (0.0, 1.0)),
    lambda w: w.set_boundary("periodic", lo=(-200, -200), hi=(200, 200)),
    lambda w: w.shift_origin((3.0, -4.0)),
    lambda w: setattr(w, "max_substeps", 3),
    lambda w: setattr(w, "drag", 0.1),
    lambda w: setattr(w, "dt", 1 / 60),
    lambda w: w.apply_force(int(w.ids[0]), (0.0, 0.0)),
    lambda w: w.plan([i for i in w.actor_ids if w.is_ship(i)][0],
                     [sp.Burn(start=w.t + 0.1, duration=0.2)]),
], ids=["rule", "kind", "integrator", "softening", "wall", "boundary", "origin",
        "substeps", "drag", "dt", "held force", "burn plan"])
def test_restore_undoes_a_change_of_setting(change):
    w, ships = _duel()
    game = _Game(w, ships)
    _play(w, ships, 0, 10)
    snap, digest, state = game.save(), w.digest(), w.state()
    ahead = _play(w, ships, 10, 10)
    game.back(snap)
    change(w)
    _play(w, ships, 10, 3)
    game.back(snap)
    assert w.digest() == digest
    _same_state(w.state(), state)
    assert _play(w, ships, 10, 10) == ahead


def _back_and_on(w, steps, on):
    """Snapshot w, step it `steps`, restore, step `on` one at a time: the states and every
    step's events equal a copy's stepped from the snapshot. Returns the events' kinds."""
    ref = w.copy()
    snap = w.snapshot()
    w.step(steps)
    w.restore(snap)
    _same_state(w.state(), ref.state())
    kinds = []
    for _ in range(on):
        w.step(1)
        ref.step(1)
        assert w.events.tobytes() == ref.events.tobytes()
        kinds += w.events["kind"].tolist()
    _same_state(w.state(), ref.state(), "then stepped")
    return kinds


def test_a_torpedo_that_armed_and_hit_after_the_snapshot_is_unarmed_again():
    # the torpedo starts touching its ship, which pushes into it: it ignores its launcher
    # until armed (the tables' owners), then both are destroyed (the tables' rows die)
    w = sp.World(2, dt=0.01)
    w.set_collision("missile", "ship", "destroy_both")
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=5.0,
                                  exhaust_speed=100.0, radius=2.0), (0.0, 0.0))
    w.launch(ship, sp.MissileSpec(mass=0.01, radius=1.0, arming_delay=0.1, hits_launcher=True),
             heading=(1, 0))
    w.control(ship, throttle=1.0)
    w.step(2)
    assert _back_and_on(w, 30, 30).count(ev.DESTROY) == 2 and w.n == 0     # one each


def test_an_explosion_spec_added_after_the_snapshot_is_gone_again():
    w, ships = _duel()
    _play(w, ships, 0, 4)
    specs, snap, before = w.state()["actors"]["explosions"], w.snapshot(), w.digest()
    w.set_body(ships[0], explosion=sp.ExplosionSpec(count=5))    # a spec not seen before
    w.restore(snap)
    assert w.state()["actors"]["explosions"] == specs and w.digest() == before


def test_pairs_in_touch_come_back():
    # two sensors overlap at the snapshot and part after it: they part again, once
    w = sp.World(2, dt=0.01)
    w.set_collision("body", "body", "sensor")
    w.add_body(1e-9, (0.0, 0.0), (-1.0, 0.0), radius=1.0)
    w.add_body(1e-9, (1.5, 0.0), (1.0, 0.0), radius=1.0)
    w.step(1)
    assert ev.SENSOR_BEGIN in w.events["kind"]
    kinds = _back_and_on(w, 40, 40)
    assert kinds.count(ev.SENSOR_END) == 1 and ev.SENSOR_BEGIN not in kinds


def test_a_second_restore_after_one_that_laid_the_bodies_out_anew():
    # an explosion gives the bodies lifetime columns (a new layout): the first restore makes
    # a new block in the snapshot's layout, the second writes into that block; neither may
    # hand the kernels the tables taken with the snapshot, which point into the old block
    w = sp.World(2, dt=0.001, softening=0.05)
    w.add_body(10.0, (0.0, 0.0), radius=0.5)
    rock = w.add_body(0.5, (3.0, 0.0), (0.0, 1.5), radius=0.1)
    w.step(1)
    ref = w.copy()
    snap = w.snapshot()
    w.explode(rock, sp.ExplosionSpec(count=3, speed=1.0, lifetime=1.0))
    for _ in range(2):
        w.restore(snap)
        _same_state(w.state(), ref.state())
        w.step(3)
    ref.step(3)
    _same_state(w.state(), ref.state(), "restored twice, stepped")


def test_gauss_radau_carries_its_polynomials_through_a_restore():
    w = sp.World(2, integrator="gauss_radau", tolerance=1e-10)
    w.add_body(1.0, (0.0, 0.0))
    w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    w.add_body(0.0, (0.0, 1.5), (-0.8, 0.0))
    w.step(7)
    snap = w.snapshot()
    w.step(9)
    ahead, stats = w.state(), w.integrator_stats
    w.restore(snap)
    w.step(9)
    _same_state(w.state(), ahead)
    assert w.integrator_stats == stats


def test_restore_to_before_the_integrator_kept_columns():
    # Gauss-Radau's per-body polynomials are columns the bodies gain at its first step; a
    # snapshot from before has none, and they come back zero, not as the later step left them
    w = sp.World(2, dt=0.001, softening=0.05, integrator="gauss_radau")
    w.add_body(10.0, (0.0, 0.0), radius=0.5)
    w.add_body(0.3, (-3.0, 7.0), (0.6, -0.5), radius=0.1)
    _back_and_on(w, 60, 5)


def test_the_events_of_the_last_call_come_back():
    w, ships = _duel()
    _play(w, ships, 0, 4)
    _inputs(w, ships, 7)                     # launches: reported with the next step
    w.step(1)
    events = w.events
    assert ev.LAUNCH in events["kind"]
    snap = w.snapshot()
    w.step(3)
    w.restore(snap)
    assert w.events.tobytes() == events.tobytes()


def test_launches_waiting_for_the_next_step_come_back():
    w, ships = _duel()
    w.step(1)
    snap0 = w.snapshot()
    m = w.launch(ships[0], TORPEDO, target=ships[1])
    snap = w.snapshot()
    w.step(2)
    kinds = w.events["kind"].tolist()
    w.restore(snap)
    w.step(2)
    assert w.events["kind"].tolist() == kinds and ev.LAUNCH in kinds
    w.restore(snap0)
    assert m not in w
    w.step(2)
    assert ev.LAUNCH not in w.events["kind"]


# ----------------------------------------------------------------------------- digest

def test_equal_states_have_equal_digests_whatever_brought_them_there(tmp_path):
    w, ships = _duel()
    _play(w, ships, 0, 30)
    d = w.digest()
    assert sp.World.from_state(w.state()).digest() == d
    w.save(tmp_path / "duel.h5")               # (a file lists the columns in its own order)
    assert sp.World.load(tmp_path / "duel.h5").digest() == d
    assert w.copy().digest() == d
    assert pickle.loads(pickle.dumps(w)).digest() == d
    assert w.digest() == d and 0 <= d < 2 ** 64


def test_the_digest_of_what_moves_is_not_frozen_with_the_settings():
    # the settings are taken once, with the first snapshot after a change: the pairs in
    # touch and the wind move on, and the digest must follow them, as a fresh World's does
    w = sp.World(2, dt=0.01, drag=0.1)
    w.set_collision("body", "body", "sensor")
    w.add_body(1e-9, (0.0, 0.0), (1.0, 0.0), radius=1.0)
    w.add_body(1e-9, (3.0, 0.0), radius=1.0)
    w.snapshot()
    w.wind = (0.5, 0.0)
    w.step(150)                                  # they meet: a pair in touch
    assert len(w.state()["collisions"]["touching"]) == 1
    assert w.digest() == sp.World.from_state(w.state()).digest()


def test_a_digest_is_the_same_in_another_process():
    code = ("import sys; sys.path.insert(0, %r); import test_snapshot as t; "
            "w, s = t._duel(); t._play(w, s, 0, 12); print(w.digest())"
            % os.path.dirname(__file__))
    env = dict(os.environ, PYTHONHASHSEED="12345")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True)
    w, ships = _duel()
    _play(w, ships, 0, 12)
    assert int(out.stdout.split()[-1]) == w.digest()


@pytest.mark.parametrize("where", ["pos", "vel", "mass", "kind", "fuel", "generation",
                                   "t", "touch", "setting", "queued", "curves", "specs"])
def test_one_changed_bit_changes_the_digest(where):
    w, ships = _duel()
    _play(w, ships, 0, 8)
    d = w.digest()
    b = w._b
    if where in ("pos", "vel", "mass", "fuel"):
        getattr(b, where).view(np.uint64).reshape(b.capacity, -1)[b.n - 1, 0] ^= 1
    elif where == "kind":
        b.kind[0] ^= 1
    elif where == "generation":
        b.generation[0] ^= 1
    elif where == "t":
        w._t_base = np.nextafter(w._t_base, 1.0)
    elif where == "touch":
        w.restore(w.snapshot())
        w._collisions.set_touching(np.array([[int(ships[0]), int(ships[1]), 0]]))
    elif where == "setting":
        w.set_collision("debris", "debris", "merge")
    elif where == "curves":                  # replaced after their bytes were kept
        w._actors.curves = np.vstack([w._actors.curves, [[1.0, 0.5]]])
    elif where == "specs":                   # grown after their bytes were kept
        w._actors.specs.append(sp.ExplosionSpec(count=3))
    else:
        w.launch(ships[0], TORPEDO, target=ships[1])
        d = w.digest()                       # the launch event waits for the next step
        w._actors.queued[0]["time"] = np.nextafter(w._actors.queued[0]["time"], 1.0)
    assert w.digest() != d


def _hash_words(words):
    """kernels/digest.rows of one span holding `words` ((W,) uint64)."""
    from spacephys.kernels import digest as kd
    return int(kd.rows(np.uint64(7), words, np.zeros(1, np.int64),
                       np.array([8 * words.size], np.int64), 1, 0, 0, 0,
                       np.zeros(0, np.int64)))


def test_the_hash_sees_every_bit_of_every_word_and_every_place():
    """Each bit of each word of three blocks and a part (the last one alone in a block), and
    two words swapped within a block; a word whose high half keys to zero (its product is 0
    whatever the low half) still counts by itself."""
    from spacephys.kernels import digest as kd
    words = np.random.default_rng(1).integers(0, 2**63, 3 * kd.BLOCK + 1,
                                              dtype=np.int64).view(np.uint64)
    base = _hash_words(words)
    seen = {base}
    for j in range(words.size):
        for bit in range(64):
            flipped = words.copy()
            flipped[j] ^= np.uint64(1 << bit)
            seen.add(_hash_words(flipped))
    assert len(seen) == 1 + 64 * words.size
    swapped = words.copy()
    swapped[[3, 40]] = words[[40, 3]]
    assert _hash_words(swapped) != base
    zero_high = words.copy()
    zero_high[5] = kd.KEY[5] & np.uint64(0xFFFFFFFF00000000)
    flipped = zero_high.copy()
    flipped[5] ^= np.uint64(1)
    assert _hash_words(flipped) != _hash_words(zero_high)


def test_the_rows_past_the_live_bodies_are_not_part_of_the_digest():
    w, ships = _duel()
    _play(w, ships, 0, 8)
    d = w.digest()
    b = w._b
    b.pos[b.n:] = 12345.0                    # rows no body holds
    b.block[-8:] = 255
    assert w.digest() == d


# ----------------------------------------------------------------------------- refusals

def test_a_snapshot_of_another_world_is_refused_and_nothing_changes():
    w, ships = _duel()
    _play(w, ships, 0, 5)
    other = w.copy()
    snap = other.snapshot()
    d = w.digest()
    with pytest.raises(ValueError, match="another World"):
        w.restore(snap)
    assert w.digest() == d
    with pytest.raises(ValueError, match="World.snapshot"):
        w.restore(w.state())


def test_a_snapshot_of_another_version_is_refused():
    w, _ = _duel()
    snap = w.snapshot()
    snap.version = "0.0.1"
    w.step(1)
    d = w.digest()
    with pytest.raises(ValueError, match="spacephys 0.0.1"):
        w.restore(snap)
    assert w.digest() == d


def test_a_recorded_world_refuses_a_restore(tmp_path):
    w, ships = _duel()
    snap = w.snapshot()
    with w.record(tmp_path / "run.h5"):
        _play(w, ships, 0, 3)
        d = w.digest()
        with pytest.raises(ValueError, match="being recorded"):
            w.restore(snap)
        assert w.digest() == d


def test_a_snapshot_is_not_a_file_format():
    w, _ = _duel()
    with pytest.raises(TypeError, match="World.state"):
        pickle.dumps(w.snapshot())


@pytest.mark.parametrize("first", [False, True])
def test_a_restore_keeps_the_shapes_added_since_the_setup_was_taken(first):
    """A snapshot taken after a compound body brought a new shape restores that shape's
    entry in the shape table, even when a setting changed in between (the restore then puts
    the snapshot's setup back: it once held the table as the first snapshot found it, and
    the body's shape named an entry past its end)."""
    two = sp.Circles([[0.5, 0.0], [-0.5, 0.0]], [0.4, 0.6])
    other = sp.Circles([[0.3, 0.0], [-0.3, 0.0]], [0.2, 0.7])
    w = sp.World(2, gravity="none", dt=0.1)
    if first:
        w.add_body(1.0, [0.0, 0.0], shape=two)
    w.snapshot()                               # takes the setup (the shape table so far)
    b = w.add_body(1.0, [5.0, 0.0], shape=other)   # a new shape in the table
    snap = w.snapshot()
    ids, k, centres, radii = w.circles()
    digest = w.digest()
    w.set_boundary("periodic", [-10.0, -10.0], [10.0, 10.0])   # a setting changes
    w.restore(snap)
    assert w.shape(b) == other
    got = w.circles()
    for a, want in zip(got, (ids, k, centres, radii)):
        np.testing.assert_array_equal(a, want)
    assert w.digest() == digest
    assert w.query_radius([[5.0, 0.0]], 1.0).ids.tolist() == [b]
    w.step(1)                                  # the collision tables build from it too


def test_a_restore_undoes_rails_put_on_after_the_setup_was_taken():
    """Rails are part of the setup snapshots share: putting a body on rails (or taking it
    off) makes the next snapshot take the setup again, so that a restore to a snapshot from
    before undoes it (it once kept the rails: the World then moved as no copy from that
    snapshot did), and the digest tells the two apart."""
    w = sp.World(2)
    star = w.add_body(100.0, [0.0, 0.0])
    moon = w.add_body(0.01, [5.0, 0.0], [0.0, 4.5])
    before, d0, c0 = w.snapshot(), w.digest(), w.copy()
    w.set_rails(moon, star)
    assert w.digest() != d0
    on, d1 = w.snapshot(), w.digest()
    w.set_collision("body", "body", "ignore")              # a setting changes too
    w.restore(on)
    assert w.rails["id"].tolist() == [moon] and w.digest() == d1
    w.step(10)
    w.restore(before)
    assert w.rails["id"].tolist() == [] and w.digest() == d0
    w.step(100)
    c0.step(100)
    assert np.array_equal(w.pos, c0.pos) and np.array_equal(w.vel, c0.vel)
    w.set_rails(moon, star)
    w.snapshot()                                           # the setup with the rails
    w.set_rails(moon, None)                                # off again
    off = w.snapshot()
    w.set_collision("body", "body", "elastic")
    w.restore(off)
    assert w.rails["id"].tolist() == []


def test_a_restore_brings_back_the_rails_a_removed_parent_took_away():
    """A body whose parent is removed leaves its rails when the tables are next built; the
    setup snapshots share then changed, and a restore to a snapshot from before puts the
    rails back (it once kept them dropped: the World moved as no copy did)."""
    w = sp.World(2)
    star = w.add_body(100.0, [0.0, 0.0])
    moon = w.add_body(0.01, [5.0, 0.0], [0.0, 4.5])
    w.set_rails(moon, star)
    w.set_collision("body", "body", "ignore")
    before, d0, c0 = w.snapshot(), w.digest(), w.copy()
    w.remove(star)
    w.step(1)                                              # the moon leaves its rails
    w.restore(before)
    assert w.rails["id"].tolist() == [moon] and w.digest() == d0
    w.step(100)
    c0.step(100)
    assert np.array_equal(w.pos, c0.pos)


def test_a_tether_broken_in_the_last_step_stays_broken_in_a_copy_and_after_a_restore():
    """A tether the kernels broke leaves the setup at once, so that a copy or a snapshot
    taken right after the break does not bring it back (it once did: the flag of the break
    lived only in the kernels' tables, and the rope snapped again)."""
    def broken():
        w = sp.World(2, gravity="none")
        a = w.add_body(1.0, [0.0, 0.0], [-1.0, 0.0])
        b = w.add_body(1.0, [1.0, 0.0], [1.0, 0.0])
        w.tether(a, b, break_force=0.5)                    # pulled apart: breaks at once
        w.step(1)
        return w

    def pulled(w):
        w.set_body(w.ids[0], vel=[-1.0, 0.0])
        w.set_body(w.ids[1], vel=[1.0, 0.0])
        w.step(100)
        return w.pos.copy()

    alone = pulled(broken())
    w = broken()
    c = w.copy()
    s = w.snapshot()
    w.step(10)
    w.restore(s)
    assert alone[1, 0] - alone[0, 0] > 1.5                 # apart: no rope
    assert np.array_equal(pulled(c), alone) and np.array_equal(pulled(w), alone)
