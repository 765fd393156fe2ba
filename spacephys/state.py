"""Structure-of-arrays body storage: live bodies packed at [0, n), capacity that grows by
doubling, and stable generational ids.

An id is (generation << 32) | slot. Removing a body bumps its slot's generation, so the old id
turns stale and never names a later body; freed slots are reused first-in first-out, which keeps
the slot table as large as the most bodies ever alive at once. First-generation ids are 0, 1, 2...
"""
import numpy as np

_SLOT_BITS = 32
_SLOT_MASK = (1 << _SLOT_BITS) - 1

# per-body columns: name -> (trailing shape, dtype)
_COLUMNS = {
    "ids": ((), np.int64),
    "pos": ((3,), np.float64),
    "vel": ((3,), np.float64),
    "prev": ((3,), np.float64),     # positions before the latest step, for render interpolation
    "mass": ((), np.float64),
    "radius": ((), np.float64),
    "kind": ((), np.int16),
    "active": ((), np.bool_),
    "fixed": ((), np.bool_),        # immovable: infinite inertial mass, never moves
    "category": ((), np.int64),     # collision filter: the bits a body is...
    "mask": ((), np.int64),         # ...and the bits it collides with
    "serial": ((), np.int64),       # order of addition (rows move when bodies are removed)
}


class Bodies:
    """Per-body columns of length `capacity`; rows [0, n) are the live bodies. Removing bodies
    moves the last rows into the holes (O(removed), not O(n)); `serial` keeps the order of
    addition for whoever needs it.

    Columns: ids (int64), pos/vel/prev (cap, 3) float64, mass/radius float64, kind int16,
    active bool. Always 3 components: a 2D world keeps z = 0, so one set of kernels serves both.
    """

    def __init__(self, capacity=64):
        capacity = max(int(capacity), 1)
        self.n = 0
        self.columns = dict(_COLUMNS)
        self.defaults = {}                # columns whose default is not 0
        for name, (shape, dtype) in _COLUMNS.items():
            setattr(self, name, np.zeros((capacity,) + shape, dtype=dtype))
        self.generation = np.zeros(capacity, dtype=np.int64)   # per slot
        self.index = np.full(capacity, -1, dtype=np.int64)     # per slot: row of its body, -1 free
        self.slots_used = 0                                    # slots ever handed out
        self.added = 0                                         # bodies ever added
        self.free = np.zeros(0, dtype=np.int64)                # freed slots, oldest first

    @property
    def capacity(self):
        return self.mass.shape[0]

    def ensure_column(self, name, shape=(), dtype=np.float64, default=0):
        """Add a per-body column that grows, compacts and copies with the others, holding
        `default` for every body that exists or is added without a value for it; integrators
        and ships keep per-body state this way (Gauss-Radau's polynomial, fuel, heading)."""
        if name not in self.columns:
            self.columns[name] = (tuple(shape), dtype)
            self.defaults[name] = default
            setattr(self, name, np.full((self.capacity,) + tuple(shape), default, dtype=dtype))
        return getattr(self, name)

    def _grow(self, need):
        """Make room for `need` rows, doubling so that growth is amortised O(1) per body."""
        cap = self.capacity
        if need <= cap:
            return
        new = max(need, 2 * cap)
        for name in self.columns:
            old = getattr(self, name)
            arr = np.full((new,) + old.shape[1:], self.defaults.get(name, 0), dtype=old.dtype)
            arr[:self.n] = old[:self.n]
            setattr(self, name, arr)

    def _grow_slots(self, need):
        cap = self.generation.shape[0]
        if need <= cap:
            return
        new = max(need, 2 * cap)
        self.generation = np.concatenate([self.generation, np.zeros(new - cap, np.int64)])
        self.index = np.concatenate([self.index, np.full(new - cap, -1, np.int64)])

    def add(self, columns):
        """Append k bodies; columns maps column names to (k, ...) arrays (ids and prev are set
        here; columns not given take their default: 0 unless ensure_column said otherwise).
        The caller has validated everything, so this cannot fail half-way. Returns (k,) ids.
        """
        k = len(columns["mass"])
        n = self.n
        self._grow(n + k)
        reused = self.free[:k]
        fresh = np.arange(self.slots_used, self.slots_used + (k - reused.size), dtype=np.int64)
        slots = np.concatenate([reused, fresh])
        self._grow_slots(self.slots_used + fresh.size)
        self.free = self.free[reused.size:]
        self.slots_used += fresh.size
        ids = (self.generation[slots] << _SLOT_BITS) | slots
        for name in self.columns:
            getattr(self, name)[n:n + k] = columns.get(name, self.defaults.get(name, 0))
        self.ids[n:n + k] = ids
        self.serial[n:n + k] = np.arange(self.added, self.added + k)
        self.added += k
        self.prev[n:n + k] = self.pos[n:n + k]
        self.index[slots] = np.arange(n, n + k)
        self.n = n + k
        return ids

    def lookup(self, ids):
        """Rows of the given ids: (k,) int64, or -1 where an id names no live body."""
        ids = np.asarray(ids, dtype=np.int64)
        slots = ids & _SLOT_MASK
        rows = np.full(ids.shape, -1, dtype=np.int64)
        ok = (ids >= 0) & (slots < self.slots_used)
        ok[ok] &= self.generation[slots[ok]] == (ids[ok] >> _SLOT_BITS)
        rows[ok] = self.index[slots[ok]]
        return rows

    def row(self, body_id):
        """The row of one id (a Python int), -1 if it names no live body: lookup without
        numpy, for the per-call paths (control, get)."""
        slot = body_id & _SLOT_MASK
        if body_id < 0 or slot >= self.slots_used or \
                self.generation.item(slot) != body_id >> _SLOT_BITS:
            return -1
        return self.index.item(slot)

    def remove(self, rows):
        """Delete the bodies at the given (validated, distinct) rows: the last live rows move
        into the holes, so the cost is O(removed) whatever the number of bodies."""
        rows = np.asarray(rows, dtype=np.int64)
        n = self.n
        m = n - rows.size
        slots = self.ids[rows] & _SLOT_MASK
        self.generation[slots] += 1      # every id that named these bodies is now stale
        self.index[slots] = -1
        self.free = np.concatenate([self.free, slots])
        gone = np.zeros(n - m, dtype=bool)
        tail = rows[rows >= m] - m
        gone[tail] = True
        holes = np.sort(rows[rows < m])
        movers = m + np.flatnonzero(~gone)             # live rows past the new end, in order
        for name in self.columns:
            col = getattr(self, name)
            col[holes] = col[movers]
        self.n = m
        self.index[self.ids[holes] & _SLOT_MASK] = holes

    # ------------------------------------------------------------ state
    def motion(self, rows=None, copy=True):
        """The columns of the live rows (or of `rows`), for set_motion: copies, or with
        copy=False the columns' own views where it can."""
        if rows is not None:
            return {name: getattr(self, name)[rows] for name in self.columns}
        n = self.n
        keep = np.copy if copy else (lambda a: a)
        return {name: keep(getattr(self, name)[:n]) for name in self.columns}

    def set_motion(self, columns):
        """The first rows' columns from motion()'s (as many rows as it holds); a column it
        lacks takes its default (one only these Bodies have: an integrator's of its own)."""
        k = len(columns["ids"])
        for name in self.columns:
            getattr(self, name)[:k] = columns[name] if name in columns else \
                self.defaults.get(name, 0)

    def state(self):
        """The named fields a checkpoint keeps (docs/runlog.md): every column's live rows,
        the columns' dtypes, shapes and defaults, the id slots and counters."""
        n = self.n
        columns = {name: getattr(self, name)[:n].copy() for name in self.columns}
        return {"n": n, "capacity": self.capacity, "columns": columns,
                "defaults": {name: float(v) if not isinstance(v, (bool, np.bool_)) else bool(v)
                             for name, v in self.defaults.items()},
                "generation": self.generation[:self.slots_used].copy(),
                "index": self.index[:self.slots_used].copy(),
                "slots_used": self.slots_used, "added": self.added, "free": self.free.copy()}

    @classmethod
    def from_state(cls, s):
        """Bodies as state() saw them."""
        b = cls(max(int(s["capacity"]), 1))
        n = int(s["n"])
        for name, values in s["columns"].items():
            values = np.asarray(values)
            if name not in b.columns:
                default = s["defaults"].get(name, 0)
                b.ensure_column(name, values.shape[1:], values.dtype, default)
            getattr(b, name)[:n] = values
        b.n = n
        used = int(s["slots_used"])
        b._grow_slots(used)
        b.generation[:used] = s["generation"]
        b.index[:used] = s["index"]
        b.slots_used = used
        b.added = int(s["added"])
        b.free = np.array(s["free"], np.int64)
        return b
