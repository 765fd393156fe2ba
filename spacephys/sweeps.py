"""Ensembles and parameter sweeps (`sp.sweep`, `spacephys sweep`): one scenario run for every
combination of the varied values and every seed, on Dask's distributed scheduler — a local
cluster of worker processes by default (nothing to start), any cluster by its scheduler's
address.

Each run is independent and seeded by its parameters and seed (`SweepRun.run_seed`, the World's
seed), so the table is the same whatever the number of workers or the order runs finish in.
A run that raises is a row with its error; a worker that dies has its runs done by the others
(Dask reschedules them). With `out`, each finished run is appended to OUT.partial as it
arrives (one JSON line: a restarted sweep skips those runs), and OUT, the table in HDF5, is
written when the last run is in: a file at OUT is a complete sweep.
"""
import hashlib
import itertools
import json
import logging
import math
import os
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .events import EVENT_KINDS

FORMAT = "spacephys-sweep"
VERSION = 1
PARAM = "param."             # vary keys for setup / measure only, not set in the scenario
CONNECT_TIMEOUT = 5.0        # seconds to reach a scheduler given by address
WORKER_TIMEOUT = 30.0        # seconds to wait for the first worker of such a cluster
# the columns every table has, in order (then the parameters, events.KIND, the measures)
COLUMNS = ("index", "seed", "run_seed", "status", "error", "wall", "steps", "t", "bodies0",
           "survivors", "energy_error", "momentum_error")


@dataclass(frozen=True)
class SweepRun:
    """One run of a sweep: its row, its values {key path: value} and seed, and the seed its
    World gets (from those: the same run, the same numbers, on any worker)."""
    index: int
    params: dict
    seed: int
    run_seed: int

    def rng(self):
        """A numpy Generator of this run's own (for a setup's random draws)."""
        return np.random.default_rng(self.run_seed)


class Sweep:
    """A sweep's table: one row per run, in run order; sweep[name] is a column (numpy array):
    the COLUMNS, each varied key path, "events.KIND" (counts), each measure's name."""

    def __init__(self, columns, params, measures, meta):
        self.columns = columns          # name -> (R,) or (R, k) array
        self.params = params            # the varied key paths, in order
        self.measures = measures        # the measures' names
        self.meta = meta                # scenario text, vary, seeds, ...
        self.resumed = 0                # runs an interrupted sweep had finished

    def __len__(self):
        return len(self.columns["index"])

    def __getitem__(self, name):
        if name not in self.columns:
            raise KeyError(f"{name!r} is not a column; columns: {', '.join(self.columns)}")
        return self.columns[name]

    @property
    def ok(self):
        """(R,) bool: the runs that finished without an error."""
        return self.columns["status"] == "ok"

    def __repr__(self):
        return (f"Sweep({len(self)} runs, {int(self.ok.sum())} ok; varied: "
                f"{', '.join(self.params) or 'nothing'}; measures: "
                f"{', '.join(self.measures) or 'none'})")


def sweep(scenario, vary=None, seeds=(0,), measure=None, setup=None, client=None,
          workers=None, out=None, logs=None, progress=None):
    """Run `scenario` (a .toml path, its text, or a loaded Scenario) once for every
    combination of the values in `vary` and every seed in `seeds`; a Sweep.

    vary : {key path: [values]} — "world.dt", "ships.hunter.vel", "bodies[0].mass"
        (scenario.set_key), or "param.NAME" for a value only setup and measure read;
    seeds : the seed numbers (each run's World seed comes from them and its values);
    setup(world, names, run) : called after the World is built, before its first step;
    measure(result, run) : the run's own figures, {name: number, bool or text} (or one
        number, named "measure"), from its runner.RunResult;
    client : None (a local cluster of `workers` processes, default one per core), a
        scheduler's address ("tcp://host:8786"), or a dask.distributed.Client;
    out : write the table here (HDF5), resuming from OUT.partial if it is there;
    logs : a directory for one run log per run (run_00012.h5), on the workers' disks;
    progress : a file to draw a progress bar on.
    setup and measure travel to the workers pickled: functions of an importable module, or
    of the script itself (sent by value).
    """
    from .scenario import Scenario, load_scenario
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    source, text = sc.source, sc.text
    seeds = list(seeds) if hasattr(seeds, "__iter__") else seeds
    runs = plan(sc, vary or {}, seeds)
    keys = list((vary or {}).keys())
    meta = {"format": FORMAT, "version": VERSION, "scenario": text, "source": source,
            "vary": json.dumps(vary or {}), "seeds": json.dumps([int(s) for s in seeds]),
            "measure": _name(measure), "setup": _name(setup)}
    digest = hashlib.sha256(json.dumps(meta, sort_keys=True).encode()).hexdigest()
    journal = None
    done = {}
    if out is not None:
        out = os.fspath(out)
        if os.path.exists(out):
            old = read_sweep(out)
            if old.meta.get("digest") == digest:
                return old                       # this very sweep, finished before
            raise ValueError(f"out = {out!r} holds another sweep: remove it or give "
                             f"another path")
        journal = Journal(out + ".partial", digest)
        done = journal.rows()
    if logs is not None:
        Path(logs).mkdir(parents=True, exist_ok=True)
    job = {"text": text, "source": source, "measure": measure, "setup": setup,
           "logs": None if logs is None else os.path.abspath(logs)}
    pending = [r for r in runs if r.index not in done]
    if pending:
        client, close = connect(client, workers)
        try:
            if journal is not None:
                journal.open()
            _execute(client, job, pending, digest, done, journal, progress, len(runs))
        finally:
            if journal is not None:
                journal.close()
            close()
    resumed = len(runs) - len(pending)
    table = _table([done[r.index] for r in runs], runs, keys, {**meta, "digest": digest})
    table.resumed = resumed
    if out is not None:
        write_sweep(out, table)
        os.remove(out + ".partial")
    return table


def plan(scenario, vary, seeds):
    """Every run of the sweep, in order (the values' combinations in vary's key order, the
    last key fastest, each with every seed), each combination checked as the scenario it
    makes: a bad key path or value is refused before anything runs. scenario: a loaded
    Scenario."""
    from .scenario import ScenarioError, load_scenario
    if not isinstance(vary, dict):
        raise ValueError(f"vary = {vary!r}: expected {{key path: [values]}}")
    for key, values in vary.items():
        if key == "world.seed":
            raise ValueError("vary: world.seed is set for each run from its values and seed; "
                             "give seeds= instead")
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise ValueError(f"vary[{key!r}] = {values!r}: expected a list of values")
        if not list(values):
            raise ValueError(f"vary[{key!r}]: no values")
        if key.startswith(PARAM) and not key[len(PARAM):]:
            raise ValueError(f"vary key {key!r}: name the parameter (param.NAME)")
    try:
        seeds = [int(s) for s in seeds]
    except (TypeError, ValueError):
        raise ValueError(f"seeds = {seeds!r}: expected whole numbers") from None
    if not seeds or min(seeds) < 0:
        raise ValueError(f"seeds = {seeds!r}: expected at least one, each >= 0")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds = {seeds!r}: each seed once")
    keys = list(vary)
    text, base = scenario.text, scenario.data["world"]["seed"]
    runs = []
    for combo in itertools.product(*(list(vary[k]) for k in keys)):
        params = {k: _plain(k, v) for k, v in zip(keys, combo)}
        scene = {k: v for k, v in params.items() if not k.startswith(PARAM)}
        try:
            load_scenario(text, scene)
        except ScenarioError as e:
            where = ", ".join(f"{k} = {v!r}" for k, v in scene.items())
            problems = "; ".join(f"{p}: {m}" for p, m in e.problems)
            raise ValueError(f"vary {where}: {problems}") from None
        for seed in seeds:
            runs.append(SweepRun(len(runs), params, seed, run_seed(base, params, seed)))
    return runs


def _plain(key, value):
    """A value as plain Python (numpy numbers and arrays to numbers and lists): what a
    scenario and the table hold."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(key, v) for v in value]
    if value is None or not isinstance(value, (bool, int, float, str)):
        raise ValueError(f"vary[{key!r}]: {value!r} is not a value a scenario holds "
                         f"(a number, true/false, text or a list of them)")
    return value


def run_seed(base, params, seed):
    """A run's World seed: a digest of the scenario's seed, the run's values and its seed
    number (< 2^63)."""
    blob = json.dumps([base, sorted(params.items()), seed]).encode()
    return int.from_bytes(hashlib.sha256(blob).digest()[:8], "little") >> 1


def _name(fn):
    if fn is None:
        return ""
    return f"{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', repr(fn))}"


# ----------------------------------------------------------------------- on a worker

def run_one(job, run):
    """Run `run` of the sweep `job` (on a worker): its row, {column: value}, with
    "measure": {name: value}. Whatever the run raises is its row's error."""
    from .runner import run_scenario
    from .scenario import load_scenario
    start = time.perf_counter()
    row = {"index": run.index, "seed": run.seed, "run_seed": run.run_seed, "status": "ok",
           "error": "", "measure": {}}
    try:
        scene = {k: v for k, v in run.params.items() if not k.startswith(PARAM)}
        sc = load_scenario(job["text"], {**scene, "world.seed": run.run_seed})
        sc.log = None                                   # one log per run, or none
        out = None if job["logs"] is None else \
            os.path.join(job["logs"], f"run_{run.index:05d}.h5")
        setup = job["setup"]
        result = run_scenario(sc, out=out, setup=None if setup is None else
                              (lambda w, names: setup(w, names, run)))
        row.update(steps=result.steps, t=result.world.t, bodies0=result.bodies0,
                   survivors=result.world.n, energy_error=result.energy_error,
                   momentum_error=result.momentum_error,
                   events={k: int(v) for k, v in result.events.items()})
        if job["measure"] is not None:
            row["measure"] = _measures(job["measure"](result, run))
    except Exception as e:                               # the run's error is its result
        row["status"] = "error"
        row["error"] = f"{type(e).__name__}: {e}"
    row["wall"] = time.perf_counter() - start
    return row


def _measures(value):
    """A measure's result as {name: plain value}."""
    if not isinstance(value, dict):
        value = {"measure": value}
    out = {}
    for name, v in value.items():
        if isinstance(v, np.generic):
            v = v.item()
        if not isinstance(name, str) or not name or name in COLUMNS or \
                name.startswith("events."):
            raise ValueError(f"measure name {name!r}: expected text, not one of the table's "
                             f"own columns")
        if not isinstance(v, (bool, int, float, str)):
            raise ValueError(f"measure {name!r} = {v!r}: expected a number, true/false or text")
        out[name] = v
    return out


# ----------------------------------------------------------------------- the cluster

def connect(client, workers=None):
    """(a dask Client, a function that closes what was opened here): a new local cluster
    of `workers` processes (client None), the scheduler at an address, or the Client
    given. An address that cannot be reached is a ValueError within CONNECT_TIMEOUT."""
    from .extras import require
    require("a sweep (dask's distributed scheduler)", "distributed")
    from dask.distributed import Client, LocalCluster
    if client is not None and workers is not None:
        raise ValueError(f"workers = {workers!r}: the number of local workers; a cluster "
                         f"given by address or Client brings its own")
    if client is None:
        n = (os.cpu_count() or 1) if workers is None else workers
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise ValueError(f"workers = {workers!r}: expected a whole number >= 1")
        # one thread per worker and per numba kernel: the workers are the parallelism
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR,
                               env={"NUMBA_NUM_THREADS": "1"})
        c = Client(cluster)

        def close():
            c.close()
            cluster.close()
        return c, close
    if isinstance(client, str):
        try:
            c = Client(client, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as e:
            raise ValueError(f"scheduler {client!r} cannot be reached "
                             f"({CONNECT_TIMEOUT:g} s): {e}") from None
        try:
            c.wait_for_workers(1, timeout=WORKER_TIMEOUT)
        except (OSError, TimeoutError):
            c.close()
            raise ValueError(f"scheduler {client!r} has no workers (waited "
                             f"{WORKER_TIMEOUT:g} s)") from None
        return c, c.close
    return client, lambda: None


def _execute(client, job, pending, digest, done, journal, progress, total):
    """Run `pending` on the cluster; each finished row into done and the journal as it
    comes. The first run goes alone: it loads (or compiles) the kernels into the numba cache
    the other workers then read, instead of every worker compiling them at once."""
    from dask.distributed import as_completed

    def submit(run):
        return client.submit(run_one, job, run, key=f"spacephys-run-{digest[:16]}-{run.index}")

    started = time.perf_counter()
    first = submit(pending[0])
    queue = as_completed([first], with_results=True, raise_errors=False)
    rest = pending[1:]
    runs = {first.key: pending[0]}
    for future, row in queue:
        run = runs.pop(future.key)
        if not isinstance(row, dict):                # the cluster's failure, not the run's
            row = {"index": run.index, "seed": run.seed, "run_seed": run.run_seed,
                   "status": "error", "error": f"{type(row).__name__}: {row}", "wall": math.nan,
                   "measure": {}}
        done[run.index] = row
        if journal is not None:
            journal.append(row)
        if rest:
            for r in rest:
                f = submit(r)
                runs[f.key] = r
                queue.add(f)
            rest = []
        if progress is not None:
            _bar(progress, len(done), total, started, done)
    if progress is not None:
        print(file=progress)


def _bar(progress, n, total, started, done):
    from .runner import draw_bar
    errors = sum(1 for r in done.values() if r["status"] != "ok")
    draw_bar(progress, n, total, f"{n}/{total} runs, {errors} errors, "
                                 f"{time.perf_counter() - started:.1f} s")


# ----------------------------------------------------------------------- the files

class Journal:
    """OUT.partial: a header line (the sweep's digest), then one JSON line per finished run,
    flushed as written. A last line cut short by a kill is ignored."""

    def __init__(self, path, digest):
        self.path = path
        self.digest = digest
        self.file = None

    def rows(self):
        """{index: row} of the runs already finished (none if there is no journal)."""
        if not os.path.exists(self.path):
            return {}
        with open(self.path, encoding="utf-8") as f:
            lines = f.read().split("\n")
        try:
            head = json.loads(lines[0])
        except json.JSONDecodeError:
            head = {}
        if head.get("digest") != self.digest:
            raise ValueError(f"{self.path!r} holds an unfinished sweep of another scenario, "
                             f"values or seeds: remove it, or give another out")
        rows = {}
        for line in lines[1:]:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue                               # cut short
            rows[row["index"]] = row
        return rows

    def open(self):
        new = not os.path.exists(self.path)
        cut = False
        if not new:
            with open(self.path, "rb") as f:
                f.seek(0, os.SEEK_END)
                if f.tell():
                    f.seek(-1, os.SEEK_END)
                    cut = f.read(1) != b"\n"
        self.file = open(self.path, "a", encoding="utf-8")
        if new:
            self.file.write(json.dumps({"format": FORMAT, "digest": self.digest}) + "\n")
        elif cut:                                   # a line cut short by a kill: end it
            self.file.write("\n")
        self.file.flush()

    def append(self, row):
        self.file.write(json.dumps(row) + "\n")
        self.file.flush()
        os.fsync(self.file.fileno())

    def close(self):
        if self.file is not None:
            self.file.close()
            self.file = None


def _column(values, missing):
    """A column from per-row values (`missing` where a run has none)."""
    present = [v for v in values if v is not missing]
    if present and all(isinstance(v, bool) for v in present) and len(present) == len(values):
        return np.array(values, bool)
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present) \
            and len(present) == len(values):
        return np.array(values, np.int64)
    if all(isinstance(v, (int, float)) for v in present):
        return np.array([math.nan if v is missing else float(v) for v in values])
    if all(isinstance(v, list) and all(isinstance(x, (int, float)) for x in v)
           for v in present) and len({len(v) for v in present}) == 1 and \
            len(present) == len(values):
        return np.array(values, float)
    if all(isinstance(v, str) for v in present):
        return np.array(["" if v is missing else v for v in values], dtype=object)
    return np.array(["" if v is missing else json.dumps(v) for v in values], dtype=object)


def _table(rows, runs, keys, meta):
    """A Sweep from the rows (in run order)."""
    none = object()
    cols = {}
    for name in COLUMNS:
        values = [r.get(name, none) for r in rows]
        if name in ("status", "error"):
            cols[name] = np.array(values, dtype=object)
        elif name in ("index", "seed", "run_seed", "steps", "bodies0", "survivors"):
            cols[name] = np.array([-1 if v is none else v for v in values], np.int64)
        else:
            cols[name] = np.array([math.nan if v is none else v for v in values], float)
    for key in keys:
        cols[key] = _column([run.params[key] for run in runs], none)
    for kind in EVENT_KINDS.values():
        cols[f"events.{kind}"] = np.array(
            [r.get("events", {}).get(kind, 0) if r["status"] == "ok" else -1 for r in rows],
            np.int64)
    measures = sorted({m for r in rows for m in r.get("measure", {})})
    for m in measures:
        cols[m] = _column([r.get("measure", {}).get(m, none) for r in rows], none)
    return Sweep(cols, keys, measures, meta)


def write_sweep(path, table):
    """The table as HDF5: a group "runs" with one dataset per column, the sweep's
    definition as attributes. Written beside the path, then moved there: a file at the
    path is whole."""
    import h5py
    tmp = f"{path}.{os.getpid()}.tmp"
    with h5py.File(tmp, "w") as f:
        for k, v in table.meta.items():
            f.attrs[k] = v
        f.attrs["params"] = json.dumps(table.params)
        f.attrs["measures"] = json.dumps(table.measures)
        f.attrs["columns"] = json.dumps(list(table.columns))
        runs = f.create_group("runs")
        for name, col in table.columns.items():
            if col.dtype == object:
                runs.create_dataset(name, data=col.astype(str).tolist(),
                                    dtype=h5py.string_dtype())
            else:
                runs.create_dataset(name, data=col)
    os.replace(tmp, path)


def read_sweep(path):
    """A Sweep from a file write_sweep (spacephys sweep --out) wrote."""
    import h5py
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise ValueError(f"{path!r} is not a sweep table: {e}") from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ValueError(f"{path!r} is not a sweep table (spacephys sweep --out)")
        meta = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()
                if k not in ("params", "measures", "columns")}
        cols = {}
        for name in json.loads(f.attrs["columns"]):
            d = f["runs"][name]
            cols[name] = np.array(d.asstr()[()], dtype=object) if \
                h5py.check_string_dtype(d.dtype) else d[()]
        return Sweep(cols, json.loads(f.attrs["params"]), json.loads(f.attrs["measures"]),
                     meta)


def parse_vary(text):
    """"key=v1,v2,..." (spacephys sweep --vary) -> (key, [values]): each value TOML (1e-3,
    [1.0, 0.0], "text", true), or a bare word taken as text (leapfrog)."""
    key, sep, rest = text.partition("=")
    key = key.strip()
    if not sep or not key or not rest.strip():
        raise ValueError(f"--vary {text!r}: expected KEY=V1,V2,... (as world.dt=0.01,0.02)")
    values, depth, quoted, part = [], 0, False, ""
    for ch in rest + ",":                     # commas inside [...] and "..." are the value's
        if ch == "," and depth == 0 and not quoted:
            values.append(part.strip())
            part = ""
            continue
        quoted ^= ch == '"'
        depth += (ch in "[{") - (ch in "]}")
        part += ch
    out = []
    for v in values:
        if not v:
            raise ValueError(f"--vary {text!r}: an empty value")
        try:
            out.append(tomllib.loads(f"v = {v}")["v"])
        except tomllib.TOMLDecodeError:
            out.append(v)
    return key, out


def summary(table, wall=None, workers=None):
    """A few lines about a finished sweep: its runs, errors, and per combination of values
    the mean of each figure."""
    n, ok = len(table), int(table.ok.sum())
    lines = [f"runs          {n} ({ok} ok, {n - ok} errors)" +
             (f" in {wall:.1f} s" + (f" on {workers} workers" if workers else "")
              if wall is not None else "")]
    if table.resumed:
        lines.append(f"resumed       {table.resumed} runs finished before (OUT.partial)")
    errors = [e for e in table["error"] if e]
    if errors:
        first = max(set(errors), key=errors.count)
        lines.append(f"errors        {len(errors)}, most often: {first}")
    keys = table.params
    combos = {}
    for i in range(n):
        combos.setdefault(tuple(json.dumps(_plain(k, table[k][i])) for k in keys), []).append(i)
    head = keys + ["runs", "ok", "energy err", "survivors"] + table.measures
    lines.append("  ".join(f"{h:>12}" for h in head))
    for combo, rows in combos.items():
        rows = np.array(rows)
        good = rows[table.ok[rows]]
        cells = list(combo) + [str(rows.size), str(good.size)]
        for name in ["energy_error", "survivors"] + table.measures:
            col = table[name]
            if col.dtype == object or good.size == 0:
                cells.append("-")
            else:
                cells.append(f"{np.mean(col[good].astype(float)):.4g}")
        lines.append("  ".join(f"{c:>12}" for c in cells))
    return "\n".join(lines)

