"""Structure-of-arrays body storage: live bodies packed at [0, n), capacity that grows by
doubling, and stable generational ids.

An id is (generation << 32) | slot. Removing a body bumps its slot's generation, so the old id
turns stale and never names a later body; freed slots are reused first-in first-out, which keeps
the slot table as large as the most bodies ever alive at once. First-generation ids are 0, 1, 2...
"""
import hashlib

import numpy as np

from .kernels import digest as kdigest

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

    Every column, and the id slots' generation and index, are views of one byte block
    (`block`, laid out by `layout`), so a snapshot copies the bodies in one move and a restore
    writes them back where the kernels' tables look (snapshot(), restore()).
    """

    def __init__(self, capacity=64):
        self.n = 0
        self.columns = dict(_COLUMNS)
        self.defaults = {}                # columns whose default is not 0
        self.slots_used = 0               # slots ever handed out
        self.added = 0                    # bodies ever added
        self.free = np.zeros(0, dtype=np.int64)    # freed slots, oldest first; never written
        self._lay_out(max(int(capacity), 1), keep=0)

    @property
    def capacity(self):
        return self.mass.shape[0]

    def _lay_out(self, capacity, keep):
        """Put every column (its first `keep` rows kept, the others their default) and the
        slots (generation per slot, index: the row of its body, -1 free; slots_used kept) in
        a new block of `capacity` rows. Every array is new: tables built before must be."""
        fields = [(name, shape, dtype) for name, (shape, dtype) in self.columns.items()]
        fields += [("generation", (), np.int64), ("index", (), np.int64)]
        layout, size = [], 0
        for name, shape, dtype in fields:
            nbytes = capacity * np.dtype(dtype).itemsize * int(np.prod(shape))
            layout.append((name, tuple(shape), np.dtype(dtype), size, nbytes))
            size += -(-nbytes // 64) * 64          # every array starts 64-byte aligned
        held = {f[0] for f in getattr(self, "layout", ())}
        old = {name: getattr(self, name) if name in held else None       # None: new
               for name, *_ in fields}
        self._bind(tuple(layout), np.empty(size, np.uint8))
        for name, *_ in fields:
            arr, was = getattr(self, name), old[name]
            rows = 0 if was is None else keep if name in self.columns else self.slots_used
            arr[rows:] = -1 if name == "index" else self.defaults.get(name, 0)
            if rows:
                arr[:rows] = was[:rows]

    def ensure_columns(self, columns):
        """Add per-body columns, {name: (shape, dtype, default)}, that grow, compact and copy
        with the others, holding `default` for every body that exists or is added without a
        value for it (those already there are kept); integrators and ships keep per-body
        state this way (Gauss-Radau's polynomial, fuel, heading). Adding one lays every column
        out anew (tables built before must be)."""
        new = {name: spec for name, spec in columns.items() if name not in self.columns}
        if new:
            self.columns = {**self.columns,
                            **{name: (tuple(shape), dtype) for name, (shape, dtype, _) in
                               new.items()}}
            self.defaults = {**self.defaults,
                             **{name: default for name, (_, _, default) in new.items()}}
            self._lay_out(self.capacity, keep=self.n)

    def ensure_column(self, name, shape=(), dtype=np.float64, default=0):
        """ensure_columns for one column; returns it."""
        self.ensure_columns({name: (shape, dtype, default)})
        return getattr(self, name)

    def _grow(self, need):
        """Make room for `need` rows (bodies and slots), doubling so that growth is amortised
        O(1) per body."""
        cap = self.capacity
        if need > cap:
            self._lay_out(max(need, 2 * cap), keep=self.n)

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
        if ids.size <= 4:       # a ship or a few (a HUD's prediction): row(), not numpy's calls
            return np.array([self.row(i) for i in ids.ravel().tolist()],
                            np.int64).reshape(ids.shape)
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
        into the holes, so the cost is O(removed) whatever the number of bodies. Their slots
        are freed in the order of their ids, whatever rows they held."""
        rows = np.asarray(rows, dtype=np.int64)
        n = self.n
        m = n - rows.size
        slots = np.sort(self.ids[rows]) & _SLOT_MASK
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

    def reorder(self, order):
        """Put the live rows in the order `order` ((n,) int64, a permutation of 0..n-1: the
        new row k is the old row order[k]), every column in place (the arrays tables hold
        stay these Bodies'), ids and slots kept."""
        n = self.n
        for name in self.columns:
            col = getattr(self, name)
            col[:n] = np.take(col, order, axis=0)     # (3x faster than col[order])
        self.index[self.ids[:n] & _SLOT_MASK] = np.arange(n)

    def live(self, names):
        """The columns `names` (a tuple) cut to the live rows: views, kept while the block
        and n hold (a frame's queries ask for the same ones many times)."""
        held = self._live.get(names)
        if held is not None and held[0] == self.n:
            return held[1]
        got = tuple([getattr(self, name)[:self.n] for name in names])
        self._live[names] = (self.n, got)
        return got

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
        n, used = int(s["n"]), int(s["slots_used"])
        b = cls(max(int(s["capacity"]), used, 1))
        columns = {name: np.asarray(values) for name, values in s["columns"].items()}
        b.ensure_columns({name: (values.shape[1:], values.dtype, s["defaults"].get(name, 0))
                          for name, values in columns.items()})
        for name, values in columns.items():
            getattr(b, name)[:n] = values
        b.n = n
        b.generation[:used] = s["generation"]
        b.index[:used] = s["index"]
        b.slots_used = used
        b.added = int(s["added"])
        b.free = np.array(s["free"], np.int64)
        return b

    # ------------------------------------------------------------ snapshots
    def snapshot(self):
        """Everything these Bodies hold, for restore(): the block copied whole (the rows past
        n included, so that a restore in place leaves every byte as it was)."""
        return (self.layout, self.block.copy(), self.columns, self.defaults, self.n,
                self.slots_used, self.added, self.free)

    def restore(self, snap):
        """Make these Bodies snapshot() `snap` again; True when it was written into the same
        block (the arrays tables hold still hold the bodies), False when laid out anew."""
        layout, block, self.columns, self.defaults, self.n, self.slots_used, self.added, \
            self.free = snap
        if layout is self.layout:
            np.copyto(self.block, block)
            return True
        self._bind(layout, block.copy())
        return False

    def _bind(self, layout, block):
        """Make `block`, laid out by `layout` (as _lay_out makes them; a layout is replaced,
        never changed, so a snapshot knows its own), these Bodies'."""
        names = {f[0] for f in layout}
        for name, *_ in getattr(self, "layout", ()):
            if name not in names:
                delattr(self, name)                  # a column the new layout lacks
        for name, shape, dtype, start, nbytes in layout:
            capacity = nbytes // (dtype.itemsize * int(np.prod(shape)))
            setattr(self, name, block[start:start + nbytes].view(dtype).reshape(
                (capacity,) + shape))
        self.block, self.layout = block, layout
        self._live = {}                 # live()'s views, of the block before
        self._words = block.view(np.uint64)
        # the digest's order: the columns by name (a loaded World may list them in another
        # order), then the slots' two arrays
        order = sorted(layout[:-2], key=lambda f: f[0]) + list(layout[-2:])
        self._starts = np.array([f[3] for f in order], np.int64)
        self._row_bytes = np.array([f[4] // capacity for f in order], np.int64)
        self._names = hashlib.blake2b(",".join(f[0] for f in order).encode(),
                                      digest_size=8).digest()

    def digest(self, h):
        """The finished 64-bit hash (kernels/digest.py) of hashlib's h with the columns' names
        (hashed once per layout), then every live row of every column (in the names' order),
        the used id slots, the counters and the free slots mixed in: the rows past n are not
        part of it."""
        h.update(self._names)
        return _rows(int.from_bytes(h.digest(), "little"), self._words, self._starts,
                     self._row_bytes, self.n, 2, self.slots_used, self.added, self.free)

    def __getstate__(self):
        return {k: self.__dict__[k] for k in _KEPT}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._bind(state["layout"], state["block"])


def _rows(*args):
    """kdigest.rows(*args), past numba's dispatch once compiled (its argument types never
    change: the dispatch would cost a third of a duel's digest)."""
    if not _ENTRY:
        result = kdigest.rows(np.uint64(args[0]), *args[1:])     # typed uint64 from here on
        _ENTRY.append(kdigest.rows.overloads[kdigest.rows.signatures[-1]].entry_point)
        return result
    return _ENTRY[0](*args)


_ENTRY = []

# what a copy or pickle of Bodies keeps: the block and what lays it out, not its views
_KEPT = ("n", "columns", "defaults", "slots_used", "added", "free", "block", "layout")
