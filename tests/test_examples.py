"""The scripts in examples/ run as a user runs them, and say what they should."""
import math
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_salvo_sweep_plots_hit_probability_against_spread(tmp_path):
    png = tmp_path / "salvo.png"
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "salvo_sweep.py"),
                           "--seeds", "4", "--out", str(png)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [s for s in done.stdout.splitlines() if "hit probability" in s]
    assert len(lines) == 7
    # no spread: both missiles fly the same line, and it hits, whatever the seed
    assert lines[0] == "spread   0.0 deg: hit probability 1.00 +- 0.00"
    # the widest spread misses at least once in 4 seeds × 2 missiles
    assert float(lines[-1].split()[5]) < 1.0
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def run_example(name, *args):
    """Run examples/<name> as a user does; its stdout, after checking it exited 0."""
    done = subprocess.run([sys.executable, str(ROOT / "examples" / name), *map(str, args)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def numbers(line):
    """The numbers in a printed line, in order."""
    return [float(x) for x in re.findall(r"[-+]?\d+(?:\.\d*)?(?:e[-+]?\d+)?", line)]


def line_with(out, start):
    lines = [s for s in out.splitlines() if s.startswith(start)]
    assert len(lines) == 1, (start, out)
    return lines[0]


def test_game_loop_takes_fixed_steps_for_varying_frames():
    out = run_example("game_loop.py")
    frames, played, simulated, dropped = numbers(line_with(out, "frames "))
    total, fewest, most = numbers(line_with(out, "steps "))
    lo, hi = numbers(line_with(out, "alpha "))
    fallen, n0, n1 = numbers(line_with(out, "rocks fallen"))
    dt = 1 / 120
    assert frames == 600
    assert total == round(simulated / dt)                 # whole steps of dt, no fractions
    assert abs(played - simulated - dropped) < dt + 1e-3  # the rest waits in the accumulator
    # the three hitches of 0.25 s: 8 steps each (max_substeps), the rest of each dropped
    assert most == 8 and 0.5 < dropped <= 3 * 0.25 and fewest >= 0
    assert 0 <= lo < 0.1 and 0.9 < hi < 1                 # alpha covers [0, 1)
    assert fallen > 0 and n0 - n1 == fallen               # each DESTROY event: a rock gone
    # the ship circles at r = 100: every interpolated drawing position is on that circle
    drawn = [numbers(s.split("drawn at")[1]) for s in out.splitlines() if "drawn at" in s]
    assert len(drawn) == 4
    for x, y in drawn:
        assert abs(math.hypot(x, y) - 100) < 0.02


def test_missile_salvo_detonates_on_the_target():
    out = run_example("missile_salvo.py")
    launches = [s for s in out.splitlines() if "  launch " in s]
    assert len(launches) == 4 and all(s.endswith("from red") for s in launches)
    booms = [s for s in out.splitlines() if "  detonation " in s]
    assert len(booms) == 1 and " at blue: " in booms[0]   # the first hit kills it
    t, _, miss, closing, debris = numbers(booms[0])
    assert 0 <= miss <= 4.0 and closing > 0 and debris == 40   # fuse radius 4; blue's 40
    assert t > numbers(launches[-1])[0]
    # every missile is accounted for: one detonated, the others ran out of life
    tally = dict((k, v) for v, k in re.findall(r"(\d+) (\w+)", line_with(out, "tally:")))
    assert tally["launch"] == "4" and int(tally["detonation"]) + int(tally["expiry"]) == 4
    assert line_with(out, "result:").startswith("result: blue destroyed by missile")
    assert numbers(line_with(out, "result:"))[-1] == t


def test_hohmann_transfer_reaches_the_goal_orbit():
    out = run_example("hohmann_transfer.py")
    r_apo, t_apo, _, t_burn2 = numbers(line_with(out, "first burn alone"))
    assert abs(r_apo - 2.0) < 1e-4 and abs(t_apo - t_burn2) < 0.01
    final = [s for s in out.splitlines() if s.startswith("whole plan")]
    assert len(final) == 2
    for s in final:
        assert abs(numbers(s)[0] - 2.0) < 1e-4            # the final orbit's apsides
    burned, fuel = numbers(line_with(out, "fuel burned"))
    assert 0.005 < burned < fuel                          # delta-v 0.284 at ve 50: 0.0057
    assert numbers(line_with(out, "prediction vs flight"))[0] == 0.0   # bit for bit
    goal, a, e, r_lo, r_hi = numbers(line_with(out, "goal radius"))
    # one burn only would leave a = 1.5, e = 0.33; a wrong second burn, e of 1e-2 or more
    assert goal == 2.0 and abs(a - goal) < 1e-4 and e < 1e-4
    assert goal - 1e-4 < r_lo <= r_hi < goal + 1e-4


def test_laser_hits_what_is_in_line_nearest_first():
    out = run_example("laser.py")
    shots = [s for s in out.splitlines() if s.startswith("shot ")]
    hit = [s.split()[3] for s in shots]
    # "aside" is the nearest rock but off the line; "grazed" pokes 0.5 into it
    assert hit == ["first", "grazed", "behind", "wall"], out
    # distances from the ship's centre, which the ray leaves out: centre distance along the
    # line minus the half chord's depth; the points on the line at 30 degrees
    expected = [150 - 10, 220 - math.sqrt(4 ** 2 - 3.5 ** 2), 300 - 20, 400]
    for s, d in zip(shots, expected):
        distance, x, y = numbers(s.split("distance")[1])
        assert abs(distance - d) < 1e-5, s
        assert abs(math.hypot(x, y) - d) < 1e-5
        assert abs(math.atan2(y, x) - math.pi / 6) < 1e-6
    assert line_with(out, "rocks left:") == "rocks left: aside"


def test_replay_match_replays_bit_for_bit(tmp_path):
    log = tmp_path / "match.h5"
    out = run_example("replay_match.py", log)
    assert log.stat().st_size > 0
    assert line_with(out, "replay:").startswith("replay: identical (101 recorded frames,")
    frames, t0, t1 = numbers(line_with(out, "log:"))
    assert (frames, t0, t1) == (101, 0.0, 10.0)          # every 6th of 600 steps, and t = 0
    inputs = {k: int(v) for v, k in re.findall(r"(\d+) (\w+)", line_with(out, "inputs:"))}
    events = {k: int(v) for v, k in re.findall(r"(\d+) (\w+)", line_with(out, "events:"))}
    assert inputs["step"] == 600 and inputs["control"] > 0
    assert inputs["launch"] == events["launch"] > 0        # each launch call, one event
    assert events["destroy"] >= 2                          # a torpedo and the ship it hit
    seen, of, last = numbers(line_with(out, "omega:"))
    assert of == 101 and seen < 101 and abs(last - 0.1 * (seen - 1)) < 1e-9
    assert line_with(out, "omega:").endswith("survivors: alpha")


def test_asteroids_plays_itself_headless():
    """examples/asteroids.py with the computer flying: its laser and its torpedoes break
    rocks into debris, and each scores the rock's tag (5, 7 or 12), the torpedoes' read from
    the destroy events (tag_a, tag_b); the enemy fires a guided missile every 4 s."""
    out = run_example("asteroids.py", "--headless", "--frames", "1200")
    line = line_with(out, "frames ")
    frames, score, left, lasered, torpedoed, debris = numbers(line)[:6]
    assert frames == 1200 and lasered >= 1 and torpedoed >= 1
    assert left == 14 - lasered - torpedoed
    assert 5 * (lasered + torpedoed) <= score <= 12 * (lasered + torpedoed)
    assert debris >= 12                                   # a rock's ExplosionSpec(count=12)
    assert "enemy alive after firing 5 missiles" in line
