"""Spatial queries honour compound hitboxes (sp.Circles): a compound body is its circles, where
they are now (turned with its heading), not its bounding circle. Each named case is one the
bounding circle answers wrongly; the property tests compare every query with a brute force
over the circles."""
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import spacephys as sp

ROOT = Path(__file__).resolve().parents[1]

# a dumbbell 2.5 long along its heading: circles at x = +-1 of radius 0.25 (bounding 1.25)
STICK = sp.Circles([[1.0, 0.0], [-1.0, 0.0]], [0.25, 0.25])
BALL = sp.Circles([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], [0.25, 0.25])


def _scene(dim=2):
    """A round body (id 0, radius 0.5 at the origin) and a dumbbell (id 1, centre (5, 0))."""
    w = sp.World(dim=dim, gravity="none")
    z = (0.0,) * (dim - 2)
    a = w.add_body(1.0, (0.0, 0.0) + z, radius=0.5)
    s = w.add_body(1.0, (5.0, 0.0) + z, shape=STICK if dim == 2 else BALL)
    return w, a, s


# ---------------------------------------------------------------------------- raycast

def test_a_ray_through_the_dumbbells_gap_misses_and_one_at_a_circle_hits_it():
    w, a, s = _scene()
    assert w.radius[w.index_of(s)] == 1.25
    gap = w.raycast((5.0, -5.0), (0.0, 1.0), 10.0)          # through the bounding circle
    assert not gap.hit[0] and gap.body[0] == -1 and gap.circle[0] == -1
    hit = w.raycast((6.0, -5.0), (0.0, 1.0), 10.0)          # at circle 0, centre (6, 0)
    assert hit.body[0] == s and hit.circle[0] == 0
    assert abs(hit.distance[0] - 4.75) <= 1e-12
    assert np.allclose(hit.points[0], (6.0, -0.25), atol=1e-12)
    assert np.allclose(hit.normals[0], (0.0, -1.0), atol=1e-12)
    back = w.raycast((-5.0, 0.1), (1.0, 0.0), 20.0, ignore=a)   # meets circle 1 at x ~ 3.75
    assert back.body[0] == s and back.circle[0] == 1
    assert abs(back.distance[0] - (8.0 - math.sqrt(0.25 ** 2 - 0.1 ** 2) + 1.0)) <= 1e-12


def test_a_turned_dumbbell_is_met_where_its_circles_went():
    w, a, s = _scene()
    w.set_heading(s, math.pi / 2)                 # circle 0 at (5, 1), circle 1 at (5, -1)
    up = w.raycast([(5.0, -5.0), (6.0, -5.0)], [(0.0, 1.0)] * 2, 10.0)
    assert up.body.tolist() == [s, -1] and up.circle.tolist() == [1, -1]
    assert abs(up.distance[0] - 3.75) <= 1e-12
    down = w.raycast((5.0, 5.0), (0.0, -1.0), 10.0)
    assert down.circle[0] == 0 and abs(down.distance[0] - 3.75) <= 1e-12


def test_every_hit_along_a_ray_lists_a_compound_body_once_at_its_nearer_circle():
    w, a, s = _scene()
    w.add_plane((10.0, 0.0), (-1.0, 0.0))
    rays = w.raycast((-5.0, 0.0), (1.0, 0.0), 30.0, first=False)
    assert rays.ids.tolist() == [a, s, -1] and rays.walls.tolist() == [-1, -1, 0]
    assert rays.circles.tolist() == [-1, 1, -1]
    assert np.allclose(rays.distances, [4.5, 8.75, 15.0], rtol=0, atol=1e-12)
    one = rays[0]
    assert one.circles.tolist() == [-1, 1, -1] and one.circle[0] == -1


def test_ignore_leaves_out_every_circle_of_a_compound_body():
    w, a, s = _scene()
    through = w.raycast((-5.0, 0.0), (1.0, 0.0), 30.0, ignore=[a, s])
    assert not through.hit[0]
    inside = w.raycast((6.0, 0.0), (1.0, 0.0), 30.0)         # from inside circle 0: at 0
    assert inside.body[0] == s and inside.circle[0] == 0 and inside.distance[0] == 0.0
    out = w.raycast((6.0, 0.0), (1.0, 0.0), 30.0, ignore=s)
    assert not out.hit[0]
    assert w.query_radius((5.0, 0.0), 2.0, ignore=s)[0][0].tolist() == []
    assert w.nearest((6.0, 0.0), ignore=s)[0].tolist() == [[a]]


def test_a_ray_in_3d_meets_the_spheres_not_their_bounding_sphere():
    w, a, s = _scene(dim=3)
    miss = w.raycast((5.0, 0.0, -5.0), (0.0, 0.0, 1.0), 10.0)
    assert not miss.hit[0]
    hit = w.raycast((4.0, 0.1, -5.0), (0.0, 0.0, 1.0), 10.0)
    assert hit.body[0] == s and hit.circle[0] == 1
    assert abs(hit.distance[0] - (5.0 - math.sqrt(0.25 ** 2 - 0.1 ** 2))) <= 1e-12
    w.set_heading(s, (0.0, 0.0, 1.0))             # circle 0 at (5, 0, 1), circle 1 below
    turned = w.raycast((5.0, 0.0, -5.0), (0.0, 0.0, 1.0), 10.0)
    assert turned.body[0] == s and turned.circle[0] == 1
    assert abs(turned.distance[0] - 3.75) <= 1e-12
    assert np.allclose(turned.normals[0], (0.0, 0.0, -1.0), atol=1e-12)


# ---------------------------------------------------------------------------- shapecast

def test_a_circle_cast_through_the_gap_misses_and_one_at_a_circle_names_it():
    w, a, s = _scene()
    gap = w.shapecast(((5.0, -5.0), 0.1), (0.0, 10.0))
    assert not gap.hit[0]
    hit = w.shapecast(((6.0, -5.0), 0.1), (0.0, 10.0))
    assert hit.body[0] == s and hit.circle[0] == 0
    assert abs(hit.distance[0] - 4.65) <= 1e-12
    assert np.allclose(hit.points[0], (6.0, -0.35), atol=1e-12)      # the shape's centre
    assert np.allclose(hit.normals[0], (0.0, -1.0), atol=1e-12)
    w.set_heading(s, math.pi / 2)
    turned = w.shapecast(([(5.0, -5.0), (6.0, -5.0)], 0.1), [(0.0, 10.0)] * 2)
    assert turned.body.tolist() == [s, -1] and turned.circle.tolist() == [1, -1]
    assert abs(turned.distance[0] - 3.65) <= 1e-12


def test_a_compound_body_cast_moves_its_circles():
    w, a, s = _scene()
    w.add_plane((0.0, 3.0), (0.0, -1.0))                   # a wall at y = 3
    up = w.shapecast(s, (0.0, 5.0))                        # circles at y = 0: 3 - 0.25
    assert up.wall[0] == 0 and abs(up.distance[0] - 2.75) <= 1e-12
    assert np.allclose(up.points[0], (5.0, 2.75), atol=1e-12)    # the body's centre then
    assert np.allclose(up.normals[0], (0.0, -1.0), atol=1e-12)
    w.set_heading(s, math.pi / 2)                          # circle 0 now at y = 1
    up = w.shapecast(s, (0.0, 5.0))
    assert up.wall[0] == 0 and abs(up.distance[0] - 1.75) <= 1e-12
    # the turned dumbbell's circles (x = 5) pass a body at x = 6.2 (1.2 apart > 0.25 + 0.5),
    # which its bounding circle (1.25 + 0.5 > 1.2) would meet; that body moving up misses
    # them likewise
    b = w.add_body(1.0, (6.2, -2.0), radius=0.5)
    down = w.shapecast([s, b], [(0.0, -5.0), (0.0, 5.0)], walls=False)
    assert not down.hit.any()
    near = w.add_body(1.0, (5.0, -3.0), radius=0.5)
    down = w.shapecast(s, (0.0, -5.0), walls=False)
    assert down.body[0] == near and down.circle[0] == -1
    assert abs(down.distance[0] - (3.0 - 1.0 - 0.25 - 0.5)) <= 1e-12
    assert np.allclose(down.points[0], (5.0, -1.25), atol=1e-12)
    assert np.allclose(down.normals[0], (0.0, 1.0), atol=1e-12)


def test_a_compound_cast_meets_another_compound_body_circle_to_circle():
    w = sp.World(dim=2, gravity="none")
    s = w.add_body(1.0, (0.0, 0.0), shape=STICK)
    t = w.add_body(1.0, (0.0, 3.0), shape=STICK)
    w.set_heading(t, math.pi / 2)                 # t's circles at (0, 4) and (0, 2)
    # s's circles at x = +-1 slide past t's at x = 0, though both bounding circles meet
    assert not w.shapecast(s, (0.0, 10.0), walls=False).hit[0]
    w.set_body(t, pos=(1.0, 3.0))                 # now in the path of s's circle 0
    hit = w.shapecast(s, (0.0, 10.0), walls=False)
    assert hit.body[0] == t and hit.circle[0] == 1
    assert abs(hit.distance[0] - 1.5) <= 1e-12
    assert np.allclose(hit.points[0], (0.0, 1.5), atol=1e-12)
    back = w.shapecast(t, (0.0, -10.0), walls=False)
    assert back.body[0] == s and back.circle[0] == 0 and abs(back.distance[0] - 1.5) <= 1e-12


# ---------------------------------------------------------------------------- query_radius

def test_query_radius_finds_a_compound_body_only_near_its_circles():
    w, a, s = _scene()
    assert w.query_radius((5.0, 0.5), 0.2)[0][0].tolist() == []          # in the gap
    ids, d = w.query_radius((6.0, 0.5), 0.3)[0]
    assert ids.tolist() == [s] and abs(d[0] - 0.25) <= 1e-12
    ids, d = w.query_radius((5.0, 0.0), 1.0)[0]                # both circles: listed once
    assert ids.tolist() == [s] and abs(d[0] - 0.75) <= 1e-12
    w.set_heading(s, math.pi / 2)
    assert w.query_radius((6.0, 0.5), 0.3)[0][0].tolist() == []
    ids, d = w.query_radius((5.0, 1.5), 0.3)[0]
    assert ids.tolist() == [s] and abs(d[0] - 0.25) <= 1e-12


def test_query_radius_in_3d_meets_the_spheres():
    w, a, s = _scene(dim=3)
    assert w.query_radius((5.0, 0.0, 0.5), 0.2)[0][0].tolist() == []
    ids, d = w.query_radius((6.0, 0.0, 0.5), 0.3)[0]
    assert ids.tolist() == [s] and abs(d[0] - 0.25) <= 1e-12
    w.set_heading(s, (0.0, 0.0, 1.0))
    ids, d = w.query_radius((5.0, 0.0, 1.5), 0.3)[0]
    assert ids.tolist() == [s] and abs(d[0] - 0.25) <= 1e-12


# ---------------------------------------------------------------------------- query_box

def test_query_box_finds_a_compound_body_only_where_a_circle_overlaps():
    w, a, s = _scene()
    assert w.query_box((4.5, -0.5), (5.5, 0.5))[0][0].tolist() == []     # the gap
    ids, d = w.query_box((5.6, -0.5), (6.5, 0.5))[0]
    # found once; its distance the body's centre from the box's (not circle 0's: 0.05)
    assert ids.tolist() == [s] and abs(d[0] - 1.05) <= 1e-12
    ids, d = w.query_box((-1.0, -1.0), (7.0, 1.0))[0]
    assert ids.tolist() == [s, a] and np.allclose(d, [2.0, 3.0], rtol=0, atol=1e-12)
    w.set_heading(s, math.pi / 2)
    assert w.query_box((5.6, -0.5), (6.5, 0.5))[0][0].tolist() == []
    assert w.query_box((4.9, 0.9), (5.1, 1.1))[0][0].tolist() == [s]


# ---------------------------------------------------------------------------- nearest

def test_nearest_measures_to_the_nearest_circles_surface():
    w, a, s = _scene()
    b = w.add_body(1.0, (5.0, 1.5), radius=0.1)
    # from (5, 0.5): b's surface is 0.9 away; the dumbbell's bounding circle 0 (inside it),
    # its circles sqrt(1 + 0.25) - 0.25 = 0.868
    ids, d = w.nearest([(5.0, 0.5), (5.0, 0.9)], k=3)
    assert ids.tolist() == [[s, b, a], [b, s, a]]
    assert abs(d[0, 0] - (math.sqrt(1.25) - 0.25)) <= 1e-12
    assert abs(d[1, 1] - (math.sqrt(1.81) - 0.25)) <= 1e-12
    w.set_heading(s, math.pi / 2)                 # circle 0 at (5, 1), circle 1 at (5, -1)
    ids, d = w.nearest((6.0, 0.0), k=2)
    assert ids.tolist() == [[s, b]]
    assert abs(d[0, 0] - (math.sqrt(2.0) - 0.25)) <= 1e-12


def test_nearest_lists_each_body_once_and_pads_past_the_bodies():
    w, a, s = _scene()
    ids, d = w.nearest((5.0, 0.0), k=4)
    assert ids.tolist() == [[s, a, -1, -1]]
    assert np.allclose(d[0, :2], [0.75, 4.5], rtol=0, atol=1e-12) and np.all(np.isinf(d[0, 2:]))


# ------------------------------------------------------------- against brute force

def _world(dim, rounds, shaped, headings):
    w = sp.World(dim=dim, gravity="none")
    for p, r in rounds:
        w.add_body(1.0, p[:dim], radius=r)
    for (p, offsets, radii), h in zip(shaped, headings):
        body = w.add_body(1.0, p[:dim], shape=sp.Circles(np.array(offsets)[:, :dim], radii))
        if dim == 2:
            w.set_heading(body, h)
        else:
            w.set_heading(body, (math.cos(h), math.sin(h), 0.3))
    return w


def _pieces(w):
    """(body ids (P,), circle (P,), centres (P, 3), radii (P,)): every body's circles (a
    round body: one, circle -1)."""
    cid, k, centres, cr = w.circles()
    ids, circ, cen, rad = [], [], [], []
    for row, body in enumerate(w.ids.tolist()):
        if w.shape(body) is None:
            ids.append(body)
            circ.append(-1)
            cen.append(np.r_[w.pos[row], np.zeros(3 - w.dim)])
            rad.append(w.radius[row])
    for j in range(cid.size):
        ids.append(int(cid[j]))
        circ.append(int(k[j]))
        cen.append(np.r_[centres[j], np.zeros(3 - w.dim)])
        rad.append(cr[j])
    return np.array(ids), np.array(circ), np.array(cen), np.array(rad)


def _ray_t(o, d, c, r):
    w = c - o
    b = w @ d
    cc = w @ w - r * r
    # inside: by math.hypot, which scales (w @ w underflows to 0 for a centre 1e-309 from
    # the origin, which put a body of radius 0 there on every ray)
    if math.hypot(*w) <= r:
        return 0.0
    h = w - b * d
    disc = r * r - h @ h
    if b <= 0 or disc < 0:
        return np.inf
    return cc / (b + math.sqrt(disc))


pos = st.tuples(*[st.floats(-4.0, 4.0) for _ in range(3)])
offset = st.tuples(*[st.floats(-2.0, 2.0) for _ in range(3)])
circle_sets = st.integers(1, 4).flatmap(lambda k: st.tuples(
    pos, st.lists(offset, min_size=k, max_size=k),
    st.lists(st.floats(0.05, 0.8), min_size=k, max_size=k)))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([2, 3]),
       st.lists(st.tuples(pos, st.floats(0.0, 1.0)), max_size=6),
       st.lists(circle_sets, min_size=1, max_size=4),
       st.lists(st.floats(-math.pi, math.pi), min_size=4, max_size=4),
       st.lists(pos, min_size=1, max_size=4), st.floats(0.0, 2.0), st.integers(1, 5),
       st.data())
def test_every_query_is_a_brute_force_over_the_circles(dim, rounds, shaped, headings, points,
                                                       r, k, data):
    w = _world(dim, rounds, shaped, headings)
    ids, circ, cen, rad = _pieces(w)
    p = np.zeros((len(points), 3))
    p[:, :dim] = np.array(points)[:, :dim]
    gap = np.maximum(np.linalg.norm(cen[None] - p[:, None], axis=2) - rad[None], 0.0)
    tol = 1e-12
    # each body's gap: to its nearest circle
    every = np.unique(ids)
    body_gap = np.array([[gap[q, ids == b].min() for b in every] for q in range(len(p))])
    hits = w.query_radius(p[:, :dim], r)
    near, near_d = w.nearest(p[:, :dim], k=k)
    for q in range(len(p)):
        got, d = hits[q]
        sure = set(every[body_gap[q] <= r - tol].tolist())
        maybe = set(every[body_gap[q] <= r + tol].tolist())
        assert sure <= set(got.tolist()) <= maybe and len(set(got.tolist())) == got.size
        for b, dd in zip(got.tolist(), d):
            assert abs(dd - body_gap[q, every == b][0]) <= tol
        # the k smallest body gaps, each body once, -1 and inf past the bodies there are
        m = min(k, every.size)
        assert np.allclose(near_d[q, :m], np.sort(body_gap[q])[:m], rtol=0, atol=tol)
        assert near[q, m:].tolist() == [-1] * (k - m) and np.all(np.isinf(near_d[q, m:]))
        assert len(set(near[q, :m].tolist())) == m
        for b, dd in zip(near[q, :m].tolist(), near_d[q, :m]):
            assert abs(dd - body_gap[q, every == b][0]) <= tol
    # boxes about the points
    half = data.draw(st.floats(0.0, 2.0))
    boxed = w.query_box(p[:, :dim] - half, p[:, :dim] + half)
    for q in range(len(p)):
        e = np.maximum(np.abs(cen - p[q]) - np.r_[[half] * dim, [0.0] * (3 - dim)], 0.0)
        box_gap = np.linalg.norm(e, axis=1) - rad
        sure = set(ids[box_gap <= -tol].tolist())
        maybe = set(ids[box_gap <= tol].tolist())
        got = boxed[q][0].tolist()
        assert sure <= set(got) <= maybe and len(set(got)) == len(got)
    # rays from the points
    dirs = np.zeros((len(p), 3))
    dirs[:, :dim] = np.array(data.draw(st.lists(st.tuples(*[st.floats(-1, 1)] * 3),
                                                min_size=len(p), max_size=len(p))))[:, :dim]
    dirs[np.abs(dirs).sum(axis=1) < 1e-3, 0] = 1.0
    unit = dirs / np.linalg.norm(dirs, axis=1)[:, None]
    rays = w.raycast(p[:, :dim], dirs[:, :dim], 12.0)
    every_hit = w.raycast(p[:, :dim], dirs[:, :dim], 12.0, first=False)
    for q in range(len(p)):
        t = np.array([_ray_t(p[q], unit[q], cen[j], rad[j]) for j in range(ids.size)])
        t[t > 12.0] = np.inf
        if not np.isfinite(t).any():
            assert not rays.hit[q] and every_hit[q].ids.size == 0
            continue
        j = int(np.argmin(t))
        assert rays.hit[q] and abs(rays.distance[q] - t[j]) <= 1e-9
        if np.sort(t)[1:2].tolist() != [] and np.sort(t)[1] - t[j] > 1e-9:
            assert rays.body[q] == ids[j] and rays.circle[q] == circ[j]
        bodies_met = {b: t[ids == b].min() for b in every if np.isfinite(t[ids == b]).any()}
        row = every_hit[q]
        assert sorted(row.ids.tolist()) == sorted(bodies_met)
        for b, dd, c in zip(row.ids.tolist(), row.distances, row.circles):
            assert abs(dd - bodies_met[b]) <= 1e-9
            assert abs(t[(ids == b) & (circ == c)][0] - dd) <= 1e-9
    # every body cast along a ray's direction, 6 long: each of its circles against every
    # circle of the others
    moves = 6.0 * unit
    cast = w.shapecast(w.ids, moves[np.arange(every.size) % len(p), :dim], walls=False)
    for q, b in enumerate(w.ids.tolist()):
        u = unit[q % len(p)]
        mine, theirs = np.flatnonzero(ids == b), np.flatnonzero(ids != b)
        t = np.array([[_ray_t(cen[i], u, cen[j], rad[i] + rad[j]) for j in theirs]
                      for i in mine]).reshape(mine.size, theirs.size)
        t[t > 6.0] = np.inf
        if not np.isfinite(t).any():
            assert not cast.hit[q]
            continue
        i, j = np.unravel_index(np.argmin(t), t.shape)
        assert cast.hit[q] and abs(cast.distance[q] - t[i, j]) <= 1e-9
        row = w.index_of(b)
        centre = np.r_[w.pos[row], np.zeros(3 - dim)] + t[i, j] * u
        assert np.allclose(cast[q].points[0], centre[:dim], rtol=0, atol=1e-9)
        if np.sum(np.abs(t - t[i, j]) <= 1e-9) == 1:
            assert cast.body[q] == ids[theirs[j]] and cast.circle[q] == circ[theirs[j]]


def test_a_periodic_world_wraps_the_circles():
    w = sp.World(dim=2, gravity="none")
    w.set_boundary("periodic", (-5.0, -5.0), (5.0, 5.0))
    s = w.add_body(1.0, (4.5, 0.0), shape=STICK)         # circle 0 at x = 5.5: -4.5
    ids, d = w.query_radius((-4.5, 0.5), 0.3)[0]
    assert ids.tolist() == [s] and abs(d[0] - 0.25) <= 1e-12
    ray = w.raycast((-4.5, -3.0), (0.0, 1.0), 5.0)
    assert ray.body[0] == s and ray.circle[0] == 0 and abs(ray.distance[0] - 2.75) <= 1e-12
    assert not w.raycast((4.5, -3.0), (0.0, 1.0), 5.0).hit[0]     # the gap


def test_a_world_without_compound_bodies_answers_as_before():
    w = sp.World(dim=2, gravity="none")
    w.add_bodies(1.0, [(0.0, 0.0), (3.0, 0.0)], radius=[0.5, 1.0])
    hits = w.raycast((-5.0, 0.0), (1.0, 0.0), 20.0, first=False)
    assert hits.ids.tolist() == [0, 1] and hits.circles.tolist() == [-1, -1]
    assert hits.circle[0] == -1


# ---------------------------------------------------------------------------- the guide

def test_the_guides_compound_example_prints_what_the_page_says():
    text = (ROOT / "docs" / "guide" / "queries.md").read_text()
    block = re.search(r"<!-- compound-queries -->\s*```python\n(.*?)```", text, re.S).group(1)
    printed = re.search(r"<!-- compound-queries -->.*?It prints:\s*```\n(.*?)```", text,
                        re.S).group(1).splitlines()
    res = subprocess.run([sys.executable, "-c", block], capture_output=True, text=True,
                         cwd=ROOT, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines() == printed


def test_a_ray_passing_a_hair_from_a_body_of_no_radius_misses_it():
    """A body of radius 0 at 1e-309 beside a ray's origin is not on the ray (the brute force
    above once said it was: its square of the distance underflowed to 0)."""
    w = sp.World(dim=2, gravity="none")
    w.add_body(1.0, (0.0, 2.225073858507203e-309), radius=0.0)
    hull = w.add_body(1.0, (0.0, 0.0), shape=sp.Circles(np.zeros((1, 2)), [0.5]))
    assert w.raycast((0.0, 0.0), (1.0, 0.0), 12.0, first=False)[0].ids.tolist() == [hull]
    up = w.raycast((0.0, 0.0), (0.0, 1.0), 12.0, first=False)[0].ids.tolist()
    assert sorted(up) == [0, hull]
