"""Bodies stored in space order (spacephys/space_order.py): a World that puts its rows in
Morton order every few steps reaches, body by body, the same bits, the same events and the
same pairs in touch as one that never does; a restored World sorts where the original did;
scenes whose results hang on rows are never sorted. The thresholds are lowered here (the
default sorts only scenes of 5e4 bodies and more) so that small scenes are sorted often."""
import numpy as np
import pytest

import spacephys as sp
from spacephys import space_order


def _field(seed, dim, boundary, gravity="none", blast=None):
    """A few hundred bodies of three kinds in a box, a quarter of it covered, every response
    that moves, merges, destroys or only reports: many contacts at one time (overlaps at the
    start), chains of merges, bodies removed and added between steps (rows moved); blast:
    the ice's explosion, if any."""
    rng = np.random.default_rng(seed)
    n = 400
    r = rng.uniform(0.3, 1.2, n)
    side = float((np.pi * (r ** 2).sum() / 0.25) ** 0.5) if dim == 2 else \
        float((4.0 / 3.0 * np.pi * (r ** 3).sum() / 0.08) ** (1.0 / 3.0))
    kw = {"g": (0.0,) * (dim - 1) + (-0.5,)} if gravity == "uniform" else {}
    w = sp.World(dim=dim, gravity=gravity, dt=0.02, seed=seed, **kw)
    for kind in ("rock", "ice", "zone"):
        w.add_kind(kind)
    w.set_collision("rock", "rock", "elastic")
    w.set_collision("rock", "ice", "merge")
    w.set_collision("ice", "ice", "bounce", restitution=0.5)
    w.set_collision("zone", "rock", "sensor")
    w.set_collision("zone", "ice", "destroy_b")
    w.set_collision("zone", "zone", "bounce", restitution=0.8)
    w.set_boundary(boundary, lo=(0.0,) * dim, hi=(side,) * dim)
    kinds = np.array(["rock", "ice", "zone"])[rng.integers(0, 3, n)]
    for kind in ("rock", "ice", "zone"):
        k = kinds == kind
        w.add_bodies(r[k] ** 2, rng.uniform(1.0, side - 1.0, (k.sum(), dim)),
                     rng.normal(scale=3.0, size=(k.sum(), dim)), radius=r[k], kind=kind,
                     explosion=blast if kind == "ice" else None)
    return w, rng


def _run(w, rng, calls):
    """Step w in calls of 1..9 steps, removing and adding a body now and then; returns
    everything a user can see, by id: events, bodies, pairs in touch."""
    seen = []
    for c in range(calls):
        w.step(int(rng.integers(1, 10)))
        seen += [tuple(e.tolist()) for e in w.events]
        if c % 5 == 2:
            w.remove(np.unique(np.sort(w.ids)[rng.integers(0, w.n, 3)]))   # (by id)
            for _ in range(len(w.state()["bodies"]["free"])):   # every slot freed, reused
                w.add_body(0.5, rng.uniform(1.0, 5.0, w.dim), radius=0.4, kind="rock")
    by_id = np.argsort(w.ids)
    bodies = {name: getattr(w, name)[by_id].copy() for name in ("ids", "pos", "vel", "mass",
                                                                  "radius")}
    return seen, bodies, w.state()["collisions"]["touching"]


def _both(monkeypatch, build, calls=40):
    """(sorted run, unsorted run, the sorted World's rows moved): build() stepped with rows
    sorted every 3 steps, then never."""
    monkeypatch.setattr(space_order, "MIN_BODIES", 0)
    monkeypatch.setattr(space_order, "EVERY", 3)
    w, rng = build()
    ids_before = w.ids.copy()
    sorted_run = _run(w, rng, calls)
    moved = not np.array_equal(w.ids[:len(ids_before)], ids_before)
    monkeypatch.setattr(space_order, "MIN_BODIES", 10 ** 9)
    w, rng = build()
    return sorted_run, _run(w, rng, calls), moved


@pytest.mark.parametrize("dim, boundary, gravity", [(2, "reflect", "none"),
                                                    (3, "periodic", "uniform")])
def test_sorting_the_rows_changes_no_bit_of_any_body_event_or_pair_in_touch(
        monkeypatch, dim, boundary, gravity):
    (events, bodies, touching), (events0, bodies0, touching0), moved = _both(
        monkeypatch, lambda: _field(7, dim, boundary, gravity))
    assert moved                                   # the rows were put in another order
    kinds = {e[0] for e in events0}
    assert len(events0) > 100 and len(kinds) >= 4, kinds      # contacts of every sort
    assert events == events0
    for name in bodies0:
        assert np.array_equal(bodies[name], bodies0[name]), name
    assert len(touching0) > 0 and np.array_equal(touching, touching0)


def test_the_bodies_dying_in_a_step_explode_in_the_order_of_their_ids(monkeypatch):
    """Ice bodies destroyed by zones throw out debris (with lifetimes: from then on the scene
    has actors and is no longer sorted); the debris, their ids and all else are the same."""
    blast = sp.ExplosionSpec(count=6, speed=2.0, lifetime=5.0, radius=0.05)
    (events, bodies, _), (events0, bodies0, _), moved = _both(
        monkeypatch, lambda: _field(11, 2, "reflect", blast=blast), calls=6)
    assert moved
    assert len(bodies0["ids"]) > 400                # debris thrown out
    assert events == events0
    for name in bodies0:
        assert np.array_equal(bodies[name], bodies0[name]), name


def test_a_restored_world_sorts_where_the_original_did(monkeypatch):
    monkeypatch.setattr(space_order, "MIN_BODIES", 0)
    monkeypatch.setattr(space_order, "EVERY", 4)
    w, _ = _field(3, 2, "reflect")
    w.step(8)
    snap = w.snapshot()
    w.step(6)
    after = w.digest()
    w.restore(snap)
    w.step(6)
    assert w.digest() == after
    copy = sp.World.from_state(w.state())         # at step 14: the next sort at 16
    w.step(5)
    copy.step(5)
    assert copy.digest() == w.digest()


@pytest.mark.parametrize("gravity, integrator, sorts", [("direct", "leapfrog", False),
                                                         ("none", "gauss_radau", False),
                                                         ("none", "rk4", True)])
def test_scenes_whose_results_hang_on_rows_keep_their_rows(monkeypatch, gravity, integrator,
                                                           sorts):
    """Direct gravity sums over bodies in row order and Gauss-Radau carries its state in
    it: never sorted; the same scene with neither is."""
    rows = []
    for least in (0, 10 ** 9):
        monkeypatch.setattr(space_order, "MIN_BODIES", least)
        monkeypatch.setattr(space_order, "EVERY", 1)
        w, _ = _field(5, 2, "reflect", gravity)
        w.integrator = integrator
        w.step(3)
        rows.append(w.ids.copy())
    assert np.array_equal(*rows) != sorts


def test_the_order_is_morton_order_by_position_then_id():
    pos = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0]])
    ids = np.array([9, 1, 2, 3, 4])
    # Z-order over the unit square: (0,0), (1,0), (0,1), (1,1); the two at (0,0) by id
    assert space_order.order(pos, ids).tolist() == [4, 0, 3, 2, 1]
    pos[2, 0] = np.nan
    assert space_order.order(pos, ids) is None
