"""The collision broad phase, and the contacts a step finally reports, against a brute force
written here from scratch.

The reference below shares nothing with the grid code: it imports nothing from
spacephys.kernels, and computes on its own
- which pairs may meet: the kind x kind rules (symmetric: ignore, sensor, elastic, bounce,
  destroy_both) and the category/mask bits;
- the periodic images: every shift of the other body by -L, 0, +L per wrapping axis, the
  earliest contact over all of them (no minimum-image formula);
- the time of impact of two discs on straight lines, |d + e t| = ra + rb, from the quadratic
  evaluated in exact decimal arithmetic (the floats converted exactly), with an error budget
  for the library's floating-point inputs (its lines come from the integrated end
  positions) so that a contact is called certain only when rounding cannot change it;
- the sequential answer of a step: contacts taken in time order, sensors recorded, bounces
  change two lines from the moment of contact on, destroys end both bodies. Scenes where a
  body's line changes and that body then meets anything again in the same step (where the
  library's one-contact-per-pass resolution is an approximation), or where two contacts of
  a body tie in time, or a line-changing contact is within rounding of happening or not, are
  thinned by removing bodies until the answer is unambiguous.

Scenes: 2D and 3D; radii from 2^-12 to 6 in one scene (giants above a 2x gap among bodies
of radius <= 1 with the default cell; every body in the grid with a hand-set cell); fast
movers crossing many cells in one step; boxes placed on cell edges; pairs exactly touching
(axis-aligned, 3-4-5 diagonals, across the periodic seam), static, approaching, separating or
sliding; clusters straddling the periodic seam; up to four kinds with rules between some
kinds only, and category/mask bits. Positions and radii are multiples of 2^-12, so the
geometry at the start of the step is exact in floats (touching means touching).
"""
import itertools
import math
from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import spacephys as sp
# The grid under test, called directly by the broad-phase tests (their scenes' tables come from
# World.tables()). The reference does not use it, nor anything else of spacephys.kernels.
from spacephys.kernels.broadphase import candidate_pairs

EPS = 2.0 ** -52
QUANTUM = 2.0 ** -12            # positions and radii are multiples of it: exact geometry
SIDE = 64.0                     # the scenes' box (the periodic one when wrapping)
KINDS = ("k0", "k1", "k2", "k3")
TOL_T = 1e-12                   # times of impact agree to this fraction of the step ...
POS_ULPS = 16.0                 # ... plus what an error of this many ulps of the coordinates
                                # in the library's lines can move them (see Reference._exact)

# the reference's own response codes
NOTHING, SENSE, BOUNCE, KILL = 0, 1, 2, 3
OWN_CODE = {"ignore": NOTHING, "sensor": SENSE, "elastic": BOUNCE, "bounce": BOUNCE,
            "destroy_both": KILL}
EVENT_OF = {1: BOUNCE, 3: KILL, 4: SENSE}          # spacephys event kinds, by their number
# the ends of sensor overlaps and the begin/end of resting contacts: tested in test_touch.py
UNCHECKED = (sp.events.SENSOR_END, sp.events.CONTACT_BEGIN, sp.events.CONTACT_END)

PROFILE = dict(derandomize=True, deadline=None,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def quantize(x):
    return np.round(np.asarray(x, dtype=float) / QUANTUM) * QUANTUM


# ----------------------------------------------------------------------------- scenes

class Scene:
    """Bodies (pos, vel, radius, mass, kind, category, mask) and the rules, as plain arrays."""

    def __init__(self, **fields):
        self.__dict__.update(fields)

    @property
    def n(self):
        return self.pos.shape[0]

    def response(self, a, b):
        return self.rules.get((min(a, b), max(a, b)), ("ignore", None))


def min_image(d, periodic):
    return d - SIDE * np.round(d / SIDE) if periodic else d


def make_scene(seed, dim, n, periodic, cell, n_giants, n_fast, n_edge, n_touch, n_aim,
               cluster, spread, n_kinds, rules, bits, dt, lo):
    """A random scene (see the module) drawn from seed; the counts say how many bodies get
    each treatment (giants, fast movers, boxes on cell edges, touching pairs, aimed)."""
    rng = np.random.default_rng(seed)
    radius = np.where(rng.random(n) < 0.5, 2.0 ** rng.uniform(-12, 0, n),
                      rng.uniform(0.1, 1.0, n))
    radius = np.maximum(quantize(radius), QUANTUM)
    n_giants = min(n_giants, n - 1)
    radius[:n_giants] = quantize(rng.uniform(3.0, 6.0, n_giants))
    centre = lo + rng.uniform(0, SIDE, dim)
    if periodic and rng.random() < 0.6:
        centre[rng.integers(dim)] = lo + rng.uniform(-1, 1)      # the cluster straddles a seam
    pos = centre + rng.uniform(-cluster / 2, cluster / 2, (n, dim))
    if spread:                        # mostly apart at the start: contacts within the step
        for k in range(n):
            for _ in range(8):
                gap = np.linalg.norm(min_image(pos[:k] - pos[k], periodic), axis=1) \
                    - radius[:k] - radius[k]
                if not np.any(gap < 0):
                    break
                pos[k] = centre + rng.uniform(-cluster / 2, cluster / 2, dim)
    disp = rng.normal(scale=cluster / 6, size=(n, dim))           # displacement over the step
    speed = np.linalg.norm(disp, axis=1, keepdims=True)
    disp *= np.minimum(1.0, 3.0 / np.maximum(speed, 1e-300))
    disp[:n_giants] *= 0.2
    fast = np.arange(n_giants, min(n, n_giants + n_fast))
    for k in fast:                    # through the cluster, 6 to 9.5 lengths in one step
        u = rng.normal(size=dim)
        u /= np.linalg.norm(u)
        disp[k] = rng.uniform(6.0, 9.5) * u
        pos[k] = centre - disp[k] * rng.uniform(0.2, 0.8) + rng.normal(scale=0.3, size=dim)
    for _ in range(n_aim):            # at another body's position somewhere in the step
        i, j = rng.choice(n, 2, replace=False)
        if i >= n_giants:
            aim = min_image(pos[j] + disp[j] * rng.uniform(0, 1) - pos[i], periodic)
            aim *= rng.uniform(0.6, 1.6)
            aim += rng.normal(scale=0.3 * (radius[i] + radius[j]), size=dim)
            disp[i] = aim * min(1.0, 9.5 / max(np.linalg.norm(aim), 1e-300))
    disp[rng.random(n) < 0.1] = 0.0                               # some at rest
    disp[rng.random((n, dim)) < 0.1] = 0.0                        # some along axes
    pos = quantize(pos)
    # boxes on the grid's cell edges (the default cell is the largest diameter but a giant's)
    step = cell if cell is not None else 2.0 * radius[n_giants:].max()
    origin = lo if periodic else 0.0
    if periodic:
        step = SIDE / max(1, int(SIDE // step))
    normal = np.arange(n_giants, n)
    for k in rng.choice(normal, min(n_edge, normal.size), replace=False):
        c = rng.integers(dim)
        m = np.round((pos[k, c] - origin) / step)
        pos[k, c] = quantize(origin + m * step + rng.choice([-1.0, 1.0]) * radius[k])
    # exactly touching pairs
    pool = [k for k in normal if k not in set(fast.tolist())]
    rng.shuffle(pool)
    for q in range(min(n_touch, len(pool) // 2)):
        i, j = pool[2 * q], pool[2 * q + 1]
        style = rng.integers(3)
        u = np.zeros(dim)
        if style == 1:                                            # a 3-4-5 diagonal
            quantum = math.ceil((radius[i] + QUANTUM) / (5 * QUANTUM)) * QUANTUM
            radius[j] = 5 * quantum - radius[i]
            s = rng.choice([-1.0, 1.0], 2)
            pos[j] = pos[i]
            pos[j, 0] += 3 * quantum * s[0]
            pos[j, 1] += 4 * quantum * s[1]
            u[0], u[1] = 0.6 * s[0], 0.8 * s[1]
        else:
            c = rng.integers(dim)
            if style == 2 and periodic:                           # across the seam
                pos[i, c] = lo + radius[i]
                pos[j] = pos[i]
                pos[j, c] = lo + SIDE - radius[j]
                u[c] = -1.0                                       # j's image lies below i
            else:
                s = rng.choice([-1.0, 1.0])
                pos[j] = pos[i]
                pos[j, c] += s * (radius[i] + radius[j])
                u[c] = s
        motion = rng.integers(4)
        v = rng.uniform(0.1, 2.0)
        disp[i] = 0.0
        disp[j] = 0.0
        if motion == 1:
            disp[i], disp[j] = v * u, -0.5 * v * u                # closing
        elif motion == 2:
            disp[i], disp[j] = -v * u, 0.5 * v * u                # separating
        elif motion == 3 and style != 1:                          # sliding along the contact
            side = (np.flatnonzero(u == 0.0))
            disp[j, rng.choice(side)] = v
    if periodic:
        pos = lo + np.mod(pos - lo, SIDE)                         # exact on these multiples
    mass = rng.uniform(0.5, 2.0, n)
    kind = rng.integers(0, n_kinds, n)
    if bits:
        category = rng.choice([1, 2], n)
        mask = rng.choice([1, 2, 3, -1], n)
    else:
        category = np.ones(n, np.int64)
        mask = -np.ones(n, np.int64)
    return Scene(dim=dim, pos=pos, vel=disp / dt, radius=radius, mass=mass, kind=kind,
                 category=category, mask=mask, rules=rules, periodic=periodic, lo=lo,
                 cell=cell, dt=dt)


def documented_default_cell(radius):
    """The default cell as docs/guide/collisions.md describes it: the largest diameter, once the giants (the
    bodies above the widest gap, at least 2x in radius, among the 65 largest) are set aside.
    Only used to keep the scenes' grids small (fit_grid_budget), never as an expectation.
    Returns (cell, giant flags)."""
    order = np.argsort(-radius, kind="stable")[:65]
    r = radius[order]
    giant = np.zeros(radius.size, bool)
    if r.size > 1:
        gaps = r[:-1] / r[1:]
        k = int(np.argmax(gaps))
        if gaps[k] >= 2.0 and k < 64:
            giant[order[:k + 1]] = True
    return 2.0 * radius[~giant].max(), giant


def fit_grid_budget(scene, budget=2e5):
    """Halve the sweeps of the bodies whose swept boxes would fill the most grid cells until
    the whole scene fills about `budget`: a tiny body sweeping across a 3D grid diagonally
    fills a cube of cells, up to 1024^3, and one step then takes seconds to minutes (see
    test_a_tiny_fast_body_does_not_fill_millions_of_cells). Only a guard on this file's run
    time: the scenes keep bodies crossing tens of cells in a step."""
    cell, giant = documented_default_cell(scene.radius)
    cell = scene.cell if scene.cell is not None else cell
    for _ in range(200):
        width = np.abs(scene.vel * scene.dt) + 2 * scene.radius[:, None]
        size = max(cell, width[~giant].max() / 1024)
        cells = np.where(giant, 0.0, np.prod(np.floor(width / size) + 2, axis=1))
        if cells.sum() <= budget:
            break
        scene.vel[int(np.argmax(cells))] *= 0.5
    return scene


@st.composite
def scenes(draw, responses, n_max=40):
    dim = draw(st.sampled_from([2, 3]))
    n_kinds = draw(st.integers(1, 4))
    rules = {}
    for a, b in itertools.combinations_with_replacement(range(n_kinds), 2):
        name = draw(st.sampled_from(responses))
        if name != "ignore":
            rules[(a, b)] = (name, draw(st.sampled_from([0.3, 0.8])) if name == "bounce"
                             else None)
    return fit_grid_budget(make_scene(
        seed=draw(st.integers(0, 2 ** 32 - 1)), dim=dim, n=draw(st.integers(2, n_max)),
        periodic=draw(st.booleans()),
        cell=draw(st.sampled_from([None, None, 0.25, 1.0, 4.0, 0.7, 3.3])),
        n_giants=draw(st.integers(0, 2)), n_fast=draw(st.integers(0, 4)),
        n_edge=draw(st.integers(0, 8)), n_touch=draw(st.integers(0, 4)),
        n_aim=draw(st.integers(0, 8)), cluster=draw(st.sampled_from([3.0, 6.0, 12.0])),
        spread=draw(st.sampled_from([True, True, False])), n_kinds=n_kinds, rules=rules,
        bits=draw(st.booleans()), dt=draw(st.sampled_from([1.0, 0.5, 0.1])),
        lo=draw(st.sampled_from([0.0, -32.0, 1000.0]))))


def build_world(scene, keep=None):
    """The World of the scene's bodies in keep (all by default); returns (world, rows), rows
    the scene index of each world row."""
    rows = np.arange(scene.n) if keep is None else np.flatnonzero(keep)
    w = sp.World(dim=scene.dim, gravity="none", dt=scene.dt)
    for name in KINDS:
        w.add_kind(name)
    for (a, b), (name, restitution) in scene.rules.items():
        w.set_collision(KINDS[a], KINDS[b], name, restitution=restitution)
    if scene.periodic:
        w.set_boundary("periodic", lo=[scene.lo] * scene.dim, hi=[scene.lo + SIDE] * scene.dim)
    if scene.cell is not None:
        w.collision_cell = scene.cell
    if rows.size:
        w.add_bodies(scene.mass[rows], scene.pos[rows], scene.vel[rows],
                     radius=scene.radius[rows], kind=[KINDS[k] for k in scene.kind[rows]],
                     category=scene.category[rows], mask=scene.mask[rows])
    return w, rows


# ----------------------------------------------------------------------------- the reference

def allowed_matrix(scene):
    """(n, n) own response codes of every pair, after the category/mask bits."""
    n = scene.n
    code = np.zeros((n, n), np.int64)
    restitution = np.ones((n, n))
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            ci, cj = int(scene.category[i]), int(scene.category[j])
            mi, mj = int(scene.mask[i]), int(scene.mask[j])
            if ci & mj == 0 or cj & mi == 0:
                continue
            name, e = scene.response(int(scene.kind[i]), int(scene.kind[j]))
            code[i, j] = OWN_CODE[name]
            restitution[i, j] = 1.0 if e is None else e
    return code, restitution


def image_shifts(scene):
    """Every shift of the other body to try: -L, 0, +L on each wrapping axis."""
    if not scene.periodic:
        return np.zeros((1, scene.dim))
    return SIDE * np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=scene.dim)))


class Outcome:
    """A contact the reference predicts: certain (sure) or within rounding of not happening
    (maybe); t its time as a fraction of the step, tol how far the library's may be."""

    def __init__(self, sure, t, tol):
        self.sure, self.t, self.tol = sure, t, tol

    def __repr__(self):
        return f"{'sure' if self.sure else 'maybe'} t={self.t!r} tol={self.tol:.2g}"


class Reference:
    """Bodies on straight lines p = P + V t from t = tb on (t the fraction of the step, V the
    displacement over the step), and the step's contacts taken in time order."""

    def __init__(self, scene, keep):
        self.scene = scene
        self.dim = scene.dim
        self.P = scene.pos.astype(float).copy()
        self.V = scene.vel * scene.dt
        self.tb = np.zeros(scene.n)
        self.changed = np.zeros(scene.n, bool)
        self.alive = np.array(keep, bool)
        self.code, self.restitution = allowed_matrix(scene)
        self.shifts = image_shifts(scene)

    # ------------------------------------------------------------- one pair
    def _scale(self, i, j):
        ends = [self.P[k] + self.V[k] * t for k in (i, j) for t in (self.tb[k], 1.0)]
        return max(float(np.abs(ends).max()), SIDE if self.scene.periodic else 0.0, 1.0)

    def _exact(self, i, j, shift):
        """The earliest contact of i and j's image (j shifted) on their lines over
        [max(tb_i, tb_j), 1], or None. Exact arithmetic; the library's inputs differ from
        these lines by rounding (its lines come from integrated end positions), bounded by
        dpos: a contact is sure when no such difference can change it."""
        t_lo = max(self.tb[i], self.tb[j])
        ends = self.code[i, j] in (KILL, SENSE)   # an overlap at the start counts for both
        R = self.scene.radius[i] + self.scene.radius[j]
        with localcontext() as ctx:
            ctx.prec = 200
            D = Decimal
            tl = D(float(t_lo))
            e = [D(float(self.V[j, c])) - D(float(self.V[i, c])) for c in range(self.dim)]
            p = [D(float(self.P[j, c])) + D(float(shift[c])) - D(float(self.P[i, c]))
                 + e[c] * tl for c in range(self.dim)]
            a = sum(x * x for x in e)
            b = sum(x * y for x, y in zip(p, e))
            c = sum(x * x for x in p) - (D(float(self.scene.radius[i]))
                                         + D(float(self.scene.radius[j]))) ** 2
            pn, en = float(sum(x * x for x in p).sqrt()), float(a.sqrt())
            dpos = POS_ULPS * EPS * self._scale(i, j)
            df = 2 * R * dpos + dpos * dpos + 8 * EPS * (pn + en + R) ** 2
            db = (pn + en) * dpos + 4 * EPS * pn * en
            sure = lambda t, tol: Outcome(True, t, tol)
            maybe = lambda t, tol=1.0: Outcome(False, t, tol)
            # the start: exact when the lines are the scene's own (multiples of QUANTUM)
            if t_lo == 0.0:
                c_state = "in" if c <= 0 else "out"
            else:
                c_state = "in" if c < -df else "out" if c > df else "edge"
            structural = t_lo == 0.0 and not (self.changed[i] or self.changed[j]) and all(
                p[k] == 0 or (self.V[i, k] == 0.0 and self.V[j, k] == 0.0)
                for k in range(self.dim))
            if structural:
                b_state = "nonneg" if b >= 0 else "neg"
            else:
                b_state = "neg" if b < -db else "nonneg" if b > db else "edge"
            if c_state == "in":                   # touching or overlapping at t_lo
                if ends or b_state == "neg":
                    return sure(t_lo, TOL_T)
                return None if b_state == "nonneg" else maybe(t_lo, TOL_T)
            if c_state == "edge":
                if b_state == "neg":
                    return sure(t_lo, TOL_T + df / abs(float(b)))
                return None if b_state == "nonneg" and not ends else maybe(t_lo, TOL_T)
            # apart at t_lo: too far to close the gap?
            if pn - R > (en + 2 * dpos) * (1.0 - t_lo) + 2 * dpos:
                return None
            if b_state == "nonneg":
                return None
            disc = b * b - a * c
            vertex = t_lo + float(-b / a) if a > 0 else t_lo
            spread = math.sqrt(2 * df / float(a)) + TOL_T if a > 0 else 1.0
            if b_state == "edge":
                return None if a > 0 and -disc / a > df else maybe(vertex, spread)
            if disc < 0:
                return None if -disc / a > df else maybe(vertex, spread)
            if disc / a <= df:
                return maybe(vertex, spread)        # grazing
            root = disc.sqrt()
            t = t_lo + float((-b - root) / a)
            slack = 4 * df / (2 * float(root))
            if t > 1.0 + slack + TOL_T:
                return None
            if t < 1.0 - slack - TOL_T:
                return sure(t, TOL_T + slack)
            return maybe(t, slack + TOL_T)

    def _near(self, I, J):
        """Rows of (pair, image) whose lines may come within the radii's sum: the ones to
        settle exactly (a generous float filter)."""
        t_lo = np.maximum(self.tb[I], self.tb[J])[:, None]
        e = (self.V[J] - self.V[I])[:, None, :]
        d = (self.P[J] - self.P[I])[:, None, :] + self.shifts[None, :, :]
        p = d + e * t_lo[..., None]
        ee = np.sum(e * e, axis=-1)
        s = np.where(ee > 0, -np.sum(p * e, axis=-1) / np.where(ee > 0, ee, 1.0), 0.0)
        s = np.clip(s, 0.0, 1.0 - t_lo)
        gap = np.linalg.norm(p + e * s[..., None], axis=-1)
        R = (self.scene.radius[I] + self.scene.radius[J])[:, None]
        return np.argwhere(gap <= R + 1e-6 * (1.0 + R + SIDE + np.abs(self.P).max()))

    def contacts(self, pairs):
        """{(i, j): Outcome} for the given pairs (i < j) that may meet."""
        pairs = [(i, j) for i, j in pairs if self.alive[i] and self.alive[j]
                 and self.code[i, j] != NOTHING]
        found = {}
        if not pairs:
            return found
        I = np.array([p[0] for p in pairs])
        J = np.array([p[1] for p in pairs])
        per_pair = {}
        for q, s in self._near(I, J):
            out = self._exact(I[q], J[q], self.shifts[s])
            if out is not None:
                per_pair.setdefault((int(I[q]), int(J[q])), []).append(out)
        for key, outs in per_pair.items():
            if len(outs) == 1:
                found[key] = outs[0]
            else:                                 # two images meet: not a scene for this test
                found[key] = Outcome(False, min(o.t for o in outs), 1.0)
        return found

    # ------------------------------------------------------------- the step
    def _bounce(self, i, j, t):
        """Reflect i and j at time t (the restitution of their rules, mass fractions); their
        lines change from t on."""
        pi = self.P[i] + self.V[i] * t
        pj = self.P[j] + self.V[j] * t
        offsets = pj[None, :] + self.shifts - pi[None, :]
        k = np.argmin(np.linalg.norm(offsets, axis=1))
        normal = offsets[k] / np.linalg.norm(offsets[k])
        closing = float(np.dot(self.V[j] - self.V[i], normal))
        e = self.restitution[i, j]
        mi, mj = self.scene.mass[i], self.scene.mass[j]
        self.V[i] = self.V[i] + (1 + e) * mj / (mi + mj) * closing * normal
        self.V[j] = self.V[j] - (1 + e) * mi / (mi + mj) * closing * normal
        self.P[i] = pi - self.V[i] * t
        self.P[j] = pj - self.V[j] * t
        self.tb[i] = self.tb[j] = t
        self.changed[i] = self.changed[j] = True

    def run(self):
        """The step's contacts in time order. Returns (events, optional, issue): events the
        sure ones [(code, i, j, t, tol)], optional the sensor contacts within rounding of
        happening [(i, j)], issue None or a body to remove for an unambiguous answer."""
        n = self.scene.n
        pending = self.contacts(itertools.combinations(range(n), 2))
        events, optional, history = [], [], {}
        while pending:
            (i, j), out = min(pending.items(), key=lambda kv: (kv[1].t, kv[0]))
            del pending[(i, j)]
            code = self.code[i, j]
            changes = code in (BOUNCE, KILL)
            for k in (i, j):
                if self.changed[k]:               # meets something after its line changed
                    return events, optional, j if k == i else i
            if not out.sure:
                if changes:
                    return events, optional, j
                optional.append((i, j))
                for k in (i, j):
                    history.setdefault(k, []).append((out.t, out.tol))
                continue
            if changes:
                # a tie in time with another contact of i or j: the order is ambiguous
                tie = out.tol + 1e-9
                for (a, b), other in pending.items():
                    if {a, b} & {i, j} and other.t - out.t <= tie + other.tol:
                        return events, optional, b if a in (i, j) else a
                for k in (i, j):
                    for t_seen, tol_seen in history.get(k, []):
                        if out.t - t_seen <= tie + tol_seen:
                            return events, optional, j if k == i else i
            for k in (i, j):
                history.setdefault(k, []).append((out.t, out.tol))
            events.append((int(code), int(i), int(j), out.t, out.tol))
            if code == KILL:
                self.alive[i] = self.alive[j] = False
                pending = {key: o for key, o in pending.items() if not set(key) & {i, j}}
            elif code == BOUNCE:
                self._bounce(i, j, out.t)
                pending = {key: o for key, o in pending.items() if not set(key) & {i, j}}
                again = [(min(k, m), max(k, m)) for k in (i, j) for m in range(n) if m != k]
                pending.update(self.contacts(sorted(set(again))))
        return events, optional, None


def reference_step(scene, most_removed=None):
    """(keep, reference after its run, events, optional): the scene thinned (by at most
    most_removed bodies) until the sequential answer is unambiguous."""
    keep = np.ones(scene.n, bool)
    for _ in range(1 + (scene.n if most_removed is None else most_removed)):
        ref = Reference(scene, keep)
        events, optional, issue = ref.run()
        if issue is None:
            return keep, ref, events, optional
        keep[issue] = False
    raise AssertionError("no unambiguous scene left")        # pragma: no cover


# ----------------------------------------------------------------------------- comparing

def check_step(scene, keep, ref, events, optional):
    w, rows = build_world(scene, keep)
    index = {int(body_id): int(rows[k]) for k, body_id in enumerate(w.ids)}
    w.step(1)
    got = {}
    kills = {}
    for ev in w.events:
        if ev["kind"] in UNCHECKED:
            continue
        code = EVENT_OF.get(int(ev["kind"]))
        assert code is not None, f"unexpected event {ev}"
        i, j = index[int(ev["a"])], index[int(ev["b"])]
        key = (code, min(i, j), max(i, j))
        t = float(ev["t_in_step"]) / scene.dt
        if code == KILL:                          # one event per destroyed body
            kills.setdefault(key, []).append((i, t))
            continue
        assert key not in got, f"{key} reported twice"
        got[key] = t
    for key, seen in kills.items():
        assert sorted(k for k, _ in seen) == [key[1], key[2]] and seen[0][1] == seen[1][1], \
            f"destroy events of {key}: {seen}"
        got[key] = seen[0][1]
    expected = {(code, i, j): (t, tol) for code, i, j, t, tol in events}
    missing = sorted(set(expected) - set(got))
    extra = sorted(set(got) - set(expected) - {(SENSE, i, j) for i, j in optional})
    assert not missing and not extra, describe(scene, keep, missing, extra, expected, got)
    for key, (t, tol) in expected.items():
        assert abs(got[key] - t) <= tol, \
            f"{key}: time of impact {got[key]!r}, the reference's {t!r} (tol {tol:.2g})\n" + \
            describe(scene, keep, [], [], expected, got)
    # what is left: the bodies destroyed are gone, the others' velocities are the reference's
    dead = {k for code, i, j, _, _ in events if code == KILL for k in (i, j)}
    survivors = [index[int(b)] for b in w.ids]
    assert sorted(survivors) == sorted(set(rows.tolist()) - dead)
    vel = ref.V[survivors] / scene.dt
    scale = np.abs(scene.vel).max() + 1e-300
    np.testing.assert_allclose(w.vel, vel, rtol=0, atol=1e-9 * scale)
    return len(expected)


def describe(scene, keep, missing, extra, expected, got):
    lines = [f"missing {missing}", f"extra {extra}"]
    for code, i, j in list(missing) + list(extra):
        lines.append(f"  pair {i},{j}: pos {scene.pos[i].tolist()} {scene.pos[j].tolist()} "
                     f"vel {scene.vel[i].tolist()} {scene.vel[j].tolist()} "
                     f"radii {scene.radius[i]} {scene.radius[j]} "
                     f"ref {expected.get((code, i, j))} got {got.get((code, i, j))}")
    lines.append(f"dim {scene.dim} periodic {scene.periodic} lo {scene.lo} cell {scene.cell} "
                 f"dt {scene.dt} bodies {int(keep.sum())} rules {scene.rules}")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- the reference itself

def test_the_reference_time_of_impact_on_textbook_cases():
    def one(pos, vel, radius, response="sensor", periodic=False):
        pos = np.array(pos, float)
        scene = Scene(dim=2, pos=pos, vel=np.array(vel, float), radius=np.array(radius, float),
                      mass=np.ones(len(pos)), kind=np.zeros(len(pos), np.int64),
                      category=np.ones(len(pos), np.int64), mask=-np.ones(len(pos), np.int64),
                      rules={(0, 0): (response, None)}, periodic=periodic, lo=0.0, cell=None,
                      dt=1.0)
        return Reference(scene, np.ones(len(pos), bool)).contacts([(0, 1)]).get((0, 1))
    # head-on: gap 2 closed at 4 per step
    out = one([[0, 0], [3, 0]], [[2, 0], [-2, 0]], [0.5, 0.5])
    assert out.sure and out.t == 0.5
    # 3-4-5: relative path from (-5, 3) along +x, R = 5 / 1 ... meets at x = -4
    out = one([[0, 0], [-10, 3]], [[0, 0], [10, 0]], [2.0, 3.0])
    assert out.sure and abs(out.t - 0.6) < 1e-15
    assert one([[0, 0], [3, 0]], [[0, 0], [1.5, 0]], [0.5, 0.5]) is None   # moving away
    assert one([[0, 0], [3, 2]], [[0, 0], [-6, 0]], [0.5, 0.5]) is None    # passes by
    # touching at the start: a bounce counts it only while closing, a sensor or destroy always
    assert one([[0, 0], [1, 0]], [[0, 0], [-1, 0]], [0.5, 0.5]).t == 0.0
    assert one([[0, 0], [1, 0]], [[0, 0], [0, 1]], [0.5, 0.5]).t == 0.0
    assert one([[0, 0], [1, 0]], [[0, 0], [0, 1]], [0.5, 0.5], "elastic") is None
    assert one([[0, 0], [1, 0]], [[0, 0], [0, 1]], [0.5, 0.5], "destroy_both").t == 0.0
    # across the seam of a 64-wide box: 0.25 and 63.75 are 0.5 apart
    out = one([[0.25, 5], [63.75, 5]], [[-0.5, 0], [0.5, 0]], [0.1, 0.1], periodic=True)
    assert out.sure and abs(out.t - 0.3) < 1e-15


# ----------------------------------------------------------------------------- the step's events

@settings(max_examples=200, **PROFILE)
@given(scene=scenes(["ignore", "sensor", "sensor"]))
def test_sensor_events_are_every_contact_the_brute_force_finds(scene):
    # sensors change nothing: every pair that touches within the step is reported once, at
    # its first contact, however many contacts a body has
    keep, ref, events, optional = reference_step(scene, most_removed=0)
    check_step(scene, keep, ref, events, optional)


@settings(max_examples=200, **PROFILE)
@given(scene=scenes(["ignore", "sensor", "elastic", "bounce", "destroy_both", "destroy_both"]))
def test_bounce_and_destroy_events_are_the_sequential_brute_force_answer(scene):
    # contacts in time order: bounces change two lines, destroys end two bodies; the scene is
    # thinned until no body meets anything after its line changed (see the module)
    keep, ref, events, optional = reference_step(scene)
    check_step(scene, keep, ref, events, optional)


# ----------------------------------------------------------------------------- the broad phase

def segment_distance(P0, P1, Q0, Q1):
    """Distance between the segments P0-P1 and Q0-Q1 (arrays (..., dim)): the minimum of a
    convex function on the square of parameters, at an interior stationary point or on an
    edge (a point against a segment)."""
    def point_segment(X, A, B):
        AB = B - A
        ll = np.sum(AB * AB, axis=-1)
        s = np.where(ll > 0, np.sum((X - A) * AB, axis=-1) / np.where(ll > 0, ll, 1.0), 0.0)
        s = np.clip(s, 0.0, 1.0)
        return np.linalg.norm(A + s[..., None] * AB - X, axis=-1)
    best = np.minimum.reduce([point_segment(P0, Q0, Q1), point_segment(P1, Q0, Q1),
                              point_segment(Q0, P0, P1), point_segment(Q1, P0, P1)])
    u, v, w = P1 - P0, Q1 - Q0, P0 - Q0
    a, b, c = (np.sum(u * u, axis=-1), np.sum(u * v, axis=-1), np.sum(v * v, axis=-1))
    d, e = np.sum(u * w, axis=-1), np.sum(v * w, axis=-1)
    den = a * c - b * b
    ok = den > 1e-12 * np.maximum(a * c, 1e-300)
    safe = np.where(ok, den, 1.0)
    s, t = (b * e - c * d) / safe, (a * e - b * d) / safe
    ok &= (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1)
    inner = np.linalg.norm(w + s[..., None] * u - t[..., None] * v, axis=-1)
    return np.where(ok, np.minimum(best, inner), best)


def broad_phase_case(scene, seed):
    """The grid's candidates for the scene's bodies on their lines over [tb, 1] (tb random,
    some bodies dead), and what the brute force says must be among them."""
    rng = np.random.default_rng(seed)
    w, _ = build_world(scene)
    plan = w.tables()
    n, dim = scene.n, scene.dim
    A = np.zeros((n, 3))
    B = np.zeros((n, 3))
    A[:, :dim] = scene.pos
    B[:, :dim] = scene.vel * scene.dt
    tb = np.where(rng.random(n) < 0.3, rng.uniform(0, 0.9, n), 0.0)
    alive = rng.random(n) > 0.1
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    if plan.rules is None:                   # every pair ignored: no collision pass at all
        pairs, entries = np.zeros((0, 2), np.int64), 0
    else:
        pairs, entries = candidate_pairs(A, B, tb, alive, plan.rules, lo, hi)
    got = [tuple(p) for p in pairs.tolist()]
    # the reference: every allowed pair of live bodies whose swept discs (capsules) overlap
    code, _ = allowed_matrix(scene)
    I, J = np.triu_indices(n, 1)
    ok = alive[I] & alive[J] & (code[I, J] != NOTHING)
    I, J = I[ok], J[ok]
    starts = scene.pos + (scene.vel * scene.dt) * tb[:, None]
    ends = scene.pos + scene.vel * scene.dt
    shifts = image_shifts(scene)
    dist = np.min([segment_distance(starts[I], ends[I], starts[J] + s, ends[J] + s)
                   for s in shifts], axis=0) if I.size else np.zeros(0)
    R = scene.radius[I] + scene.radius[J]
    scale = 1.0 + np.abs(ends).max() + np.abs(scene.pos).max()
    must = {(int(i), int(j)) for i, j, dd, r in zip(I, J, dist, R) if dd < r - 1e-9 * scale}
    allowed = {(int(i), int(j)) for i, j in zip(I, J)}
    return got, must, allowed, entries


@settings(max_examples=250, **PROFILE)
@given(scene=scenes(["ignore", "sensor", "elastic", "destroy_both"], n_max=60),
       seed=st.integers(0, 2 ** 32 - 1))
def test_candidate_pairs_hold_every_pair_whose_swept_discs_overlap(scene, seed):
    got, must, allowed, _ = broad_phase_case(scene, seed)
    assert len(set(got)) == len(got), "a pair reported twice"
    assert all(i < j for i, j in got)
    assert set(got) <= allowed, f"not allowed, or dead: {sorted(set(got) - allowed)}"
    missed = sorted(must - set(got))
    assert not missed, f"swept discs overlap but the grid misses {missed}\n" + \
        describe(scene, np.ones(scene.n, bool), [], [], {}, {})


@settings(max_examples=80, **PROFILE)
@given(scene=scenes(["sensor"]))
def test_the_default_cell_holds_a_resting_body_in_at_most_two_cells_per_axis(scene):
    # the default cell is the largest diameter of the bodies in the grid (giants stay out):
    # a body at rest covers at most two cells along each axis, 2^dim entries
    scene.cell = None
    w, _ = build_world(scene)
    plan = w.tables()
    n, dim = scene.n, scene.dim
    A = np.zeros((n, 3))
    A[:, :dim] = scene.pos
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        alive = np.zeros(n, bool)
        alive[k] = True
        _, entries = candidate_pairs(A, np.zeros((n, 3)), np.zeros(n), alive, plan.rules,
                                     lo, hi)
        assert entries <= 2 ** dim, (k, scene.radius[k], scene.radius.max(), entries)


# Found by these tests: the guard in candidate_pairs capped the cells along each axis of a
# box at 1024, so a tiny body sweeping diagonally through a 3D grid (the default cell is the
# largest diameter) filled a cube of cells: two bodies of radius 0.001, one moving (0.25,
# 0.25, 0.25) in a step, made 2.0e6 grid entries; (1, 1, 1) made 1.3e8 (17 s and 4 GB for
# one step), (2, 2, 2) would have made 1e9. The box's volume is capped too now.
@pytest.mark.parametrize("speed", [0.25, 2.0])
def test_a_tiny_fast_body_does_not_fill_millions_of_cells(speed):
    w = sp.World(dim=3, gravity="none", dt=1.0)
    w.set_collision("body", "body", "sensor")
    w.add_body(1.0, (0.0, 0.0, 0.0), (speed, speed, speed), radius=0.001)
    half = 0.5 * speed
    w.add_body(1.0, (half, half, half), radius=0.001)       # on the path
    plan = w.tables()
    A = np.zeros((2, 3))
    A[:] = w.pos
    B = np.zeros((2, 3))
    B[0] = speed
    lo, hi = np.empty((2, 3)), np.empty((2, 3))
    _, entries = candidate_pairs(A, B, np.zeros(2), plan.alive, plan.rules, lo, hi)
    assert entries <= 18 ** 3 + 8             # at most ~16 cells a side, and the other body
    w.step(1)                                 # and the step finds the contact on the way
    # it passes through within the step: the overlap begins and ends
    assert w.events["kind"].tolist() == [sp.events.SENSOR_BEGIN, sp.events.SENSOR_END]
    assert w.events["time"][0] == pytest.approx(0.5 - 0.002 / (math.sqrt(3) * speed), rel=1e-12)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.sampled_from([0.0, 0.2, 0.5, 1.0, 3.0, 20.0]) | st.floats(0.0, 100.0),
                max_size=300), st.integers(1, 70))
def test_the_giants_candidates_are_the_k_largest_radii_ties_in_row_order(radii, k):
    """arrays.largest (the giants' candidates): the rows of the k largest values, largest
    first, ties in row order: a stable sort's answer, whatever the ties and the order."""
    from spacephys.kernels.arrays import largest
    values = np.array(radii, np.float64)
    assert largest(values, k).tolist() == np.argsort(-values, kind="stable")[:k].tolist()


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 70), st.sampled_from([8, 16, 24, 32, 56]), st.integers(0, 2 ** 32))
def test_the_grids_sort_is_stable_by_the_low_bits_below_and_above_its_small_size(n, bits, seed):
    """arrays.radix_sort: the entries in a stable order of their keys' low `bits` bits, as
    numpy's stable argsort gives it, whether sorted by insertion (fewer than SMALL_SORT) or by
    radix passes; keys that share their low bits (one cell's entries) keep their order."""
    from spacephys.kernels.arrays import SMALL_SORT, radix_sort
    rng = np.random.default_rng(seed)
    # few distinct low parts, high bits that differ: ties the sort must keep in order
    keys = (rng.integers(0, 6, n) | (rng.integers(0, 1 << 20, n) << bits)).astype(np.int64)
    values = np.arange(n, dtype=np.int64)
    want = np.argsort(keys & ((1 << bits) - 1), kind="stable")
    got_k, got_v = radix_sort(keys.copy(), values.copy(), np.empty(n, np.int64),
                              np.empty(n, np.int64), bits)
    assert got_v.tolist() == want.tolist() and got_k.tolist() == keys[want].tolist()
    assert SMALL_SORT <= 70                   # both ways are drawn


@pytest.mark.parametrize("size", [-1_000, 12_345, 3 << 16])
@pytest.mark.parametrize("bits", [8, 12, 16, 24, 32, 64])
def test_the_grids_sort_of_many_entries_is_numpys_stable_order_by_wide_digits(bits, size):
    """arrays.radix_sort of many entries (size: how many more than WIDE_SORT): below
    WIDE_SORT by 8-bit digits from the lowest; from it in digits up to WIDE_DIGIT bits wide
    (the last one narrower when they do not divide `bits`), the top digit first, then each
    group on its own (one digit: one pass): numpy's stable order by the low `bits` bits
    (all 64: as unsigned, the space order's Morton codes' case, negative keys included;
    fewer: other bits set above them), with groups of every kind: empty, of one entry, fewer
    than SMALL_SORT (sorted by insertion), and large; their passes ending in either pair of
    arrays; every digit drawn from a few values, so each decides some order."""
    from spacephys.kernels import arrays
    rng = np.random.default_rng([bits, size + 1_000])
    n = arrays.WIDE_SORT + size
    passes, width = arrays.digits(n, bits)
    assert (width > 8) == (n >= arrays.WIDE_SORT and bits not in (8, 16))  # wide digits
    # each digit from a few values (its top bit alone among them: a digit read a bit short
    # orders those wrong), a tenth of the keys drawn whole
    pool = np.zeros(4096, np.uint64)
    for d in range(passes):
        w = min(width, bits - width * d)
        few = np.array([0, 1, 2, 1 << (w - 1), (1 << w) - 1], np.uint64)
        pool |= rng.choice(few, 4096) << np.uint64(width * d)
    keys = pool[rng.integers(0, 4096, n)]
    whole = rng.random(n) < 0.1
    keys[whole] = rng.integers(0, 2 ** 63, whole.sum(), dtype=np.uint64) * np.uint64(2) + \
        rng.integers(0, 2, whole.sum(), dtype=np.uint64)
    # the top digit's groups
    group = rng.choice([0, 1, 2, 3, 200, 201, (1 << width) - 1], n,
                       p=[0.7, 0.1, 0.1, 0.05, 0.03, 0.0, 0.02]).astype(np.uint64)
    group[:arrays.SMALL_SORT - 5] = 201             # a group sorted by insertion
    group[-1] = 7                                   # a group of one entry
    keys = (keys & np.uint64((1 << (bits - width)) - 1)) | (group << np.uint64(bits - width))
    if bits < 64:
        keys |= rng.integers(0, 1 << 20, n).astype(np.uint64) << np.uint64(bits)
    keys = keys.view(np.int64)
    values = rng.permutation(n).astype(np.int64)
    low = keys.view(np.uint64) & np.uint64((1 << bits) - 1 if bits < 64 else 2 ** 64 - 1)
    want = np.argsort(low, kind="stable")
    got_k, got_v = arrays.radix_sort(keys.copy(), values.copy(), np.empty(n, np.int64),
                                     np.empty(n, np.int64), bits)
    assert (keys < 0).any() == (bits == 64)
    assert np.array_equal(got_v, values[want]) and np.array_equal(got_k, keys[want])


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 70), st.sampled_from([3, 1 << 11, 1 << 40, 1 << 62]), st.integers(0, 2 ** 32))
def test_the_order_of_keys_is_numpys_stable_argsort_below_and_above_its_small_size(n, top, seed):
    """arrays.radix_order (the queries' cells, the tree's keys): numpy's stable argsort of the
    keys, ties in index order, whether sorted by insertion (fewer than SMALL_SORT keys) or by
    radix passes."""
    from spacephys.kernels.arrays import SMALL_SORT, radix_order
    rng = np.random.default_rng(seed)
    keys = rng.integers(0, top, n).astype(np.int64)
    keys[rng.random(n) < 0.3] = top // 2            # ties the order must keep
    assert radix_order(keys).tolist() == np.argsort(keys, kind="stable").tolist()
    assert SMALL_SORT <= 70                          # both ways are drawn
