"""The World's forces, one component: the gravity model and its parameters, drag toward a
wind, held per-body forces and accelerations, and user forces (numba functions).

It validates every setting, keeps them, and builds the kernels' force table
(kernels/forces.Forces) that every integrator family reads: what the scene has, typed, and
None for what it has not (kernels/forces.py). Adding a gravity model touches this file (its
name and settings, `model`) and the kernel file of its table and functions
(kernels/gravity.py, or a file of its own registered there, as kernels/tree.py).
"""
import importlib

import numba
import numpy as np
from numba.core.registry import CPUDispatcher

from . import _validate as check
from ._jit import PARALLEL_MIN_PAIRS
from .kernels import forces as kforces
from .kernels import gravity as kgravity
from .kernels import tethers as ktethers
from .kernels.pairs import PAIRS_FROM
from .rails import Rails

# the gravity models by name, each with a code (kernels/gravity.py has their tables and
# functions)
GRAVITY_MODELS = {"none": 0, "direct": 1, "uniform": 2, "central": 3, "tree": 4}

# the models in which the bodies pull each other (the pulling ones: active, of mass > 0)
MUTUAL = ("direct", "tree")
THETA_MAX = 1.5       # past it a tree accepts nodes the size of their distance: no accuracy

# the per-body column of held forces and accelerations: [F (3,), a (3,)]
HELD = "held"


class ForceField:
    """Gravity, drag and the forces a game or a user adds (see the module).

    dim : 2 or 3; G : gravitational constant; gravity : a name of GRAVITY_MODELS; g : (dim,)
    the uniform field; central_mass, central_pos : the fixed body of gravity="central";
    softening : Plummer length; drag : rate k [1/time]; wind : (dim,) [length/time];
    theta, quadrupole : the tree's opening angle and moments, with gravity="tree".
    """

    def __init__(self, dim, *, G, gravity, g=None, central_mass=None, central_pos=None,
                 softening=0.0, drag=0.0, wind=None, theta=None, quadrupole=None):
        self.dim = dim
        self.G = G
        if not isinstance(gravity, str) or gravity not in GRAVITY_MODELS:
            raise ValueError(f"gravity={gravity!r} is not known; valid: "
                             f"{', '.join(GRAVITY_MODELS)}")
        field = np.zeros(3)
        field_mass = 0.0
        if gravity == "uniform":
            if g is None:
                raise ValueError("gravity='uniform' needs g, the field vector, e.g. g=(0, -9.81)")
            field[:dim] = check.floats("g", g, (dim,))
        elif g is not None:
            raise ValueError(f"g = {g!r} is only used with gravity='uniform' (gravity={gravity!r})")
        if gravity == "central":
            if central_mass is None:
                raise ValueError("gravity='central' needs central_mass, the fixed body's mass")
            field_mass = check.scalar("central_mass", central_mass, minimum=0.0)
            if central_pos is not None:
                field[:dim] = check.floats("central_pos", central_pos, (dim,))
        elif central_mass is not None or central_pos is not None:
            raise ValueError(f"central_mass/central_pos are only used with gravity='central' "
                             f"(gravity={gravity!r})")
        if gravity != "tree" and (theta is not None or quadrupole is not None):
            raise ValueError(f"theta/quadrupole are only used with gravity='tree' "
                             f"(gravity={gravity!r})")
        self.theta = self.checked_theta(0.5 if theta is None else theta)
        self.quadrupole = self.checked_quadrupole(True if quadrupole is None else quadrupole)
        self.gravity = gravity
        self.field = field                    # (3,): g, or the central body's position
        self.field_mass = field_mass
        self.softening = check.scalar("softening", softening, minimum=0.0)
        self.drag = np.zeros(4)               # [k, wind (3,)]: shared with the kernels' table
        self.drag[0] = check.scalar("drag", drag, minimum=0.0)
        if wind is not None:
            self.drag[1:1 + dim] = check.floats("wind", wind, (dim,))
        self.user = []                        # [(fn, params (p,) float64)]
        self._typed = None                    # the kernels' typed lists of them, made on demand
        self.tape = None                      # a prediction copy's tape (spacephys/tape.py)
        self.tether_ids = np.zeros((0, 3), np.int64)   # [tether id, a id, b id]
        self.tether_params = np.zeros((0, 4))          # kernels/tethers.py's params
        self.tether_next = 0                  # the next tether's id
        self.built = None                     # the last table's TetherArrays (their breaks)
        self.rails = Rails()                  # the bodies on rails (spacephys/rails.py)

    @staticmethod
    def checked_theta(theta):
        theta = check.scalar("theta", theta, positive=True)
        if theta > THETA_MAX:
            raise ValueError(f"theta = {theta}: must be <= {THETA_MAX} (an opening angle past "
                             f"it accepts nodes as large as their distance)")
        return theta

    @staticmethod
    def checked_quadrupole(quadrupole):
        if not isinstance(quadrupole, (bool, np.bool_)):
            raise ValueError(f"quadrupole = {quadrupole!r}: must be True or False")
        return bool(quadrupole)

    @property
    def mutual(self):
        """Whether the pulling bodies pull each other (direct summation or the tree)."""
        return self.gravity in MUTUAL

    # ------------------------------------------------------------ user forces
    @staticmethod
    def _checked_function(fn):
        """fn compiled for kernels.forces.USER_FORCE, or ValueError naming what is wrong."""
        if not isinstance(fn, CPUDispatcher):
            raise ValueError(f"fn = {fn!r}: a user force must be a numba function "
                             f"(@numba.njit), called inside the step kernels")
        try:
            fn.compile(kforces.USER_FORCE.args)
        except Exception as e:          # numba's typing errors have many classes
            first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise ValueError(f"fn = {fn.__name__}: does not compile as a user force "
                             f"fn(t, pos, vel, mass, ids, params, out) -> None with t float, "
                             f"pos/vel/out (n, 3) float64, mass (n,) float64, ids (n,) int64, "
                             f"params (p,) float64: {first}") from None
        result = fn.overloads[kforces.USER_FORCE.args].signature.return_type
        if result != numba.types.none:
            raise ValueError(f"fn = {fn.__name__}: returns {result}; a user force adds into "
                             f"out and returns nothing")
        return fn

    @staticmethod
    def _checked_params(params):
        arr = check.floats("params", params, (None,))
        return np.ascontiguousarray(arr)

    def add(self, fn, params):
        """Append a user force; returns its index. Checks everything before changing."""
        fn = self._checked_function(fn)
        params = self._checked_params(params)
        self.user.append((fn, params))
        self._typed = None
        return len(self.user) - 1

    def _index(self, k):
        k = check.count("k", k)
        if k >= len(self.user):
            raise ValueError(f"k = {k}: there are {len(self.user)} user forces")
        return k

    def set_params(self, k, params):
        k = self._index(k)
        params = self._checked_params(params)
        self.user[k] = (self.user[k][0], params)
        self._typed = None

    def remove(self, k):
        del self.user[self._index(k)]
        self._typed = None

    def typed_user(self, n):
        """The kernels' UserForces for n bodies, or None without user forces."""
        if not self.user:
            return None
        if self._typed is None:
            fns, params = kforces.no_user_forces()
            for fn, p in self.user:
                fns.append(fn)
                params.append(p)
            self._typed = (fns, params)
        return kforces.UserForces(*self._typed, np.zeros((n, 3)))

    # ------------------------------------------------------------ tethers
    def tether(self, a, b, length, stiffness, rigid, break_force):
        """Add a checked tether between ids a, b (World.tether checks them); its id."""
        k = self.tether_next
        self.tether_ids = np.vstack([self.tether_ids, [[k, a, b]]])
        self.tether_params = np.vstack([self.tether_params,
                                        [[length, stiffness, float(rigid), break_force]]])
        self.tether_next = k + 1
        return k

    @property
    def inextensible(self):
        """Whether any tether is inextensible (stiffness 0)."""
        return bool(np.any(self.tether_params[:, 1] == 0.0))

    def untether(self, keep):
        """Keep the tethers where the (T,) bool keep is True."""
        self.tether_ids = self.tether_ids[keep]
        self.tether_params = self.tether_params[keep]

    def broken(self):
        """(T,) bool: the tethers the kernels broke since the tables were built."""
        built = self.built
        if built is None or built.broken.size != len(self.tether_ids):
            return np.zeros(len(self.tether_ids), bool)
        return built.broken != 0

    # ------------------------------------------------------------ the table
    def table(self, mass, ids, src, passive, still, held, threads, tether_rows=None,
              fixed=None, pos=None, rails=None):
        """The kernels' Forces for the bodies mass, ids (n,); src, passive, still: int64 rows;
        held : (n, 6) or None; threads : (1,) int64 shared with World's ThreadChoice, or None
        (the scene's force loops never run on threads); tether_rows (T, 2): the tethers'
        ends' rows (None without tethers), fixed (n,) and pos (n, 3) the bodies' now; rails:
        the kernels' RailsArrays (Rails.table), or None."""
        tape = self.tape.table_for(src, ids[src]) if self.tape is not None else None
        self.built = None if tether_rows is None else \
            ktethers.make(tether_rows, self.tether_params, fixed, pos)
        return kforces.make(mass, ids, gravity=self.model(src.size), src=src,
                            passive=passive, still=still, held=held,
                            user=self.typed_user(mass.shape[0]),
                            drag=self.drag if self.drag[0] > 0.0 else None, tape=tape,
                            threads=threads, tethers=self.built, rails=rails)

    def model(self, ns, exact=False):
        """The gravity model's table (kernels/gravity.py) for ns pulling bodies (None: no
        gravity); exact: a tree's sum made directly."""
        g, eps2 = self.G, self.softening * self.softening
        if self.gravity == "direct" or (exact and self.gravity == "tree"):
            # sums: None below PAIRS_FROM, so that a few-body scene compiles no pairs code
            return kgravity.Direct(g, eps2, np.empty((4, ns)),
                                   np.empty((3, ns)) if ns >= PAIRS_FROM else None)
        if self.gravity == "tree":
            from .kernels.tree import Tree
            return Tree(g, eps2, self.theta, int(self.quadrupole), np.empty((4, ns)))
        if self.gravity == "uniform":
            return kgravity.Uniform(self.field)
        if self.gravity == "central":
            return kgravity.Central(g, eps2, self.field, self.field_mass, np.empty((4, 1)))
        return None

    def gravity_table(self, mass, ids, src, passive, exact):
        """A Forces table of gravity alone (no drag, held or user forces, nobody held still);
        exact: the tree's sum made directly."""
        return kforces.make(mass, ids, gravity=self.model(src.size, exact), src=src,
                            passive=passive, still=np.zeros(0, np.int64))

    def work(self, n, pulling):
        """Pair evaluations of the largest force loop for n bodies, `pulling` of them pulling:
        what decides whether threads can pay."""
        if self.gravity == "direct":
            return n * pulling
        if self.gravity == "tree":      # a walk's lists hold some hundreds of entries
            return n * min(pulling, 500)
        return n if self.gravity == "central" else 0

    @staticmethod
    def threaded(work):
        """Whether a scene whose largest force loop makes `work` pair evaluations may run it
        on threads at all (then its kernels compile the threaded loops)."""
        return work >= PARALLEL_MIN_PAIRS and numba.config.NUMBA_NUM_THREADS >= 2

    def shift(self, delta):
        """The origin moved by delta (3,): a central body's position with it."""
        if self.gravity == "central":
            self.field -= delta

    @property
    def potential_has_zero(self):
        """False for a uniform field, whose potential has no natural zero."""
        return self.gravity != "uniform"

    # ------------------------------------------------------------ state
    def motion(self):
        """What moves with the tables kept (worldstate.Motion): drag and wind, and the
        coasting bodies' orbits."""
        return self.drag.copy(), self.rails.motion()

    def set_motion(self, m):
        """Back to motion m; whether the tables built still hold."""
        self.drag[:] = m[0]
        return self.rails.set_motion(m[1])

    def state(self):
        """The named fields a checkpoint keeps (see docs/runlog.md)."""
        return {"gravity": self.gravity, "G": self.G, "softening": self.softening,
                "theta": self.theta, "quadrupole": self.quadrupole,
                "field": self.field.copy(), "field_mass": self.field_mass,
                "drag": self.drag.copy(),
                "user_functions": [f"{fn.py_func.__module__}:{fn.py_func.__qualname__}"
                                   for fn, _ in self.user],
                "user_params": [p.copy() for _, p in self.user],
                "tether_ids": self.tether_ids.copy(), "tether_params": self.tether_params.copy(),
                "tether_next": self.tether_next, **self.rails.state()}

    @classmethod
    def from_state(cls, dim, s):
        f = cls.__new__(cls)
        f.dim = dim
        f.G = float(s["G"])
        f.gravity = str(s["gravity"])
        f.field = np.array(s["field"], np.float64)
        f.field_mass = float(s["field_mass"])
        f.softening = float(s["softening"])
        f.theta = float(s.get("theta", 0.5))            # absent before the tree
        f.quadrupole = bool(s.get("quadrupole", True))
        f.drag = np.array(s["drag"], np.float64)
        f.user = [(importable(name), np.array(p, np.float64))
                  for name, p in zip(s["user_functions"], s["user_params"])]
        f._typed = None
        f.tape = None
        f.tether_ids = np.array(s.get("tether_ids", np.zeros((0, 3))), np.int64).reshape(-1, 3)
        f.tether_params = np.array(s.get("tether_params", np.zeros((0, 4))),
                                   np.float64).reshape(-1, 4)
        f.tether_next = int(s.get("tether_next", 0))
        f.rails = Rails.from_state(s)
        f.built = None
        return f

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_typed"] = None                # typed lists neither copy nor pickle
        state["tape"] = None                  # a copy's tape is its own (spacephys/tape.py)
        state["built"] = None                 # the tables' scratch: rebuilt with them
        return state


def importable(name):
    """The function saved as "module:qualname" (user forces are saved by name)."""
    module, _, qualname = name.partition(":")
    try:
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as e:
        raise ValueError(f"user force {name!r} cannot be imported ({e}): a World with user "
                         f"forces is saved, replayed and loaded by their module and name, so "
                         f"define them at the top level of an importable module") from None
    return obj
