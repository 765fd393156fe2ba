"""Golden determinism: a SHA-256 of the final state of every integrator on six scenes,
stored in tests/golden.json and checked here, on one and on every thread.

No kernel is compiled with a value-changing fastmath flag and every force sum runs in source
order (spacephys/_jit.py, kernels/pairs.py), so the digests hold for any x86-64 CPU: one set
per numba version (the test extra pins the one they were recorded with). This file checks
them on this machine's CPU; test_cpu_targets.py with kernels compiled for other CPUs.
Record (after a rounding change the commit explains): SPACEPHYS_GOLDEN=record pytest
tests/test_golden.py
"""
import hashlib
import json
import math
import os
from pathlib import Path

import llvmlite.binding as llvm
import numba
import numpy as np
from numpy.lib.recfunctions import repack_fields
import pytest

import spacephys as sp

GOLDEN = Path(__file__).with_name("golden.json")
RECORD = os.environ.get("SPACEPHYS_GOLDEN") == "record"
INTEGRATORS = list(sp.INTEGRATORS)


def fingerprint():
    """What decides the digests besides the code: numba's version (its LLVM's codegen)."""
    return f"numba {numba.__version__}"


# ----------------------------------------------------------------------------- scenes
# Each builds a World, runs it and returns it with every event it saw. Small enough to run
# for all integrators in a few seconds, rich enough that each scene exercises its part of the
# step: the gravity scene crosses _jit.PARALLEL_MIN_PAIRS (its test particles are summed on
# threads), the collision scene merges and bounces, the actor scene launches, detonates,
# explodes and expires.

def World(**settings):
    """A World whose large force loops always run on threads (when more than one is set):
    the digests must not depend on them."""
    w = sp.World(**settings)
    w.threads = "always"
    return w


def _ring(rng, n, r0, r1, dim, thickness=0.0):
    """n bodies on circular orbits about a unit mass at radii r0..r1 in the xy plane, at
    heights of normal spread `thickness` (drawn after the ring)."""
    r = rng.uniform(r0, r1, n)
    th = rng.uniform(0.0, 2 * np.pi, n)
    pos = np.zeros((n, dim))
    vel = np.zeros((n, dim))
    pos[:, 0], pos[:, 1] = r * np.cos(th), r * np.sin(th)
    vel[:, 0], vel[:, 1] = -np.sin(th) / np.sqrt(r), np.cos(th) / np.sqrt(r)
    if thickness:
        pos[:, 2] = rng.normal(scale=thickness, size=n)
    return pos, vel


def gravity_scene(integrator):
    """A star, four inclined planets and 600 test particles, 3D, 60 steps."""
    rng = np.random.default_rng(11)
    w = World(dim=3, integrator=integrator, dt=0.02)
    w.add_body(1.0, (0.0, 0.0, 0.0), kind="star")
    pos, vel = _ring(rng, 4, 0.8, 2.0, 3)
    vel[:, 2] = rng.normal(scale=0.05, size=4)
    w.add_bodies(rng.uniform(1e-5, 1e-3, 4), pos, vel * rng.uniform(0.9, 1.1, (4, 1)),
                 kind="planet")
    pos, vel = _ring(rng, 600, 1.0, 3.0, 3, thickness=0.05)
    w.add_bodies(0.0, pos, vel * rng.uniform(0.8, 1.2, (600, 1)), kind="asteroid")
    w.move_to_center_of_mass()
    return w, [w.step(60)]


def collision_scene(integrator):
    """A star and 80 small bodies crowding one ring, 2D: rocks merge, balls bounce off rocks
    and each other; 150 steps."""
    rng = np.random.default_rng(12)
    w = World(dim=2, integrator=integrator, dt=0.01)
    w.add_kind("rock")
    w.add_kind("ball")
    w.set_collision("rock", "rock", "merge")
    w.set_collision("ball", "rock", "bounce", restitution=0.8)
    w.set_collision("ball", "ball", "elastic")
    w.add_body(1.0, (0.0, 0.0), radius=0.05, kind="star")
    for kind, k, radius in (("rock", 50, 0.02), ("ball", 30, 0.025)):
        pos, vel = _ring(rng, k, 0.9, 1.1, 2)
        vel *= rng.uniform(0.8, 1.2, (k, 1))
        w.add_bodies(rng.uniform(1e-7, 1e-6, k), pos, vel, radius=radius, kind=kind)
    return w, [w.step(150)]


def actor_scene(integrator):
    """A planet, two ships with held controls in orbit about it, guided missiles from each
    at the other with proximity fuses and explosions; debris hits the planet and expires;
    200 steps."""
    w = World(dim=2, integrator=integrator, dt=0.01, seed=5)
    w.add_body(1.0, (0.0, 0.0), radius=0.25, kind="planet")
    hull = sp.ShipSpec(dry_mass=1e-6, fuel_mass=1e-6, max_thrust=2e-7, exhaust_speed=1.0,
                       turn_rate=2.0, radius=0.02)
    a = w.add_ship(hull, (1.0, 0.0), (0.0, 1.0), heading=math.pi / 2)
    b = w.add_ship(hull, (0.95, 0.35), (-0.3, 0.95), heading=-math.pi / 2)
    w.control(a, throttle=0.5, turn=0.3)
    w.control(b, throttle=1.0, turn=-0.2)
    w.set_collision("debris", "planet", "destroy_a")
    w.set_collision("missile", "ship", "destroy_both")
    boom = sp.ExplosionSpec(count=60, speed=4.0, lifetime=0.8, lifetime_spread=0.5,
                            radius=0.005)
    events = []
    for guidance, (src, dst) in (("pn", (a, b)), ("pursuit", (b, a))):
        spec = sp.MissileSpec(mass=1e-8, fuel_mass=1e-8, thrust=4e-8, exhaust_speed=10.0,
                              guidance=guidance, turn_rate=6.0, fuse_radius=0.05,
                              launch_speed=0.2, radius=0.005, explosion=boom, lifetime=3.0)
        w.launch(src, spec, target=dst)
    for _ in range(4):
        w.step(50)
        events.append(w.events)
    return w, events


def drag_scene(integrator):
    """Projectiles in a uniform field with drag toward a wind, 2D, 240 steps."""
    rng = np.random.default_rng(13)
    w = World(dim=2, integrator=integrator, dt=1 / 120, gravity="uniform", g=(0.0, -9.8),
                 drag=0.3, wind=(2.0, 0.5))
    w.add_bodies(rng.uniform(0.5, 2.0, 40), rng.uniform(-5, 5, (40, 2)),
                 rng.uniform(-10, 10, (40, 2)))
    return w, [w.step(240)]


def tree_scene(integrator):
    """A Plummer sphere of 2 500 stars under the tree (its walk on threads), 3D, 10 steps."""
    from spacephys.scenes import plummer_model
    pos, vel, mass = plummer_model(2500, seed=14)
    w = World(dim=3, integrator=integrator, dt=0.01, G=1.0, softening=0.05, gravity="tree",
              theta=0.6)
    w.add_bodies(mass, pos, vel)
    return w, [w.step(10)]


def cluster_scene(integrator):
    """A star and 450 planetesimals pulling each other (their pairs taken once, in rounds of
    tiles on threads: kernels/pairs.py), 3D, 20 steps."""
    rng = np.random.default_rng(15)
    w = World(dim=3, integrator=integrator, dt=0.01)
    w.add_body(1.0, (0.0, 0.0, 0.0), kind="star")
    pos, vel = _ring(rng, 450, 1.0, 2.0, 3, thickness=0.05)
    w.add_bodies(rng.uniform(1e-7, 1e-5, 450), pos, vel * rng.uniform(0.95, 1.05, (450, 1)),
                 kind="planet")
    w.move_to_center_of_mass()
    return w, [w.step(20)]


SCENES = {"gravity": gravity_scene, "collisions": collision_scene, "actors": actor_scene,
          "drag": drag_scene, "tree": tree_scene, "cluster": cluster_scene}


# what the integrators refuse, with a reason in their error (tested in their own files)
REFUSED = {("drag", "gauss_radau"), ("drag", "wisdom_holman"),
           ("drag", "wisdom_holman_corrected"), ("tree", "gauss_radau"),
           ("tree", "wisdom_holman"), ("tree", "wisdom_holman_corrected")}


def _collect(world, results):
    """The events a scene saw: step() returns the time, so keep only arrays."""
    return [r for r in results if isinstance(r, np.ndarray)] or [world.events]


def digest(scene, integrator):
    """sha256 of the final time, ids, pos, vel, mass, radius, kind and every event; or
    "refused: <error type>" when the integrator refuses the scene."""
    try:
        w, results = SCENES[scene](integrator)
    except ValueError as e:
        # only the refusals the integrators document; anything else is a broken scene
        assert (scene, integrator) in REFUSED, f"{scene}/{integrator}: {e}"
        return f"refused: {type(e).__name__}", None
    events = np.concatenate(_collect(w, results))
    # the begin/end events (kinds 11-13) came after the digests were recorded: they follow
    # from the state bit for bit, and test_touch.py checks them against a brute force
    events = events[events["kind"] <= sp.events.EXPIRY]
    # the bodies' kinds and tags came later too: they are read from the state (and checked
    # in test_event_roles.py); the digests hash the fields they were recorded with
    events = repack_fields(events[list(sp.events.FIRST_FIELDS)])
    h = hashlib.sha256()
    h.update(np.float64(w.t).tobytes())
    for arr in (w.ids, w.pos, w.vel, w.mass, w.radius, w.kind, events):
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest(), events


def _load():
    return json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}


CASES = [(s, i) for s in SCENES for i in INTEGRATORS]


@pytest.mark.parametrize("scene,integrator", CASES)
def test_golden_digest(scene, integrator):
    """The digest equals the recorded one on this machine's fingerprint, on one thread and
    on every thread; the scene did what it is there for."""
    previous = sp.get_threads()
    try:
        sp.set_threads(1)
        one, events = digest(scene, integrator)
        sp.set_threads(numba.config.NUMBA_NUM_THREADS)
        many, _ = digest(scene, integrator)
    finally:
        sp.set_threads(previous)
    assert one == many, f"{scene}/{integrator}: the result depends on the thread count"
    if events is not None:
        kinds = set(events["kind"].tolist())
        need = {"collisions": {sp.events.MERGE, sp.events.BOUNCE},
                "actors": {sp.events.LAUNCH, sp.events.DETONATION, sp.events.EXPIRY,
                           sp.events.DESTROY}}.get(scene, set())
        assert need <= kinds, f"{scene}/{integrator}: events {kinds} lack {need - kinds}"
    key = f"{scene}/{integrator}"
    if RECORD:
        data = _load()
        data.setdefault(fingerprint(), {})[key] = one
        GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        return
    recorded = _load().get(fingerprint(), {})
    assert key in recorded, (f"no digest recorded for {key} with {fingerprint()}: install "
                             f"the test extra's numba, or record them (see the module)")
    assert one == recorded[key], f"{key}: the final state changed bit for bit"


def test_the_golden_file_covers_every_case():
    """One set of digests, this numba's, with a digest for every scene x integrator, and the
    digests tell the cases apart (a scene that did nothing would repeat another's)."""
    if RECORD:
        return
    data = _load()
    assert list(data) == [fingerprint()], list(data)
    recorded = data[fingerprint()]
    assert set(recorded) == {f"{s}/{i}" for s, i in CASES}
    hashes = [v for v in recorded.values() if not v.startswith("refused")]
    assert len(set(hashes)) == len(hashes)
