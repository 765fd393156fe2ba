"""Fuzzed files (issue 14): scenario TOML mutated along the real schema, run through the CLI;
run logs and world files with flipped and truncated bytes, read in a subprocess."""
import math
import random
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import spacephys as sp
from spacephys import checksums
from spacephys import scenario as schema
from spacephys.cli import main

SCENARIOS = sorted((Path(__file__).parents[1] / "spacephys" / "scenarios").glob("*.toml"))
SCHEMAS = {"": schema._TOP, "world": schema._WORLD, "bodies": schema._BODY,
           "rings": schema._RING, "ships": schema._SHIP, "collisions": schema._COLLISION,
           "boundary": schema._BOUNDARY, "walls": schema._WALL, "log": schema._LOG,
           "timeline": schema._EVENT}
# a value of each wrong kind, for a key whose schema type is the key of this table
WRONG = {"float": ["text", True, [1.0], math.nan, math.inf, -1e308],
         "int": ["text", 2.5, True, -1, 10**30], "str": [3, 1.5, ["a"], "", "no such thing"],
         "bool": ["yes", 1, 0.0], "vec": [[1.0], [1.0, "x", 2.0], "text", [math.nan] * 3, 5],
         "strs": ["text", [1, 2]], "table": ["text", [1], 3], "tables": ["text", [1], {"a": 1}],
         "range": [[2.0, 1.0], [1.0], "text"], "any": [{"a": 1}, "text", [[1]]]}


def toml_text(value, path=()):
    """A TOML document of a dict (tables, arrays of tables, inline values): enough for the
    scenarios, written here to mutate them freely."""
    scalars = [(k, v) for k, v in value.items()
               if not isinstance(v, dict) and not _tables(v)]
    lines = [f"{_key(k)} = {_inline(v)}" for k, v in scalars]
    for k, v in value.items():
        if isinstance(v, dict):
            lines += ["", f"[{'.'.join(_key(p) for p in path + (k,))}]", toml_text(v, path + (k,))]
        elif _tables(v):
            for item in v:
                lines += ["", f"[[{'.'.join(_key(p) for p in path + (k,))}]]",
                          toml_text(item, path + (k,))]
    return "\n".join(lines)


def _tables(v):
    return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)


def _key(k):
    return k if k.replace("_", "").isalnum() else '"' + k + '"'


def _inline(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if v != v else ("inf" if v == math.inf else "-inf" if v == -math.inf
                                     else repr(v))
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    return "{ " + ", ".join(f"{_key(k)} = {_inline(x)}" for k, x in v.items()) + " }"


def _leaves(doc):
    """(path, schema type or None) of every key the scenario sets, and of every key its
    schema allows but it leaves out (path: a tuple of keys and list indices)."""
    out = []
    for key, value in doc.items():
        kind = schema._TOP.get(key, (None,))[0]
        out.append(((key,), kind))
        items = [] if key not in SCHEMAS else list(enumerate(value)) if _tables(value) else \
            [(None, value)] if isinstance(value, dict) else []
        for k, item in items:
            base = (key,) if k is None else (key, k)
            for sub, (subkind, _) in SCHEMAS[key].items():
                out.append((base + (sub,), subkind))
    return out


def _get(doc, path):
    for p in path:
        try:
            doc = doc[p]
        except (KeyError, IndexError, TypeError):
            return None
    return doc


def _format(path):
    text = ""
    for p in path:
        text += f"[{p}]" if isinstance(p, int) else (f".{p}" if text else p)
    return text


def _mutate(doc, path, op, value):
    """A deep copy of doc with path deleted (op "delete"), set to value ("set"), or an
    unknown key added beside it ("unknown")."""
    import copy
    doc = copy.deepcopy(doc)
    parent = doc
    for p in path[:-1]:
        parent = parent[p]
    if op == "delete":
        parent.pop(path[-1], None)
    elif op == "set":
        parent[path[-1]] = value
    else:
        parent["no_such_key"] = 1.0
    return doc


@settings(deadline=None, max_examples=300, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_mutated_scenario_exits_2_naming_the_key_and_writes_nothing(data, tmp_path_factory,
                                                                      capsys):
    """Every scenario, one key at a time: deleted, given a value of another kind, or joined
    by an unknown key. The CLI either runs it (exit 0 or 1) or exits 2 naming the key's path,
    never with a traceback, and leaves no output file behind."""
    source = data.draw(st.sampled_from(SCENARIOS), label="scenario")
    doc = tomllib.loads(source.read_text())
    path, kind = data.draw(st.sampled_from(_leaves(doc)), label="key")
    op = data.draw(st.sampled_from(["set", "set", "set", "delete", "unknown"]), label="op")
    value = data.draw(st.sampled_from(WRONG.get(kind) or WRONG["any"]), label="value") \
        if op == "set" else None
    folder = tmp_path_factory.mktemp("toml")
    scenario = folder / "mutated.toml"
    scenario.write_text(toml_text(_mutate(doc, path, op, value)))
    out = folder / "out.h5"
    dt = float(doc["world"]["dt"])
    code = main(["run", str(scenario), "--out", str(out), "--duration", repr(2 * dt),
                 "--quiet"])
    err = capsys.readouterr().err
    assert code in (0, 1, 2) and "Traceback" not in err, err
    if code == 2:
        assert not out.exists() and not any(p.name.endswith(".part") for p in
                                            folder.iterdir()), "partial output"
        name = _format(path if op != "unknown" else path[:-1] + ("no_such_key",))
        parent, leaf = _format(path[:-1]), str(path[-1])
        named = name in err or (parent in err and leaf in err)
        if op == "delete" or leaf in ("name", "dim"):
            # what was deleted or renamed may be named by what refers to it instead (a
            # ring's parent, a launch's missile), a new dim by every vector: some key path
            assert named or re.search(r"^  [A-Za-z_]+(\[\d+\])?(\.[A-Za-z_]+(\[\d+\])?)*: ",
                                      err, re.M), (name, err)
        else:
            # the key's path, or its table's and its name (a spec's fields are checked by
            # the spec)
            assert named, (name, err)
    else:
        assert out.exists()


def test_the_mutations_cover_every_scenario_and_the_toml_writer_round_trips():
    for source in SCENARIOS:
        doc = tomllib.loads(source.read_text())
        assert tomllib.loads(toml_text(doc)) == doc, source.name
        kinds = {kind for _, kind in _leaves(doc)}
        assert {"float", "str", "table"} <= kinds, source.name


# ----------------------------------------------------------------------------- damaged files

READ_EVERYTHING = r"""
import sys
import spacephys as sp

def read(path):
    if path.endswith("world.h5"):
        return sp.World.load(path).n
    with sp.open_run(path) as run:
        n = len(run)
        run.times, run.steps, run.events(), run.inputs()
        for i in range(n):
            frame = run.frame(i)
        for k in range(len(run.checkpoints)):
            run.world(k)
        if n and len(frame.ids):
            run.trajectory(int(frame.ids[0]))
        run.verify()                 # after reading it all: damaged rows must not crash
    sp.World.load(path)
    w = sp.resume(path)              # and write into it
    w.step(3)
    w.recording.close()

for path in sys.argv[1:]:
    print("begin", path, flush=True)
    try:
        read(path)
        print("ok", flush=True)
    except sp.RunLogError as e:
        print("refused", path in str(e), flush=True)
    except Exception as e:
        print("other", type(e).__name__, str(e).replace("\n", " ")[:300], flush=True)
"""


def _damaged_copies(source, folder, rng, flips, cuts, aim=()):
    """Copies of source with one byte or a burst of bytes flipped, or cut short; `aim`:
    (start, end) byte ranges to flip inside (one copy each, in turn), else anywhere.
    Returns (path, (first, last + 1) byte flipped or None for a cut) pairs."""
    data = source.read_bytes()
    out = []
    for k in range(flips):
        raw = bytearray(data)
        lo, hi = aim[k % len(aim)] if aim else (0, len(raw))
        at = rng.randrange(lo, hi)
        end = min(at + rng.choice([1, 1, 1, 4, 16]), len(raw))
        for j in range(at, end):
            raw[j] ^= rng.randrange(1, 256)
        path = folder / f"flip{k}{'-aimed' if aim else ''}-{source.name}"
        path.write_bytes(bytes(raw))
        out.append((path, (at, end)))
    for k in range(cuts):
        path = folder / f"cut{k}-{source.name}"
        path.write_bytes(data[:rng.randrange(len(data))])
        out.append((path, None))
    return out


def _committed_bytes(path):
    """(start, end) byte ranges of a run log's committed rows, table by table (its raw
    chunks hold rows whole, in order)."""
    out = []
    with h5py.File(path, "r") as f:
        lengths = dict(zip(checksums.LENGTHS, f["flushes/lengths"][-1]))
        for name, count in checksums.CHECKED:
            d = f[name]
            row = d.dtype.itemsize * int(np.prod(d.shape[1:], dtype=np.int64))
            for i in range(d.id.get_num_chunks()):
                info = d.id.get_chunk_info(i)
                used = min(d.chunks[0], int(lengths[count]) - info.chunk_offset[0])
                if used > 0:
                    out.append((info.byte_offset, info.byte_offset + used * row))
    return out


def test_damaged_logs_and_world_files_are_refused_never_crash(tmp_path):
    """Flipped bytes and truncations of a run log (frames, events, inputs, checkpoints) and
    of a world file, read entirely in a subprocess: each reads, or raises RunLogError naming
    the file; the interpreter never dies and nothing else escapes."""
    w = sp.World(2, dt=0.01, seed=5)
    w.add_body(100.0, (0.0, 0.0), radius=1.0, kind="planet")
    ship = w.add_ship(sp.ShipSpec(fuel_mass=1.0, max_thrust=1.0, exhaust_speed=5.0,
                                  radius=0.2), (5.0, 0.0), (0.0, 4.0))
    w.set_collision("*", "planet", "destroy_a")
    log = w.record(tmp_path / "log.h5", every=2, checkpoint_every=5)
    w.control(ship, throttle=0.5, turn=0.3)
    for _ in range(6):
        w.step(4)
        w.launch(ship, sp.MissileSpec(radius=0.05, lifetime=0.2, launch_speed=1.0))
    log.close()
    w.save(tmp_path / "world.h5")
    rng = random.Random(2026)
    copies = []
    for source, flips, cuts in ((tmp_path / "log.h5", 140, 30), (tmp_path / "world.h5", 50, 20)):
        copies += _damaged_copies(source, tmp_path, rng, flips, cuts)
    # and flips aimed at the rows the log holds (raw tables: no HDF5 checksum covers them)
    data = _committed_bytes(tmp_path / "log.h5")
    aimed = _damaged_copies(tmp_path / "log.h5", tmp_path, rng, 3 * len(data), 0, data)
    inside = {p for p, flipped in copies + aimed if flipped and p.name.endswith("log.h5")
              and any(a < flipped[1] and flipped[0] < b for a, b in data)}
    paths = [p for p, _ in copies + aimed]
    child = subprocess.run([sys.executable, "-c", READ_EVERYTHING, *map(str, paths)],
                           capture_output=True, text=True, timeout=600)
    lines = child.stdout.splitlines()
    assert child.returncode == 0, (child.returncode, lines[-2:], child.stderr[-2000:])
    outcomes = {}
    for begin, result in zip(lines[::2], lines[1::2]):
        word = result.split()[0]
        assert word in ("ok", "refused"), (begin, result)
        if word == "refused":
            assert result == "refused True", (begin, "the error does not name the file")
        elif Path(begin.split(" ", 1)[1]) in inside:
            raise AssertionError(f"{begin}: a flipped row read as if whole")
        outcomes[word] = outcomes.get(word, 0) + 1
    assert sum(outcomes.values()) == len(paths)
    # cuts always lose something the reader needs; most flips land in metadata (checksummed)
    # or in the rows (CRC-32 per flush); the others in unused bytes
    assert outcomes["refused"] >= 60 + len(inside) // 2, outcomes
    assert len(inside) >= 3 * len(data) and len(data) >= 20, (len(inside), len(data))
    print(f"{len(paths)} damaged files: {outcomes}; {len(inside)} flipped committed rows, "
          f"every one refused")
