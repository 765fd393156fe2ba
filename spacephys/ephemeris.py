"""Ephemerides: bodies' paths as piecewise Chebyshev polynomials, as JPL's are kept, fitted
to a run (`Ephemeris.fit`), saved and loaded (HDF5), evaluated (`state`) and flown
(`World.set_rails(id, ephemeris=eph)`: planets that keep their mutual perturbations at the
cost of a polynomial's evaluation; kernels/rails.py evaluates them in the step).

Each body's path is split into equal segments of time; in each, x, y and z are sums
sum_k c_k T_k(s) over s in [-1, 1], fitted by least squares to the run's positions at every
step (kernels/rails.fit: the same coefficients on every CPU). Velocities are the
polynomials' derivatives.
"""
import math
from pathlib import Path

import numpy as np

from . import _validate as check
from .kernels import libm
from .kernels import rails as krails

# NAIF ids of the bodies by name (a planet with no body of its own in an SPK file, as Jupiter
# in DE421, is its barycentre)
NAIF = {"solar_system_barycenter": 0, "mercury_barycenter": 1, "venus_barycenter": 2,
        "earth_barycenter": 3, "mars_barycenter": 4, "jupiter_barycenter": 5,
        "saturn_barycenter": 6, "uranus_barycenter": 7, "neptune_barycenter": 8,
        "pluto_barycenter": 9, "sun": 10, "mercury": 199, "venus": 299, "moon": 301,
        "earth": 399, "mars": 499, "jupiter": 5, "saturn": 6, "uranus": 7, "neptune": 8,
        "pluto": 9}
J2000 = 2451545.0                     # the Julian date (TDB) of J2000.0
DAY = 86400.0                         # [s]
# a unit system's length and time in kilometres and seconds (sp.UNITS names)
SCALE = {"si": (1e-3, 1.0), "au-msun-yr": (149597870.7, 365.25 * DAY)}


def de421_path():
    """Where the skyfield-data package keeps JPL's DE421."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # it warns of its Earth-rotation file's age
        from skyfield_data import get_skyfield_data_path
    return str(Path(get_skyfield_data_path()) / "de421.bsp")


def _row(start, length, count, terms):
    """An ephemeris's kernels/rails E_* row (ELEMENTS,)."""
    row = np.zeros(krails.ELEMENTS)
    row[[krails.E_START, krails.E_LENGTH, krails.E_COUNT, krails.E_TERMS]] = \
        start, length, count, terms
    return row


class Ephemeris:
    """Bodies' paths from start to start + count * length [time]: ids (B,) int64, the body
    each is for (the World's ids when fitted; any labels when loaded); coef (B, count, 3,
    terms) Chebyshev coefficients [length]; dim: 2 or 3, the coordinates state() gives."""

    def __init__(self, ids, start, length, coef, dim=3, epoch=None, seconds=None):
        self.ids = np.array(ids, np.int64).reshape(-1)
        self.start = float(start)
        self.length = float(length)
        self.coef = np.ascontiguousarray(coef, np.float64)
        self.dim = int(dim)
        # a real ephemeris's clock: the Julian date (TDB) of its time 0, and the seconds in
        # its unit of time (None for one fitted to a World: its times are the World's)
        self.epoch = None if epoch is None else float(epoch)
        self.seconds = None if seconds is None else float(seconds)
        if self.coef.ndim != 4 or self.coef.shape[0] != self.ids.size or \
                self.coef.shape[2] != 3:
            raise ValueError(f"coef has shape {self.coef.shape}: expected "
                             f"({self.ids.size}, segments, 3, terms)")

    def time(self, jd):
        """Its time [its unit] of a Julian date (TDB), for an ephemeris read from an SPK
        file."""
        if self.epoch is None:
            raise ValueError("this ephemeris was fitted to a World: its times are the "
                             "World's, with no calendar")
        return (np.asarray(jd, np.float64) - self.epoch) * DAY / self.seconds

    @property
    def end(self):
        """The last time it covers [time]."""
        return self.start + self.coef.shape[1] * self.length

    def covers(self, t0, t1=None):
        return self.start <= t0 and (t1 if t1 is not None else t0) <= self.end

    def row(self, body):
        """(kernels/rails E_* row (5,), its coefficients (count, 3, terms)) of one body."""
        hit = np.flatnonzero(self.ids == body)
        if not hit.size:
            raise ValueError(f"body = {body}: not in this ephemeris (it has "
                             f"{self.ids.tolist()})")
        return _row(self.start, self.length, self.coef.shape[1], self.coef.shape[3]), \
            self.coef[hit[0]]

    def state(self, body, times):
        """Positions and velocities (m, dim) each of `body` at times (m,) (or one time:
        (dim,) each), from its polynomials; ValueError outside [start, end]."""
        scalar = np.ndim(times) == 0
        t = np.atleast_1d(check.floats("times", times))
        if t.size and not self.covers(float(t.min()), float(t.max())):
            raise ValueError(f"times from {t.min()} to {t.max()}: this ephemeris covers "
                             f"{self.start} to {self.end}")
        row, coef = self.row(body)
        out = np.empty((t.size, 6))
        krails.chebyshev_many(coef, row, np.ascontiguousarray(t, np.float64), out)
        d = self.dim
        if scalar:
            return out[0, :d].copy(), out[0, 3:3 + d].copy()
        return out[:, :d].copy(), out[:, 3:3 + d].copy()

    # ------------------------------------------------------------ fitting
    @classmethod
    def fit(cls, world, ids, duration, tolerance=1e-10, terms=14):
        """Step a copy of `world` for `duration` [time] and fit each of bodies `ids` with
        Chebyshev polynomials of `terms` terms, segments halved until every sample (a
        position after each step) is within `tolerance` of its body's orbit size (its
        largest distance from its mean place over the run). The World is not changed.
        ValueError when the tolerance needs segments shorter than 2 * terms steps."""
        ids = np.atleast_1d(np.asarray(ids, np.int64))
        rows = world.index_of(ids)                    # checks them
        duration = check.scalar("duration", duration, positive=True)
        tolerance = check.scalar("tolerance", tolerance, positive=True)
        terms = check.count("terms", terms)
        if terms < 2:
            raise ValueError(f"terms = {terms}: at least 2 (a line)")
        steps = max(1, math.ceil(duration / world.dt))
        copy = world.copy()
        start = copy.t
        times = np.empty(steps + 1)
        samples = np.zeros((steps + 1, ids.size, 3))
        dim = world.dim
        times[0] = start
        samples[0, :, :dim] = copy.pos[rows]
        for k in range(1, steps + 1):
            copy.step(1)
            times[k] = copy.t
            samples[k, :, :dim] = copy.pos[copy.index_of(ids)]
        size = np.sqrt(((samples - samples.mean(axis=0)) ** 2).sum(axis=2)).max(axis=0)
        size = np.where(size > 0.0, size, 1.0)
        total = times[-1] - start
        count = 1
        while True:
            length = total / count
            coef, worst = cls._fit(times, samples, start, length, count, terms)
            if np.all(worst <= tolerance * size):
                return cls(ids, start, length, coef, dim)
            if steps / (2 * count) < 2 * terms:
                k = int(np.argmax(worst / size))
                raise ValueError(
                    f"tolerance = {tolerance}: body {int(ids[k])} is still "
                    f"{worst[k] / size[k]:.1e} of its orbit off with segments of "
                    f"{steps // count} steps; use a smaller dt, more terms or a "
                    f"larger tolerance")
            count *= 2

    @staticmethod
    def _fit(times, samples, start, length, count, terms):
        """(coef (B, count, 3, terms), the worst distance of each body's samples from its
        fit (B,))."""
        B = samples.shape[1]
        coef = np.zeros((B, count, 3, terms))
        worst = np.zeros(B)
        row = _row(start, length, count, terms)
        for k in range(count):
            a = start + k * length
            inside = np.flatnonzero((times >= a) & (times <= a + length))   # both ends
            t = np.ascontiguousarray(times[inside])
            for b in range(B):
                krails.fit(t, np.ascontiguousarray(samples[inside, b]), start + k * length,
                           length, terms, coef[b, k])
        out = np.empty((times.size, 6))
        for b in range(B):
            krails.chebyshev_many(coef[b], row, times, out)
            worst[b] = np.sqrt(((out[:, :3] - samples[:, b]) ** 2).sum(axis=1)).max()
        return coef, worst

    # ------------------------------------------------------------ files
    def save(self, path):
        """Write it to an HDF5 file at path."""
        import h5py
        with h5py.File(path, "w") as f:
            f.attrs["format"] = "spacephys ephemeris 1"
            f.attrs["start"] = self.start
            f.attrs["length"] = self.length
            f.attrs["dim"] = self.dim
            if self.epoch is not None:
                f.attrs["epoch"] = self.epoch
                f.attrs["seconds"] = self.seconds
            f["ids"] = self.ids
            f["coef"] = self.coef

    @classmethod
    def load(cls, path):
        """An Ephemeris saved by save()."""
        import h5py
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != "spacephys ephemeris 1":
                raise ValueError(f"{path}: not a spacephys ephemeris file")
            return cls(f["ids"][()], f.attrs["start"], f.attrs["length"], f["coef"][()],
                       int(f.attrs.get("dim", 3)), f.attrs.get("epoch"),
                       f.attrs.get("seconds"))

    # ------------------------------------------------------------ JPL's SPK files
    @classmethod
    def from_spk(cls, path, bodies, units=None, start=None, end=None, epoch=J2000):
        """The bodies' places relative to the Solar System barycentre from a JPL SPK file
        (DE421 and its kin: type 2 segments), read through jplephem. bodies : names (NAIF,
        e.g. "earth", "moon", "jupiter") or NAIF ids, which become the ephemeris's ids;
        units : None (kilometres and seconds) or "si" or "au-msun-yr" (sp.UNITS); start,
        end : Julian dates (TDB) to keep (default the file's span); epoch : the Julian date
        (TDB) of its time 0 (default J2000.0; `time(jd)` converts). A body reached through several segments (the Earth: the
        Earth-Moon barycentre's, then its own about it) is their sum, refitted on the
        finest segments (a polynomial restricted to a sub-interval is one of the same
        degree: exact to rounding)."""
        from .extras import require
        require("sp.Ephemeris.from_spk", "jplephem")
        from jplephem.spk import SPK
        if units is not None and units not in SCALE:
            raise ValueError(f"units = {units!r}: None (km and s) or one of "
                             f"{', '.join(SCALE)} (units with a length and a time)")
        km, seconds = (1.0, 1.0) if units is None else SCALE[units]
        codes = [cls.naif(b) for b in np.atleast_1d(np.asarray(bodies, dtype=object))]
        kernel = SPK.open(str(Path(path)))
        try:
            chains = [cls._chain(kernel, code, path) for code in codes]
            segments = [kernel[pair] for chain in chains for pair in chain]
            first = max(seg.start_jd for seg in segments)
            last = min(seg.end_jd for seg in segments)
            start = first if start is None else check.scalar("start", start)
            end = last if end is None else check.scalar("end", end)
            if not first <= start < end <= last:
                raise ValueError(f"start, end = {start}, {end}: the file covers Julian dates "
                                 f"{first} to {last}")
            arrays = [seg.load_array() for seg in segments]
            length = min(a[1] for a in arrays)                 # days
            terms = max(a[2].shape[2] for a in arrays)
            init = arrays[0][0]
            k0 = math.floor((start - init) / length)
            k1 = math.ceil((end - init) / length)
            count = k1 - k0
            # 2 terms' samples per segment at Chebyshev points of the second kind (both ends)
            m = 2 * terms
            s = libm.each("cos", np.pi * np.arange(m)[::-1] / (m - 1))
            # each sample's date as a whole segment start plus a day fraction (jplephem's
            # two-part date: a float Julian date alone rounds to 40 microseconds), and its
            # time from the same two parts
            seg_start = init + (k0 + np.arange(count)) * length
            whole = np.repeat(seg_start, m)
            part = np.tile(0.5 * length * (s + 1.0), count)
            coef = np.zeros((len(codes), count, 3, terms))
            epoch = check.scalar("epoch", epoch)
            t0 = (seg_start[0] - epoch) * DAY / seconds
            span = length * DAY / seconds
            t = np.ascontiguousarray((((whole - epoch) * DAY + part * DAY) / seconds)
                                     .reshape(count, m))
            for b, chain in enumerate(chains):
                x = np.zeros((3, whole.size))
                for pair in chain:
                    x += kernel[pair].compute(whole, part)
                x = np.ascontiguousarray((x / km).T.reshape(count, m, 3))
                for k in range(count):
                    krails.fit(t[k], x[k], t0 + k * span, span, terms, coef[b, k])
        finally:
            kernel.close()
        return cls(codes, t0, span, coef, 3, epoch, seconds)

    @staticmethod
    def naif(body):
        """The NAIF id of a body given by name (NAIF's keys) or by its id."""
        if isinstance(body, str):
            code = NAIF.get(body.lower().replace(" ", "_"))
            if code is None:
                raise ValueError(f"bodies: {body!r} is not a body name spacephys knows "
                                 f"({', '.join(sorted(NAIF))}); give its NAIF id")
            return code
        if isinstance(body, (int, np.integer)) and not isinstance(body, bool):
            return int(body)
        raise ValueError(f"bodies: {body!r} is neither a name nor a NAIF id")

    @staticmethod
    def _chain(kernel, code, path):
        """The (centre, target) pairs from the barycentre (0) to body `code`."""
        parent = {target: centre for centre, target in kernel.pairs}
        chain = []
        while code != 0:
            if code not in parent:
                raise ValueError(f"bodies: NAIF id {code} is not in {path} (it has "
                                 f"{sorted(parent)})")
            chain.append((parent[code], code))
            code = parent[code]
        return chain[::-1]
