"""sp.recommend: the cheapest integrator and step that meet an error target for one scene,
chosen by measuring on a copy of it, with the reasons.

The scene is read first (`Scene`): the dominant mass and the others' mass ratio, every body's
osculating orbit about the dominant body (eccentricity, pericentre, period), the closest
pulling pairs, and from these the shortest dynamical time tau and a horizon: the duration
asked for (at most 1000 tau), else the longest bound period (at most 1000 tau), else 10 tau.
Then, on copies of the World over the horizon, a converged Gauss-Radau reference (tolerance
1e-12) and, for each integrator that applies, steps from tau/20 narrowed by the
integrator's order (error ~ dt^order) to the longest that meets the target.
The error of a run is the larger of
  - the relative energy error of the pulling bodies, worst of 20 samples over the horizon
    (left out when the reference itself does not conserve energy: thrust, drag, merging),
  - each body's final position error against the reference, divided by its distance to its
    nearest pulling body at the start (a moon's error against its planet, not the star).
A duration longer than the horizon is extrapolated: position errors grow linearly with time
(a phase drift), energy errors too for the non-symplectic methods. If Gauss-Radau at 1e-9
already ends more than target/10 from the reference, the scene is chaotic over the horizon
(it amplifies differences): positions are then held to 10x that gap, energy to the target,
and the reasons say so.
"""
import dataclasses
import math
import time

import numpy as np

from ..forces import MUTUAL
from ..integrators import INTEGRATORS
from ..steppers import capabilities
from ..errors import InstabilityError

# the candidates, from the registry: the fixed-step methods of order 2 or more in the order
# they are tried (cheapest per step first; first-order ones are never the cheapest in
# docs/tradeoff.md), the ones that need one dominant mass (Wisdom-Holman), the adaptive one
FIXED = tuple(s.name for s in sorted(INTEGRATORS.values(), key=lambda s: s.evaluations)
              if not s.adaptive and s.order >= 2 and not capabilities(s.name).dominant_mass)
WISDOM_HOLMAN = tuple(s.name for s in INTEGRATORS.values()
                      if capabilities(s.name).dominant_mass)
ADAPTIVE = next(s.name for s in INTEGRATORS.values() if s.adaptive)
TOLERANCES = (1e-4, 1e-6, 1e-9)       # the adaptive method's candidates
SAMPLES = 20                          # energy samples over the horizon
MAX_STEPS = 2_000_000                 # the most steps one trial run may take
SAFETY = 0.5                          # aim the step at half the target error
DOMINANCE = 0.1                       # a body dominates if the next heaviest has < 1/10
# the tree (docs/tree.md, measured by `spacephys bench tree`): one force evaluation is cheaper
# than direct summation from about this many pulling bodies (theta 0.5, two runs of its
# crossover: 930 and 950, direct 0.65 ms and the tree 0.64 at 1 000), and
# its RMS relative force error on a Plummer sphere at each opening angle, quadrupole on
TREE_CROSSOVER = 1000
TREE_RMS = {0.3: 5.2e-5, 0.5: 3.3e-4, 0.7: 1.1e-3, 1.0: 3.9e-3}


@dataclasses.dataclass
class Scene:
    """What recommend read from the scene. Times in the World's units; ids are body ids."""
    n: int                        # bodies
    pulling: int                  # bodies that pull (active, with mass)
    dominant: int | None          # the heaviest pulling body (None: no body pulls / not direct)
    mass_ratio: float             # the other pulling bodies' mass over the dominant's
    max_eccentricity: float       # over the orbits about the dominant body (nan if none)
    min_pericentre: float         # the closest approach to the dominant body among them
    shortest_period: float        # of the bound orbits about the dominant body (inf if none)
    closest_pair: float           # the closest two pulling bodies other than the dominant
    timescale: float              # tau, the shortest dynamical time found
    timescale_source: str         # what sets tau, in words
    horizon: float                # the time the trial runs cover
    conserves_energy: bool        # measured: the reference keeps its energy to 1e-9
    chaotic: bool                 # measured: position errors of 1e-9 runs exceed the target
    advice: list                  # the scene models that would do (see docs/models.md)


@dataclasses.dataclass
class Recommendation:
    """The choice, measured: set it with .apply(world). cost: wall seconds per unit of
    simulated time (one step() call per run: a game calling step(1) each frame also pays
    about 0.1 ms per call); error: measured over the horizon (extrapolated to the duration
    if longer); met: whether it meets the target and the budget."""
    integrator: str
    dt: float
    tolerance: float | None
    max_step: float | None        # Gauss-Radau's longest substep, where collisions need one
    error: float
    cost: float
    met: bool
    scene: Scene
    reasons: list
    candidates: list              # every trial: dicts of integrator, dt, tolerance, error, cost

    def apply(self, world):
        """Set world's integrator, dt (and tolerance, max_step for Gauss-Radau)."""
        world.integrator = self.integrator
        world.dt = self.dt
        if self.tolerance is not None:
            world.tolerance = self.tolerance
        if self.max_step is not None:
            world.max_step = self.max_step

    def __str__(self):
        setting = (f"tolerance {self.tolerance:g}, dt {self.dt:g}" if self.tolerance
                   is not None else f"dt {self.dt:.6g}")
        lines = [f"{self.integrator} ({setting}): error {self.error:.2g}, "
                 f"{self.cost * 1e3:.3g} ms of wall time per unit of simulated time"]
        lines += ["  - " + r for r in self.reasons]
        lines += ["  - model: " + a for a in self.scene.advice]
        return "\n".join(lines)


def recommend(scene, error=1e-6, *, budget=None, duration=None):
    """The cheapest integrator and step for `scene` (a World, or a Scenario / scenario file
    whose World is built) meeting `error` over `duration` (default: the scene's horizon;
    a scenario's own duration), measured on copies: see the module. budget: the most wall
    seconds per unit of simulated time; when nothing meets both, the most accurate setting
    within the budget is returned with met=False and the reason. Returns a Recommendation;
    the World is not changed."""
    from ..scenario import Scenario, load_scenario
    from .. import _validate as check
    if isinstance(scene, str) or hasattr(scene, "__fspath__"):
        scene = load_scenario(scene)
    note = None
    if isinstance(scene, Scenario):
        duration = scene.duration if duration is None else duration
        if scene.timeline:
            note = (f"the scenario's timeline ({len(scene.timeline)} actions) is not in the "
                    f"trials: they run the scene as built at t = 0")
        scene = scene.build()[0]
    error = check.scalar("error", error, positive=True)
    if budget is not None:
        budget = check.scalar("budget", budget, positive=True)
    if duration is not None:
        duration = check.scalar("duration", duration, positive=True)
    if not hasattr(scene, "step") or not hasattr(scene, "copy"):
        raise ValueError(f"scene = {scene!r}: expected a World, a Scenario or a scenario "
                         f"file")
    if scene.n == 0:
        raise ValueError("recommend: the World has no bodies")
    trials = _Trials(scene, error, budget, duration)
    if note:
        trials.reasons.append(note)
    return trials.choose()


# ----------------------------------------------------------------------------- the scene

def _orbits(w):
    """(dominant row or None, mu (n,), e (n,), pericentre q (n,), period (n,), time at
    pericentre (n,)) for every body's osculating orbit about the dominant mass (nan where
    it does not apply)."""
    n = w.n
    nan = np.full(n, np.nan)
    pos, vel, mass, pulls = w.pos, w.vel, w.mass, w.pulls
    if w.gravity == "central":
        centre, cvel, M, dominant = w.central_pos, np.zeros(w.dim), w.central_mass, None
        others = np.ones(n, bool)
    elif w.gravity in MUTUAL and pulls.any() and \
            np.sort(np.where(pulls, mass, 0.0))[-2:][0] < DOMINANCE * mass[pulls].max():
        dominant = int(np.argmax(np.where(pulls, mass, -1.0)))
        centre, cvel, M = pos[dominant], vel[dominant], mass[dominant]
        others = np.arange(n) != dominant
    else:
        return None, nan, nan, nan, nan, nan
    # about a fixed field the orbit's mu is G M; about a body, G (M + m) for a pulling m
    mu = w.G * (M + (0.0 if dominant is None else np.where(pulls, mass, 0.0)))
    r = pos - centre
    v = vel - cvel
    rn = np.linalg.norm(r, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        energy = 0.5 * (v ** 2).sum(axis=1) - mu / rn
        h = np.cross(np.pad(r, ((0, 0), (0, 3 - w.dim))), np.pad(v, ((0, 0), (0, 3 - w.dim))))
        h2 = (h ** 2).sum(axis=1)
        e = np.sqrt(np.maximum(1.0 + 2.0 * energy * h2 / mu ** 2, 0.0))
        # pericentre of any conic, softened; 0 (a radial fall onto the body) leaves it out
        q = np.sqrt((h2 / (mu * (1.0 + e))) ** 2 + w.softening ** 2)
        q[q == 0] = np.nan
        a = -mu / (2.0 * energy)
        period = np.where(energy < 0, 2 * np.pi * np.sqrt(np.abs(a) ** 3 / mu), np.inf)
        t_peri = np.sqrt(q ** 3 / (mu * (1.0 + e)))     # pericentre / speed there
    ok = others & (mu > 0) & (rn > 0)
    return (dominant, np.where(ok, mu, np.nan), np.where(ok, e, np.nan),
            np.where(ok, q, np.nan), np.where(ok, period, np.nan), np.where(ok, t_peri, np.nan))


def _closest_pair(w, rows):
    """(separation, dynamical time sqrt(D^3 / G(m_i + m_j))) of the closest pulling pair
    among rows (softened distance D), or (inf, inf)."""
    if rows.size < 2:
        return math.inf, math.inf
    rows = rows[:2000]                           # a sample is enough for huge clusters
    p, m = w.pos[rows], w.mass[rows]
    d = np.sqrt(((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=2) + w.softening ** 2)
    d[np.diag_indices(rows.size)] = np.inf
    with np.errstate(divide="ignore"):
        tau = np.sqrt(d ** 3 / (w.G * (m[:, None] + m[None, :])))
    return float(d.min()), float(tau.min())


def _scene(w, error, duration):
    dominant, mu, e, q, period, t_peri = _orbits(w)
    pulling = np.flatnonzero(w.pulls) if w.gravity in MUTUAL else np.zeros(0, np.int64)
    mass_ratio = 0.0
    if dominant is not None:
        mass_ratio = float(w.mass[pulling].sum() / w.mass[dominant] - 1.0)
    pair_rows = pulling[pulling != dominant] if dominant is not None else pulling
    pair, t_pair = _closest_pair(w, pair_rows)
    with np.errstate(invalid="ignore"):
        found = [(np.nanmin(t_peri) if np.isfinite(t_peri).any() else math.inf,
                  "the pericentre passage of body {}".format(
                      int(w.ids[np.nanargmin(t_peri)])) if np.isfinite(t_peri).any() else ""),
                 (t_pair, "the closest pulling pair")]
    tau, source = min(found, key=lambda x: x[0])
    bound = period[np.isfinite(period)]
    if not math.isfinite(tau):
        tau, source = 100 * w.dt, "no orbits (a uniform field or free motion): 100 steps of dt"
    # a bound scene: its longest orbit (at most 1000 tau); else ten dynamical times
    horizon = float(min(bound.max(), 1000 * tau)) if bound.size else 10 * tau
    if duration is not None:                # the whole run, unless it is very long
        horizon = min(duration, max(horizon, 1000 * tau))
    if horizon >= SAMPLES * w.dt:           # whole output intervals (see output_interval)
        horizon = math.ceil(horizon / w.dt - 1e-9) * w.dt
    advice = _advice(w, error, dominant, mass_ratio)
    return Scene(n=w.n, pulling=int(w.pulls.sum()), dominant=None if dominant is None else
                 int(w.ids[dominant]), mass_ratio=mass_ratio,
                 max_eccentricity=float(np.nanmax(e)) if np.isfinite(e).any() else math.nan,
                 min_pericentre=float(np.nanmin(q)) if np.isfinite(q).any() else math.nan,
                 shortest_period=float(bound.min()) if bound.size else math.inf,
                 closest_pair=pair, timescale=float(tau), timescale_source=source,
                 horizon=float(horizon), conserves_energy=True, chaotic=False, advice=advice)


def _tree_advice(w, error):
    """What the tree would do for a scene of many pulling bodies, or what it does to this
    one (docs/tree.md has its cost and accuracy)."""
    pulling = int(w.pulls.sum())
    fits = [t for t, rms in sorted(TREE_RMS.items()) if rms <= error]
    if w.gravity == "tree":
        out = []
        if pulling < TREE_CROSSOVER:
            out.append(f"only {pulling} bodies pull: below about {TREE_CROSSOVER} direct "
                       f"summation (gravity='direct') is faster than the tree, and exact")
        if TREE_RMS.get(w.theta, math.inf) > error or not fits:
            out.append(f"the tree's own force error (RMS {TREE_RMS.get(w.theta, math.nan):.1g} "
                       f"at theta {w.theta:g} on a Plummer sphere, docs/tree.md) is not part "
                       f"of the errors measured here (the reference runs the same tree): "
                       + (f"theta {max(fits):g} keeps it within {error:g}" if fits else
                          f"no opening angle keeps it within {error:g}: gravity='direct'"))
        return out
    if pulling < TREE_CROSSOVER:
        return []
    if not fits:
        return [f"{pulling} bodies pull: the tree (gravity='tree') would cost O(N log N) "
                f"instead of O(N^2), but its force error (RMS {min(TREE_RMS.values()):.1g} at "
                f"theta 0.3) is above {error:g}: direct summation is needed"]
    theta = max(fits)
    return [f"{pulling} bodies pull: gravity='tree' with theta={theta:g} costs O(N log N) "
            f"instead of O(N^2) per force evaluation (faster from about {TREE_CROSSOVER} "
            f"pulling bodies) with relative force errors of RMS {TREE_RMS[theta]:.1g} "
            f"(docs/tree.md), within {error:g}"]


def _advice(w, error, dominant, mass_ratio):
    """The simpler gravity models that would meet `error` (docs/models.md has their cost)."""
    out = _tree_advice(w, error) if w.gravity in MUTUAL else []
    if w.gravity != "direct" or dominant is None:
        return out
    mass, pulls = w.mass, w.pulls
    light = pulls & (mass < error * mass[dominant])
    light[dominant] = False
    if light.any():
        out.append(f"{int(light.sum())} pulling bodies have less than {error:g} of the "
                   f"dominant mass: their pull moves the others by about that fraction, so "
                   f"as test particles (active=False) they would cost O(N) instead of O(N^2)")
    R = w.radius[dominant]
    if R > 0 and w.n > 1:
        h = np.linalg.norm(w.pos - w.pos[dominant], axis=1) - R
        h[dominant] = 0.0
        # the field falls as (R / (R + h))^2, about 1 - 2 h / R across the bodies' heights
        if np.all(h >= 0) and 2 * h.max() / R < error:
            g = w.G * mass[dominant] / R ** 2
            out.append(f"every body is within {h.max():.3g} of body {int(w.ids[dominant])}'s "
                       f"surface, where its field varies by 2h/R = {2 * h.max() / R:.2g}: "
                       f"gravity='uniform' with |g| = {g:.6g} is the surface model")
    if mass_ratio == 0 and not out:
        out.append(f"only body {int(w.ids[dominant])} pulls: the others are already test "
                   f"particles in its field, O(N) (gravity='central' would also pin it in "
                   f"place)")
    if 0 < mass_ratio < error and not out:
        out.append(f"the other pulling bodies hold {mass_ratio:.2g} of the dominant mass: "
                   f"gravity='central' (a fixed body, bodies ignoring each other) or making "
                   f"them test particles changes the orbits by about that fraction")
    if not out:
        out.append("full N-body (gravity='direct'): the pulling bodies' masses matter at "
                   "this error target")
    return out


# ----------------------------------------------------------------------------- the trials

def _state(w):
    return dict(zip(w.ids.tolist(), w.pos.copy()))


class _Trials:
    def __init__(self, world, error, budget, duration):
        # the trials run on copies: unwatched (the user's energy limit is not the target),
        # and with the origin at the bodies' mean position, since far from the origin
        # precision is lost (docs/extremes.md) and position errors are differences anyway
        world = world.copy()
        world.watch_energy(None)
        self.steering = world.actor_ids.size > 0
        # with collisions Gauss-Radau's substeps must not step over a contact
        self.collisions = world.collides
        world.shift_origin(world.pos.mean(axis=0))
        self.w = world
        self.target = error
        self.budget = budget
        self.duration = duration
        self.scene = _scene(world, error, duration)
        self.rows = []
        self.reasons = []
        self.warm = set()
        self.position_target = error        # relaxed when the scene is chaotic
        self.adaptive_applies = world.gravity in capabilities(ADAPTIVE).models
        if not self.adaptive_applies:
            self.reasons.append(f"Gauss-Radau not tried: it cannot run gravity="
                                f"{world.gravity!r} (a tree's forces jump where a node opens)")
        # Gauss-Radau's substeps at most tau/20: the reference's always, the trials' (and the
        # returned setting's) where a collision could otherwise be stepped over
        self.short_step = min(world.max_step or math.inf, self.scene.timescale / 20)
        self.max_step = self.short_step if self.collisions else None
        # each body's length scale: its distance to the nearest pulling body (else the
        # scene's size), for the relative position error
        pulls = np.flatnonzero(world.pulls)[:2000] if world.gravity in MUTUAL else \
            np.zeros(0, np.int64)
        size = float(np.linalg.norm(world.pos - world.pos.mean(axis=0), axis=1).max()) or 1.0
        self.size = size
        if world.gravity == "central":
            scale = np.linalg.norm(world.pos - world.central_pos, axis=1)
            scale[scale == 0] = size
        elif pulls.size:
            d = np.linalg.norm(world.pos[:, None, :] - world.pos[None, pulls, :], axis=2)
            d[d == 0] = np.inf
            scale = np.where(np.isfinite(d.min(axis=1)), d.min(axis=1), size)
        else:
            scale = np.full(world.n, size)
        self.scale = dict(zip(world.ids.tolist(), np.maximum(scale, max(world.softening,
                                                                        1e-300))))

    def output_interval(self):
        """(dt, step counts of the 20 samples) for Gauss-Radau: the World's own dt, which
        apply() keeps and at whose multiples Gauss-Radau lands (the horizon is a whole
        number of them), or horizon/20 if dt is longer."""
        H = self.scene.horizon
        n = round(H / self.w.dt)
        if n < SAMPLES:
            return H / SAMPLES, [1] * SAMPLES
        return self.w.dt, [n // SAMPLES + (k < n % SAMPLES) for k in range(SAMPLES)]

    def trial_world(self, integrator, dt, tolerance):
        """A copy of the scene set up for one trial (Gauss-Radau: with tolerance, and with
        the returned max_step where there are collisions)."""
        w = self.w.copy()
        w.integrator, w.dt = integrator, dt
        if tolerance is not None:
            w.tolerance = tolerance
            if self.max_step is not None:
                w.max_step = self.max_step
        return w

    def run(self, integrator, dt=None, tolerance=None):
        """Run a copy over the horizon: (energies at the samples, final positions by id,
        wall seconds, steps, dt) or (None, (refused | failed, why))."""
        if integrator not in self.warm:          # compile or load the kernel: not timed
            self.warm.add(integrator)
            try:
                self.trial_world(integrator, self.scene.timescale / 100, tolerance).step(1)
            except (ValueError, FloatingPointError):
                pass
        H = self.scene.horizon
        if tolerance is not None:
            dt, chunks = self.output_interval()
        else:
            n = max(SAMPLES, SAMPLES * math.ceil(H / dt / SAMPLES))
            dt, chunks = H / n, [n // SAMPLES] * SAMPLES
        w = self.trial_world(integrator, dt, tolerance)
        energies, seconds = [w.energy(True)], 0.0
        try:
            for k in chunks:
                start = time.perf_counter()
                w.step(k)
                seconds += time.perf_counter() - start
                energies.append(w.energy(True))
        except ValueError as e:                    # the integrator does not apply
            return None, ("refused", str(e).split(". ")[0])
        except FloatingPointError as e:            # it broke down (InstabilityError too)
            return None, ("failed", str(e).split(". ")[0])
        return (np.array(energies), _state(w), seconds, sum(chunks), w.dt), None

    def measure(self, integrator, dt=None, tolerance=None):
        """Run, compare with the reference, book the row; returns it (error inf if the run
        was refused or failed)."""
        result, failure = self.run(integrator, dt, tolerance)
        row = {"integrator": integrator, "dt": dt, "tolerance": tolerance}
        self.rows.append(row)
        if result is None:
            row.update(error=math.inf, cost=math.inf, energy_error=math.inf,
                       position_error=math.inf)
            row[failure[0]] = failure[1]
            return row
        energies, final, seconds, steps, dt = result
        E0 = energies[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            energy_error = float(np.max(np.abs(energies / E0 - 1))) if E0 else 0.0
        if final.keys() != self.ref_final.keys():
            position_error = math.inf             # a different set of bodies survived
        else:
            position_error = max(float(np.linalg.norm(final[i] - self.ref_final[i]))
                                 / self.scale.get(i, self.size) for i in final)
        # the best of repeats (a busy machine stalls single runs), at least 0.05 s of them
        cost = min(seconds, self._retime(integrator, dt, tolerance, steps, seconds)) \
            / self.scene.horizon
        row.update(dt=dt, energy_error=energy_error, position_error=position_error,
                   cost=cost, steps=steps)
        row["error"] = self.error(row)
        return row

    def error(self, row):
        """The row's error as judged for this scene (see the module), extrapolated to the
        duration: the larger of the energy error (where energy is conserved) and the position
        error scaled to the target (the position target is relaxed where the scene is
        chaotic, so that it meets the target exactly when both are within theirs)."""
        symplectic = INTEGRATORS[row["integrator"]].symplectic
        grow = max(1.0, (self.duration or 0.0) / self.scene.horizon)
        errors = [row["position_error"] * grow * self.target / self.position_target]
        if self.scene.conserves_energy:
            errors.append(row["energy_error"] * (1.0 if symplectic else grow))
        value = max(errors)
        return value if math.isfinite(value) else math.inf

    def _retime(self, integrator, dt, tolerance, steps, spent):
        """The shortest of repeated runs (one step() call each, the first took `spent`): at
        least 0.05 s of them, and 3 runs while they take under 0.5 s in all."""
        best, runs = math.inf, 1
        while spent < 0.05 or runs < 3 and spent < 0.5:
            w = self.trial_world(integrator, dt, tolerance)
            start = time.perf_counter()
            w.step(steps)
            took = time.perf_counter() - start
            best, spent, runs = min(best, took), spent + took, runs + 1
            if spent > 1.0:
                break
        return best

    def ok(self, row):
        return row["error"] <= self.target and (self.budget is None
                                                 or row["cost"] <= self.budget)

    def reference(self):
        """The converged run the trials are judged against: Gauss-Radau at 1e-12, its
        substeps at most tau/20 so that no collision is stepped over; a Yoshida 8 at tau/50
        instead where ships steer (their controls act per step of a fixed-step method)."""
        w = self.w
        s = self.scene
        ref = w.copy()
        self.fine = self.steering or not self.adaptive_applies
        if self.fine:
            ref.integrator = "yoshida8"
            ref.dt = s.horizon / (SAMPLES * math.ceil(s.horizon / (s.timescale / 50) / SAMPLES))
            chunks = [round(s.horizon / ref.dt)]
            self.ref_name = ("Yoshida 8 at tau/50 (steering ships)" if self.steering else
                             f"Yoshida 8 at tau/50 (Gauss-Radau cannot run gravity="
                             f"{w.gravity!r})")
        else:
            # its output interval need not be the World's (nothing steers): only where it
            # ends matters, and its substeps are kept short enough for every contact
            self.ref_name = "Gauss-Radau at 1e-12"
            ref.integrator, ref.tolerance = "gauss_radau", 1e-12
            ref.max_step = self.short_step
            ref.dt, chunks = s.horizon / SAMPLES, [1] * SAMPLES
        E0 = ref.energy(True)
        try:
            for k in chunks:
                ref.step(k)
        except FloatingPointError as e:
            message = (f"recommend: the reference run ({ref.integrator}) failed, so nothing "
                       f"can be judged: {e}")
            if isinstance(e, InstabilityError):
                raise InstabilityError(message, e.ids, e.t) from e
            raise FloatingPointError(message) from e
        self.ref_final = _state(ref)
        if self.ref_final.keys() != set(w.ids.tolist()):
            self.reasons.append(
                "bodies were destroyed, merged or created during the horizon: a contact is "
                "found at the end of the step it happens in, so what follows it shifts with "
                "the step and errors there fall only about linearly with dt")
        self.rails_advice()
        s.conserves_energy = bool(w.gravity != "uniform" and
                                  (E0 == 0 or abs(ref.energy(True) / E0 - 1) < 1e-9))
        if w.gravity == "uniform":
            self.reasons.append("a uniform field's energy has no natural zero: judged by "
                                "position error only")
        elif not s.conserves_energy and w.gravity == "tree":
            self.reasons.append("the tree keeps energy only to its force error (docs/tree.md): "
                                "judged by position error only")
        elif not s.conserves_energy:
            self.reasons.append("the scene does not conserve energy (thrust, drag or merging "
                                "bodies): judged by position error only")

    def rails_advice(self):
        """Measured: whose Kepler orbit about the dominant body (its state now) ends the
        horizon within the target of the reference run (relative, as the trials' position
        errors): those could fly on rails or coast (docs/models.md#coasting)."""
        from ..kernels.coast import conic_states
        from ..rails import elements
        w, s = self.w, self.scene
        if s.dominant is None or w.gravity != "direct" or self.steering:
            return
        d = w.index_of(s.dominant)
        t_end = w.t + s.horizon

        def still(i):                # fixed (or at rest with nothing moving it)
            body = int(w.ids[i])
            return not w.vel[i].any() and np.array_equal(self.ref_final.get(body), w.pos[i])

        fixed_parent = still(d)
        pad = (0.0,) * (3 - w.dim)
        bodies, orbits = [], []
        for i in range(w.n):
            body = int(w.ids[i])
            if i == d or body not in self.ref_final or still(i):
                continue
            mu = w.G * (float(w.mass[d]) + (0.0 if fixed_parent else float(w.mass[i])))
            try:
                orbits.append(elements(np.append(w.pos[i] - w.pos[d], pad),
                                       np.append(w.vel[i] - w.vel[d], pad), mu, w.t))
            except ValueError:       # a radial or near-parabolic orbit: not a rails orbit
                continue
            bodies.append(body)
        if not bodies:
            return
        out = np.zeros((len(bodies), 6))       # every body's place at the horizon, at once
        conic_states(np.array(orbits), np.arange(len(bodies), dtype=np.int64), float(t_end),
                     out)
        errors = {body: float(np.linalg.norm(self.ref_final[s.dominant] + out[k, :w.dim] -
                                             self.ref_final[body])) /
                  self.scale.get(body, self.size) for k, body in enumerate(bodies)}
        good = [b for b, e in errors.items() if e <= self.target]
        worst = max(errors.values())
        if len(good) == len(errors):
            s.advice.append(
                f"on Kepler orbits about body {s.dominant} every other body ends the horizon "
                f"within {worst:.2g} of the full run (measured): pulling bodies on rails "
                f"(set_rails(id, about={s.dominant})) and ships and debris coasting (coast) "
                f"meet {self.target:g}, each a Kepler solution instead of a force sum, and "
                f"with nothing integrated time passes in jumps (advance(warp=...))")
        elif good:
            s.advice.append(
                f"{len(good)} of {len(errors)} bodies end the horizon on their Kepler orbits "
                f"about body {s.dominant} within {self.target:g} of the full run (measured): "
                f"they could be on rails or coasting (ids {good[:8]}"
                f"{' ...' if len(good) > 8 else ''}); the others, up to {worst:.2g} off, need "
                f"integrating")

    def choose(self):
        s = self.scene
        self.reference()
        best = None

        def consider(row):
            nonlocal best
            if self.ok(row) and (best is None or row["cost"] < best["cost"]):
                best = row

        for tol in TOLERANCES[::-1] if self.adaptive_applies else ():   # 1e-9 first: chaos
            row = self.measure(ADAPTIVE, tolerance=tol)
            floor = row["position_error"]
            if tol == TOLERANCES[-1] and not self.fine and \
                    self.target < 10 * floor < math.inf:
                # two converged runs already differ: the scene amplifies differences
                s.chaotic = True
                self.position_target = 10 * floor
                self.reasons.append(
                    f"chaotic over the horizon: Gauss-Radau at 1e-9 and 1e-12 already "
                    f"end {floor:.2g} apart (relative), so positions are held to "
                    f"{self.position_target:.2g}, energy to {self.target:g}")
                row["error"] = self.error(row)
            consider(row)
        fixed = list(FIXED)
        if self._wisdom_holman_applies():
            fixed = list(WISDOM_HOLMAN) + fixed
        for name in fixed:
            consider(self._narrow(name, best))
        if best is None:
            return self._fallback()
        return self._result(best)

    def _wisdom_holman_applies(self):
        w, s = self.w, self.scene
        why = None
        if w.gravity != "direct":
            why = f"it needs gravity='direct' (this scene: {w.gravity!r})"
        elif w.n < 2:
            why = "one body: nothing orbits"
        elif s.dominant is None:
            why = "there is no dominant pulling body"
        elif s.mass_ratio > 0.01:
            why = f"the other pulling bodies hold {s.mass_ratio:.2g} of the dominant mass"
        if why:
            self.reasons.append(f"Wisdom-Holman not tried: {why}")
        return why is None

    def _narrow(self, name, best):
        """The longest step meeting the target for one fixed-step integrator: from `start`,
        each next step predicted from the measured error and the order (error ~ dt^order),
        kept between the longest step that met the target and the shortest that did not;
        stops when they are close, when shorter steps stop helping (round-off), or when the
        cost could not beat the best so far."""
        order = INTEGRATORS[name].order
        s = self.scene
        dt = s.timescale / 20
        if name in WISDOM_HOLMAN:         # the Kepler motion is exact: the step follows periods
            dt = max(dt, s.shortest_period / 20)
        met, missed, row = None, math.inf, None
        for _ in range(5):
            dt = min(dt, s.horizon / SAMPLES)
            if s.horizon / dt > MAX_STEPS:
                break
            if row is not None and best is not None and dt < row["dt"] and \
                    "failed" not in row and row["cost"] * row["dt"] / dt > best["cost"]:
                break                            # shorter steps cost more than the best
            row = self.measure(name, dt)
            if "refused" in row:
                break
            if row["error"] <= self.target:
                met = row if met is None or row["cost"] < met["cost"] else met
            else:
                missed = min(missed, row["dt"])
            if "failed" in row:
                factor = 0.1
            else:
                factor = (SAFETY * self.target / max(row["error"], 1e-300)) ** (1.0 / order)
            if row["error"] > self.target and factor > 0.9:
                break                            # round-off: shorter steps won't help
            low = met["dt"] if met else 0.0
            # at most 4x shorter per trial: where the error does not follow dt^order (close
            # passes, a relaxed target), a bold jump would skip the steps that meet it
            new = min(max(dt * min(max(factor, 0.25), 8.0), low), 0.9 * missed,
                      s.horizon / SAMPLES)
            if abs(new / dt - 1) < 0.2 or met and new <= low * 1.25:
                break                            # close enough to the longest that meets
            dt = new
        return met or row or {"integrator": name, "dt": dt, "tolerance": None,
                              "error": math.inf, "cost": math.inf}

    def _fallback(self):
        """Nothing met the target (within the budget): the most accurate run that fits the
        budget, or the most accurate of all."""
        rows = [r for r in self.rows if math.isfinite(r["error"])]
        fits = [r for r in rows if self.budget is None or r["cost"] <= self.budget]
        if not rows:
            self.reasons.append("no trial ended with the reference's bodies (collisions, "
                                "merges or explosions went differently) or finished at all")
            rows = [r for r in self.rows if "steps" in r] or self.rows
        pick = min(fits or rows, key=lambda r: r["error"])
        self.reasons.append(
            f"no trial met error {self.target:g}"
            + (f" within the budget of {self.budget:g} s per unit time" if self.budget else "")
            + f": the most accurate {'within the budget' if fits else 'trial'} is returned")
        return self._result(pick, met=False)

    def _result(self, row, met=True):
        s = self.scene
        name = row["integrator"]
        spec = INTEGRATORS[name]
        dt = row["dt"]
        reasons = [f"shortest dynamical time {s.timescale:.3g} ({s.timescale_source}); "
                   f"trials over {s.horizon:.4g} time units against {self.ref_name}"]
        if s.dominant is not None:
            reasons.append(f"dominant body {s.dominant}, the other pulling bodies hold "
                           f"{s.mass_ratio:.2g} of its mass; eccentricities up to "
                           f"{s.max_eccentricity:.4g}, closest approach to it "
                           f"{s.min_pericentre:.3g}")
        if self.duration and self.duration > s.horizon * (1 + 1e-9):
            reasons.append(f"errors extrapolated from {s.horizon:.4g} to the duration "
                           f"{self.duration:g}: linearly for positions"
                           + ("" if spec.symplectic else " and energy"))
        cheaper = sorted((r for r in self.rows if r["cost"] < math.inf
                          and r["cost"] < row["cost"]), key=lambda r: -r["cost"])[:2]
        for r in cheaper:
            why = "failed: " + r["failed"] if "failed" in r else f"error {r['error']:.2g}"
            reasons.append(f"cheaper but not good enough: {r['integrator']} "
                           f"({_setting(r)}): {why}")
        reasons += self.reasons
        max_step = self.max_step if row["tolerance"] is not None else None
        if max_step is not None:
            reasons.append(f"max_step {max_step:.3g} (tau/20): substeps short enough not to "
                           f"step over a collision")
        return Recommendation(integrator=name, dt=dt, tolerance=row["tolerance"],
                              max_step=max_step,
                              error=row["error"], cost=row["cost"], met=met, scene=s,
                              reasons=reasons, candidates=self.rows)


def _setting(row):
    if row["tolerance"] is not None:
        return f"tolerance {row['tolerance']:g}"
    return f"dt {row['dt']:.3g}"
