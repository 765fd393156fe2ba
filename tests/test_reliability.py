"""Reliability under faults (issue 14): run logs that survive a kill at any moment, logs
followed while written, the superblock repair, and older formats still read."""
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import spacephys as sp
from spacephys import h5writer

DATA = Path(__file__).parent / "data"

# A fork server: imports spacephys and loads the kernels once, then forks a recorder for each
# path it reads on stdin and prints the recorder's pid, then "dead" once it was killed. The
# recorder flies 4 000 bodies in a straight line (no gravity: it is the log under test) and
# commits a frame every step and a checkpoint every 4 frames, so most of its time is spent
# writing; after each step it prints the frames committed and the share of its time spent
# inside the log's writes. One thread: the server forks, so it must not start numba's pool.
KILL_SERVER = r"""
import os, sys, time
import numpy as np
import spacephys as sp

def recorder(path):
    w = sp.World(2, dt=0.01, gravity="none")
    w.threads = "never"
    k = np.arange(4000.0)
    w.add_bodies(np.ones(4000), np.c_[k, -k], np.c_[np.cos(k), np.sin(k)])
    log = w.record(path, every=1, flush_seconds=0.0, checkpoint_every=4,
                   checkpoint_seconds=1e9)
    inside = [0.0]
    def timed(write):
        def run(*args):
            t = time.perf_counter()
            try:
                return write(*args)
            finally:
                inside[0] += time.perf_counter() - t
        return run
    log._write_buffers = timed(log._write_buffers)
    log._write_checkpoint = timed(log._write_checkpoint)
    start, frames = time.perf_counter(), 1
    print("f", frames, 0.0, flush=True)
    while True:
        w.step(1)
        frames += 1
        print("f", frames, inside[0] / (time.perf_counter() - start), flush=True)

warm = os.path.join(sys.argv[1], "warm.h5")
w = sp.World(2, dt=0.01, gravity="none")
w.threads = "never"
w.add_bodies(np.ones(3), np.zeros((3, 2)), np.ones((3, 2)))
with w.record(warm, every=1):
    w.step(2)
sp.resume(warm).recording.close()
with sp.open_run(warm) as run:
    run.world()
print("ready", flush=True)
for line in sys.stdin:
    pid = os.fork()
    if pid == 0:
        sys.stdin.close()
        recorder(line.strip())
        os._exit(0)
    print("pid", pid, flush=True)
    os.waitpid(pid, 0)
    print("dead", flush=True)
"""


def test_a_log_survives_100_kills_at_random_moments(tmp_path):
    """100 SIGKILLs at random moments of a recording (its creation, steps, flushes and
    checkpoints): each file opens with sp.open_run and with h5py (SWMR read at once; a plain
    open after spacephys cleared the dead writer's flags), holds every frame committed before
    the kill, its frames are right, and sp.resume continues it."""
    server = subprocess.Popen([sys.executable, "-c", KILL_SERVER, str(tmp_path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    rng = random.Random(14)
    shares, kills, empty = [], 0, 0
    try:
        assert server.stdout.readline().strip() == "ready", server.stderr.read()
        for k in range(100):
            path = tmp_path / f"kill{k}.h5"
            server.stdin.write(f"{path}\n")
            server.stdin.flush()
            word, pid = server.stdout.readline().split()
            assert word == "pid"
            time.sleep(rng.uniform(0.0, 0.35))
            os.kill(int(pid), signal.SIGKILL)
            kills += 1
            committed, share = 0, 0.0
            for line in iter(server.stdout.readline, "dead\n"):
                assert line, server.stderr.read()
                _, frames, share = line.split()
                committed, share = int(frames), float(share)
            if committed:
                shares.append(share)
            if not path.exists():
                # killed while making the file, before its rename: nothing was committed
                assert committed == 0
                empty += 1
                continue
            _check_killed_log(path, committed)
    finally:
        server.kill()
        server.communicate(timeout=60)
    # most of a recorder's time is spent inside the log's writes: most kills land there
    assert kills == 100 and len(shares) > 60 and np.mean(shares) > 0.5, (shares, empty)
    print(f"100 kills: {100 - empty} logs checked, {empty} killed before the file existed; "
          f"share of the recorders' time inside writes {np.mean(shares):.2f}")


def _check_killed_log(path, committed):
    with h5py.File(path, "r", swmr=True) as f:            # plain h5py, before any repair
        assert f["frames/pos"].shape[0] >= committed * 4000
    with sp.open_run(path) as run:
        assert not run.meta["closed"]
        F = len(run)
        assert F >= committed
        assert run.steps.tolist() == list(range(F))
        k = np.arange(4000.0)
        last = run.frame(F - 1)
        # a straight line: x = x0 + v t, to the rounding of F - 1 additions of v dt
        want = np.c_[k, -k] + (F - 1) * 0.01 * np.c_[np.cos(k), np.sin(k)]
        np.testing.assert_allclose(last.pos, want, rtol=0, atol=1e-9 * max(F, 1) * 4000)
        saved_step = run.checkpoints[-1][0]
    with h5py.File(path, "r") as f:                      # plain h5py, flags cleared
        assert f["commit"][()]["frames"] == F
    w = sp.resume(path)
    w.step(2)
    w.recording.close()
    with sp.open_run(path) as run:
        assert run.meta["closed"] and run.steps.tolist() == list(range(saved_step + 3))


FOLLOWED = r"""
import sys
import numpy as np
import spacephys as sp
w = sp.World(2, dt=0.01, gravity="none")
w.add_bodies(np.ones(5), np.zeros((5, 2)), np.ones((5, 2)))
log = w.record(sys.argv[1], every=1, flush_seconds=0.0)
print("recording", flush=True)
for line in sys.stdin:
    if line.strip() == "close":
        log.close()
        print("closed", flush=True)
        break
    w.step(int(line))
    print(w.t, flush=True)
"""


def test_a_reader_follows_a_log_while_it_is_written(tmp_path):
    """sp.open_run on a log another process is writing: it reads what was committed,
    refresh() shows what came since; resume refuses while the writer lives."""
    path = tmp_path / "live.h5"
    writer = subprocess.Popen([sys.executable, "-c", FOLLOWED, str(path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "recording", writer.stderr.read()
        writer.stdin.write("3\n")
        writer.stdin.flush()
        writer.stdout.readline()
        run = sp.open_run(path)
        assert len(run) == 4 and not run.meta["closed"]
        with pytest.raises(sp.RunLogError, match=f"being written by process {writer.pid}"):
            sp.resume(path)
        writer.stdin.write("5\n")
        writer.stdin.flush()
        writer.stdout.readline()
        assert len(run) == 4                      # what it read when it was opened...
        run.refresh()
        assert len(run) == 9 and run.steps.tolist() == list(range(9))   # ...and since
        np.testing.assert_allclose(run.frame(8).pos, np.full((5, 2), 0.08), rtol=1e-14)
        writer.stdin.write("close\n")
        writer.stdin.flush()
        assert writer.stdout.readline().strip() == "closed"
        run.refresh()
        assert run.meta["closed"] and len(run) == 9
        run.close()
    finally:
        writer.kill()
        writer.communicate(timeout=60)
    with h5py.File(path, "r") as f:               # closed by its writer: plain h5py opens it
        assert f["frames/step"].shape == (9,)


# ----------------------------------------------------------------------------- the superblock

def test_lookup3_matches_its_published_values():
    """Bob Jenkins' lookup3.c driver prints these for hashlittle."""
    assert h5writer.hashlittle(b"", 0) == 0xDEADBEEF
    assert h5writer.hashlittle(b"", 0xDEADBEEF) == 0xBD5B7DDE
    assert h5writer.hashlittle(b"Four score and seven years ago", 0) == 0x17770551
    assert h5writer.hashlittle(b"Four score and seven years ago", 1) == 0xCD628161


def test_the_flags_of_a_dead_writer_are_cleared_and_nothing_else(tmp_path):
    """A file left open by a killed SWMR writer: plain h5py refuses it, clear_flags makes it
    open; a superblock whose checksum does not check is left alone (and open_file says so);
    a file that is not HDF5 is refused as such."""
    path = tmp_path / "left.h5"
    code = ("import h5py, os, sys, numpy as np\n"
            "f = h5py.File(sys.argv[1], 'w', libver=('v110', 'v110'))\n"
            "f.create_dataset('x', data=np.arange(5.0), maxshape=(None,), chunks=(4,))\n"
            "f.swmr_mode = True\nf.flush()\nos.kill(os.getpid(), 9)\n")
    subprocess.run([sys.executable, "-c", code, str(path)])
    assert h5writer.flags_set(path)
    with pytest.raises(OSError):
        h5py.File(path, "r")
    damaged = tmp_path / "damaged.h5"
    raw = bytearray(path.read_bytes())
    raw[20] ^= 1                                   # an address: the checksum no longer checks
    damaged.write_bytes(raw)
    assert not h5writer.clear_flags(damaged) and damaged.read_bytes() == raw
    assert h5writer.clear_flags(path) and not h5writer.flags_set(path)
    with h5py.File(path, "r") as f:
        assert f["x"][:].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    not_hdf5 = tmp_path / "text.h5"
    not_hdf5.write_text("hello")
    assert not h5writer.clear_flags(not_hdf5) and not h5writer.flags_set(not_hdf5)
    with pytest.raises(sp.RunLogError, match="text.h5.*not an HDF5 file"):
        sp.open_run(not_hdf5)


def test_a_writer_is_alive_only_while_its_process_runs():
    pid, start = h5writer.writer_id()
    assert h5writer.alive(pid, start)
    assert not h5writer.alive(pid, start + 1)               # the pid, reused by another
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    assert not h5writer.alive(child.pid, 0) and not h5writer.alive(0, 0)


# ----------------------------------------------------------------------------- older formats

def test_version_2_files_still_read_and_are_not_resumed(tmp_path):
    """A log and a world file written by format 2 (checkpoints as groups, no commit):
    frames, checkpoints and World.load read them; resume refuses, naming the version."""
    with sp.open_run(DATA / "version2.h5") as run:
        assert run.meta["format_version"] == 2 and run.meta["closed"]
        assert len(run) == 6 and run.steps.tolist() == [0, 2, 4, 6, 8, 10]
        assert run.checkpoints == [(0, 0.0), (10, 1.0)]
        w = run.world()
        np.testing.assert_array_equal(run.frame(-1).pos, w.pos)
    assert sp.World.load(DATA / "version2.h5").t == w.t == 1.0
    saved = sp.World.load(DATA / "version2_world.h5")
    np.testing.assert_array_equal(saved.pos, w.pos)
    copy = tmp_path / "v2.h5"
    copy.write_bytes((DATA / "version2.h5").read_bytes())
    with pytest.raises(sp.RunLogError, match="v2.h5.*format version 2.*resume"):
        sp.resume(copy)
