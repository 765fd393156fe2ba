"""Sweeps on a real Dask engine: a local cluster of worker processes, and a `dask scheduler`
with two `dask worker` processes started here, one of them killed mid-sweep; an interrupted
sweep resumed; the same table whatever the number of workers; bad input refused before
anything runs."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cloudpickle
import numpy as np
import pytest

import spacephys as sp
from spacephys.cli import main
from spacephys.scenario import ScenarioError, key_parts, load_scenario
from spacephys.sweeps import parse_vary, read_sweep, run_one

# the hooks below travel to the workers by value (this test module is not importable there)
cloudpickle.register_pickle_by_value(sys.modules[__name__])

ROOT = Path(__file__).resolve().parent.parent
DOGFIGHT = ROOT / "spacephys" / "scenarios" / "dogfight.toml"
VARY = {"missiles.seeker.nav_constant": [3.0, 4.0], "world.dt": [0.004, 0.008]}
SEEDS = range(10)                       # 40 runs of about 50 ms each
CLI_VARY = ["--vary", "missiles.seeker.nav_constant=3.0,4.0", "--vary", "world.dt=0.004,0.008",
            "--seeds", "10"]
BIN = Path(sys.executable).parent


def same_table(a, b):
    """Every column but the wall times equal, bit for bit."""
    assert list(a.columns) == list(b.columns)
    for name in a.columns:
        if name == "wall":
            continue
        x, y = a[name], b[name]
        if x.dtype == object:
            assert list(x) == list(y), name
        else:
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The standard sweep on one local worker process."""
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    return sp.sweep(DOGFIGHT, VARY, seeds=SEEDS, workers=1, out=out)


def test_the_table_has_a_row_per_run_with_its_values_and_figures(reference):
    t = reference
    assert len(t) == 40 and t.ok.all()
    assert list(t["index"]) == list(range(40))
    # combinations in key order, the last key fastest, every seed for each
    assert list(t["missiles.seeker.nav_constant"][::10]) == [3.0, 3.0, 4.0, 4.0]
    assert list(t["world.dt"][::10]) == [0.004, 0.008, 0.004, 0.008]
    assert list(t["seed"][:10]) == list(range(10))
    assert list(t["steps"][:10]) == [7500] * 10 and list(t["steps"][10:20]) == [3750] * 10
    assert len(set(t["run_seed"].tolist())) == 40          # each run its own World seed
    # each row is what that run gives when run here, in this process
    run = sp.SweepRun(13, {"missiles.seeker.nav_constant": 3.0, "world.dt": 0.008}, 3,
                      int(t["run_seed"][13]))
    job = {"text": DOGFIGHT.read_text(), "source": str(DOGFIGHT), "measure": None,
           "setup": None, "logs": None}
    row = run_one(job, run)
    assert row["status"] == "ok"
    assert (row["survivors"], row["steps"], row["t"], row["energy_error"]) == \
        (t["survivors"][13], t["steps"][13], t["t"][13], t["energy_error"][13])
    assert row["events"].get("destroy", 0) == t["events.destroy"][13]
    # the seed reaches the World: the debris of the same explosion, thrown by another seed,
    # falls otherwise (one seed for all would make a combination's rows equal)
    debris = [{(t["events.destroy"][i], t["events.expiry"][i]) for i in range(k * 10, k * 10 + 10)}
              for k in range(4)]
    assert max(len(d) for d in debris) > 1
    # and the varied guidance changes who survives
    assert len({tuple(t["survivors"][k * 10:(k + 1) * 10]) for k in range(4)}) > 1


def test_two_workers_give_the_same_table_as_one(reference, tmp_path):
    t = sp.sweep(DOGFIGHT, VARY, seeds=SEEDS, workers=2, out=tmp_path / "two.h5")
    same_table(t, reference)
    same_table(read_sweep(tmp_path / "two.h5"), reference)
    assert not (tmp_path / "two.h5.partial").exists()


def failing_setup(world, names, run):
    if run.params["param.fail"]:
        raise RuntimeError(f"setup refused run {run.index}")
    for k in range(run.seed):                    # far-off markers, one per seed number
        names[f"marker{k}"] = world.add_body(0.0, [1e4 + 10.0 * k, 0.0])


def blue_measure(result, run):
    ids = set(result.world.ids.tolist())
    return {"blue_alive": result.names["blue"] in ids,
            "markers": sum(result.names[f"marker{k}"] in ids for k in range(run.seed))}


def test_a_run_that_raises_is_a_row_with_its_error_not_retried(tmp_path):
    out = tmp_path / "faults.h5"
    vary = {"param.fail": [False, True]}
    t = sp.sweep(DOGFIGHT, vary, seeds=range(3), setup=failing_setup, measure=blue_measure,
                 workers=2, out=out)
    assert list(t["status"]) == ["ok"] * 3 + ["error"] * 3
    assert list(t["error"][3:]) == [f"RuntimeError: setup refused run {k}" for k in (3, 4, 5)]
    assert list(t["error"][:3]) == ["", "", ""]
    assert t.measures == ["blue_alive", "markers"]
    # no figures for a failed run: NaN, -1, and the measures' own "missing"
    assert np.isnan(t["energy_error"][3:]).all() and (t["events.destroy"][3:] == -1).all()
    assert np.isnan(t["blue_alive"][3:]).all() and np.isnan(t["markers"][3:]).all()
    # the setup reached the World, and the measure the end of the run
    assert list(t["bodies0"][:3] - t["bodies0"][0]) == [0, 1, 2]
    assert list(t["markers"][:3]) == [0.0, 1.0, 2.0]
    # run again with the same out: finished (errors included), nothing runs again
    mtime = out.stat().st_mtime_ns
    again = sp.sweep(DOGFIGHT, vary, seeds=range(3), setup=failing_setup,
                     measure=blue_measure, workers=2, out=out)
    same_table(again, t)
    assert list(again["wall"]) == list(t["wall"]) and out.stat().st_mtime_ns == mtime


def crashing_setup(world, names, run):
    if run.params["param.crash"]:
        os._exit(3)                               # the worker process dies with the run


def test_a_run_that_kills_its_workers_is_a_row_with_the_error(tmp_path):
    import dask
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):
        t = sp.sweep(DOGFIGHT, {"param.crash": [False, True]}, seeds=range(2),
                     setup=crashing_setup, workers=2, out=tmp_path / "crash.h5")
    assert list(t["status"]) == ["ok", "ok", "error", "error"]
    assert all("KilledWorker" in e for e in t["error"][2:]), t["error"]
    assert np.isnan(t["wall"][2:]).all() and (t["steps"][2:] == -1).all()


def _wait_rows(partial, rows, proc, limit=120.0):
    """Wait until the journal holds `rows` finished runs (its header line besides)."""
    end = time.monotonic() + limit
    while time.monotonic() < end:
        if partial.exists() and partial.read_text().count("\n") >= rows + 1:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    raise AssertionError(f"{partial} did not reach {rows} rows")


def test_an_interrupted_sweep_resumes_where_it_stopped(reference, tmp_path):
    out = tmp_path / "resume.h5"
    partial = Path(str(out) + ".partial")
    cmd = [str(BIN / "spacephys"), "sweep", str(DOGFIGHT), *CLI_VARY, "--workers", "2",
           "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    _wait_rows(partial, 8, proc)
    os.killpg(proc.pid, signal.SIGKILL)           # the driver and its workers, at once
    proc.wait()
    assert not out.exists()                       # nothing presented as complete
    before = {}
    for line in partial.read_text().split("\n")[1:]:
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        before[row["index"]] = row["wall"]
    assert 8 <= len(before) < 40
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"resumed       {len(before)} runs" in done.stdout
    t = read_sweep(out)
    same_table(t, reference)
    # the runs finished before the kill were not run again: their wall times kept
    assert all(t["wall"][k] == w for k, w in before.items())
    assert not partial.exists()


def test_a_real_scheduler_and_two_workers_one_killed_mid_sweep(reference, tmp_path):
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    info = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen(
            [str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(info)],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        end = time.monotonic() + 60
        while not info.exists() and time.monotonic() < end:
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        for k in range(2):
            procs.append(subprocess.Popen(
                [str(BIN / "dask"), "worker", "--scheduler-file", str(info), "--nthreads",
                 "1", "--no-nanny", "--no-dashboard", "--name", f"w{k}"],
                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        out = tmp_path / "cluster.h5"
        partial = Path(str(out) + ".partial")
        sweep = subprocess.Popen(
            [str(BIN / "spacephys"), "sweep", str(DOGFIGHT), *CLI_VARY, "--scheduler",
             address, "--out", str(out), "--quiet"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _wait_rows(partial, 5, sweep)
        procs[1].kill()                            # worker w0, mid-sweep
        procs[1].wait()
        stdout, stderr = sweep.communicate(timeout=300)
        assert sweep.returncode == 0, stderr
        t = read_sweep(out)
        # every run present exactly once, all finished (w0's on w1), the same numbers
        assert sorted(t["index"].tolist()) == list(range(40)) and t.ok.all()
        same_table(t, reference)
    finally:
        for p in procs:
            p.kill()
            p.wait()


def test_the_command_exits_1_when_a_run_failed_with_the_table_written(tmp_path, capsys):
    out = tmp_path / "failed.h5"
    # throttle 2 passes the file's checks (any number) and is refused by the World at t = 4
    code = main(["sweep", str(DOGFIGHT), "--vary", "timeline[3].control.throttle=0.0,2.0",
                 "--workers", "2", "--out", str(out), "--quiet"])
    printed = capsys.readouterr().out
    assert code == 1 and "runs          2 (1 ok, 1 errors)" in printed
    t = read_sweep(out)
    assert list(t["status"]) == ["ok", "error"] and "must be in [0, 1]" in t["error"][1]


def test_each_run_records_its_own_log(tmp_path):
    logs = tmp_path / "logs"
    t = sp.sweep(DOGFIGHT, {"world.dt": [0.008]}, seeds=range(2), workers=2, logs=logs)
    assert sorted(p.name for p in logs.iterdir()) == ["run_00000.h5", "run_00001.h5"]
    for k in range(2):
        run = sp.open_run(logs / f"run_{k:05d}.h5")
        # the log ends where the row says the run ended, with its events
        assert run.times[-1] == t["t"][k]
        assert len(run.events("destroy")) == t["events.destroy"][k]
        assert len(run.events("expiry")) == t["events.expiry"][k] > 0
        run.close()


def test_key_paths_lead_to_a_table_entry_or_are_refused():
    sc = load_scenario(DOGFIGHT, {"ships.blue.a": 90.0, "ships[0].spec.max_thrust": 2.0,
                                  "timeline[1].launch.target": "blue", "world.dt": 0.002})
    assert sc.data["ships"][1]["a"] == 90.0 and sc.data["ships"][0]["spec"]["max_thrust"] == 2.0
    assert sc.data["world"]["dt"] == 0.002
    assert key_parts("timeline[1].launch.target") == ["timeline", 1, "launch", "target"]
    for key, value, message in [
            ("ships.hunter.vel", [1.0, 0.0], "ships has no entry named 'hunter' (named: red, blue)"),
            ("timeline[9].t", 1.0, "timeline has 4 entries, no [9]"),
            ("world.dt.x", 1.0, "world.dt is a value, not a table"),
            ("boundary.mode", "wrap", "the scenario has no boundary"),
            ("world.dtt", 1.0, "unknown key"),
            ("world.dt", "fast", "must be a number, got 'fast'"),
            ("ships[0].vel", [1.0], "must be 2 numbers"),
            ("a..b", 1, "expected names and [index]es joined by dots")]:
        with pytest.raises(ScenarioError) as err:
            load_scenario(DOGFIGHT, {key: value})
        assert message in str(err.value), (key, str(err.value))


def test_vary_values_are_toml_or_words():
    assert parse_vary("world.dt=1e-3,0.002") == ("world.dt", [1e-3, 0.002])
    assert parse_vary("ships.red.vel=[1, 0],[2.5,0]") == ("ships.red.vel", [[1, 0], [2.5, 0]])
    assert parse_vary('world.integrator=leapfrog,"rk4",true') == \
        ("world.integrator", ["leapfrog", "rk4", True])
    for bad in ("world.dt", "=1,2", "world.dt=", "world.dt=1,,2"):
        with pytest.raises(ValueError, match="--vary"):
            parse_vary(bad)


@pytest.mark.parametrize("args, message", [
    (["--vary", "ships.hunter.vel=[1,0]"], "ships has no entry named 'hunter'"),
    (["--vary", "world.dt=0.01,fast"], "world.dt = 'fast': world.dt: must be a number"),
    (["--vary", "world.seed=1,2"], "world.seed is set for each run"),
    (["--vary", "world.dt"], "expected KEY=V1,V2"),
    (["--vary", "world.dt=0.01", "--vary", "world.dt=0.02"], "given twice"),
    (["--seeds", "0"], "--seeds 0"),
    (["--workers", "0"], "workers = 0"),
    (["--scheduler", "tcp://127.0.0.1:9"], "cannot be reached"),
    (["--scheduler", "tcp://127.0.0.1:9", "--workers", "2"], "a cluster given by address"),
])
def test_bad_input_exits_2_naming_it_and_writes_nothing(args, message, tmp_path, capsys):
    out = tmp_path / "bad.h5"
    start = time.monotonic()
    code = main(["sweep", str(DOGFIGHT), "--out", str(out), "--quiet", *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err, err
    assert time.monotonic() - start < 15                  # a clear error, not a hang
    assert list(tmp_path.iterdir()) == []


def test_an_out_holding_another_sweep_is_refused_untouched(reference, tmp_path):
    out = tmp_path / "other.h5"
    sp.sweep(DOGFIGHT, {"world.dt": [0.008]}, workers=1, out=out)
    before = out.read_bytes()
    with pytest.raises(ValueError, match="holds another sweep"):
        sp.sweep(DOGFIGHT, {"world.dt": [0.004]}, workers=1, out=out)
    assert out.read_bytes() == before
