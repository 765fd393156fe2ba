"""spacephys.netplay: two real processes on 127.0.0.1 play scripted inputs through the
rollback session over UDP, under latency, jitter and loss, and end on the bits of one
process given the same inputs; a planted desync is named with its frame; bad packets and
inputs are dropped and counted."""
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import spacephys as sp
from spacephys import netplay
from spacephys.netplay import Channel, Conditions, Inputs, Packet, Session

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from test_snapshot import TORPEDO, _duel  # noqa: E402

SPECS = (TORPEDO,)


@pytest.fixture(scope="module", autouse=True)
def compiled():
    """The duel's kernels compiled (or loaded) here first, as a game warms up before it
    connects: a peer compiling a kernel for the first time on this machine is silent to the
    other for as long (a clean clone's first run)."""
    w, _ = _duel()
    for frame in range(600):
        for p in (0, 1):
            inp = Inputs(SPECS)
            inp.control(1 + p, throttle=(frame // (5 + p)) % 2 * 0.8, turn=0.3 - p * 0.6)
            if frame % 9 == 4 * p:
                inp.launch(1 + p, 0, target=2 - p)
            inp.apply(w)
        w.step(2)
    from spacephys.game.modes import autoplay
    autoplay("duel", 600)


def _pair(tmp_path, name, frames, latency=0.0, jitter=0.0, loss=0.0, **extra):
    """Start the two peers (tests/netplay_peer.py); returns a function that waits for them
    and gives their two reports."""
    opts = ["--frames", str(frames), "--latency", str(latency), "--jitter", str(jitter),
            "--loss", str(loss)]
    for key, value in extra.items():
        opts += [f"--{key.replace('_', '-')}", str(value)]
    outs = [tmp_path / f"{name}-{p}.json" for p in (0, 1)]
    host = subprocess.Popen([sys.executable, str(HERE / "netplay_peer.py"), "0", str(outs[0]),
                             *opts], stdout=subprocess.PIPE, text=True)
    port = int(host.stdout.readline())
    join = subprocess.Popen([sys.executable, str(HERE / "netplay_peer.py"), "1", str(outs[1]),
                             "--peer", f"127.0.0.1:{port}", *opts])

    def wait():
        try:
            for p in (host, join):
                assert p.wait(timeout=90 + frames / 20) == 0
        finally:
            for p in (host, join):
                p.kill()
        return [json.loads(o.read_text()) for o in outs]
    return wait


def _one_process(history):
    """The duel stepped in one process with the inputs the peers confirmed."""
    w, _ = _duel()
    for _, mine, theirs in history:
        for data in (mine, theirs):
            Inputs.decode(bytes.fromhex(data), SPECS).apply(w)
        w.step(2)
    return w.digest()


def test_two_processes_end_on_the_bits_of_one(tmp_path):
    # 3 600 frames (a minute at 60 Hz) at 0, 50 and 150 ms one way, 20 ms jitter, 10 % of
    # the datagrams lost, the three pairs side by side
    cases = {"0 ms": (0.0, 0.0), "50 ms": (0.05, 0.02), "150 ms": (0.15, 0.02)}
    waits = {name: _pair(tmp_path, name.replace(" ", ""), 3600, latency, jitter, 0.1)
             for name, (latency, jitter) in cases.items()}
    for name, wait in waits.items():
        a, b = wait()
        assert a["frames"] == b["frames"] == 3600, name
        assert a["desync"] is None and b["desync"] is None, name
        assert a["history"] == b["history"] and len(a["history"]) == 3600, name
        assert [h[1] for h in a["history"]] == a["mine"], name      # player 0's own inputs
        assert [h[2] for h in b["history"]] == b["mine"], name
        assert a["digest"] == b["digest"] == _one_process(a["history"]), name
        for r in (a, b):
            lost = r["stats"]["dropped"].get("lost on the way (test conditions)", 0)
            assert 0.05 < lost / r["stats"]["packets_out"] < 0.15, name
            if name != "0 ms":
                assert r["stats"]["rollbacks"] > 50, (name, r["stats"])
        if name == "150 ms":
            # one way beyond the 8-frame window (133 ms): the sessions waited, and the minute
            # took longer than a minute
            assert a["stats"]["waits"] > 100 and a["seconds"] > 62, a["stats"]
            # the last round trip measured: each way 150 ms +- 20 ms of jitter, so 260..340 ms
            # plus the time the datagram waits for the peer's next read
            assert 2e3 * (0.15 - 0.02) - 1 < a["stats"]["ping_ms"] < 400, a["stats"]


def test_a_desync_is_named_with_its_frame(tmp_path):
    a, b = _pair(tmp_path, "tamper", 400, 0.02, 0.01, 0.0, tamper=250, digest_every=1)()
    assert a["desync"] == b["desync"] == 250
    assert a["digest"] != b["digest"]


def test_no_desync_is_reported_without_one(tmp_path):
    # the same run as above but for the planted change: the check is not merely noisy
    a, b = _pair(tmp_path, "clean", 400, 0.02, 0.01, 0.0, digest_every=1)()
    assert a["desync"] is None and b["desync"] is None and a["digest"] == b["digest"]


# ----------------------------------------------------------------------------- in one process

def _sessions(conditions=(None, None), **kw):
    """Two sessions on two loopback sockets of this process."""
    a_world, _ = _duel()
    b_world, _ = _duel()
    ca = Channel(0, None, conditions=conditions[0])
    cb = Channel(0, ("127.0.0.1", ca.port), conditions=conditions[1])
    return (Session(a_world, 0, ca, specs=SPECS, **kw),
            Session(b_world, 1, cb, specs=SPECS, **kw))


def _idle(*sessions, seconds=0.05):
    until = time.perf_counter() + seconds
    while time.perf_counter() < until:
        for s in sessions:
            s.poll()
        time.sleep(0.001)


def test_beyond_the_window_a_session_waits_and_says_so():
    a, b = _sessions(window=4)
    try:
        for f in range(4):
            assert a.advance(a.input())
        assert not a.advance(a.input()) and a.waiting and a.stats["waits"] == 1
        assert b.advance(b.input())          # the other player catches up by one frame
        _idle(a, b)
        assert a.advance(a.input()) and not a.waiting
    finally:
        a.channel.close()
        b.channel.close()


def test_a_peer_that_falls_silent_is_an_error_not_a_hang():
    a, b = _sessions(window=2, silence=0.3)
    try:
        b.advance(b.input())                 # heard once...
        b.channel.close()                    # ...then gone
        with pytest.raises(ConnectionError, match="nothing heard from the other player"):
            for _ in range(1000):
                a.advance(a.input())
                time.sleep(0.01)
        assert a.frame == 3                  # its window past b's one frame
    finally:
        a.channel.close()


def test_a_host_waits_for_its_player_to_come():
    w, _ = _duel()
    c = Channel(0)
    s = Session(w, 0, c, specs=SPECS, window=2, silence=0.1)
    try:
        for _ in range(30):                  # 0.3 s, three times the silence: nobody yet
            s.advance(s.input())
            time.sleep(0.01)
        assert s.frame == 2 and s.waiting
    finally:
        c.close()


def test_a_late_input_rolls_back_and_steps_again():
    a, b = _sessions()
    try:
        ship = 2
        for f in range(6):
            a.advance(a.input())
        inp = b.input()
        inp.control(ship, throttle=1.0)      # b's frame 0: a guessed "nothing"
        b.advance(inp)
        _idle(a, b)
        assert a.stats["rollbacks"] == 1 and a.stats["frames_resimulated"] == 6
        w, _ = _duel()
        w.control(ship, throttle=1.0)
        w.step(12)
        assert a.world.digest() == w.digest()
    finally:
        a.channel.close()
        b.channel.close()


@pytest.mark.parametrize("data, why", [
    (b"", "short"),
    (b"XXXX" + bytes(60), "not a spacephys packet"),
    (bytes(netplay.link.MAX_PACKET + 1), "oversized"),
    (None, "malformed"),
], ids=["empty", "magic", "oversized", "truncated"])
def test_bad_packets_are_dropped_and_counted(data, why):
    a, b = _sessions()
    try:
        a.advance(a.input())
        b.advance(b.input())
        _idle(a, b)
        if data is None:                      # a real packet, cut short
            inp = b.input()
            inp.control(2, throttle=0.5)
            data = Packet(0, 1, 1, 0, [inp.encode()], [], 0.0, 0.0, 0.0).encode()[:-3]
        state = a.world.digest()
        b.channel.sock.sendto(data, ("127.0.0.1", a.channel.port))
        _idle(a)
        assert any(k.startswith(why) for k in a.channel.dropped), a.channel.dropped
        assert a.world.digest() == state and a.frame == 1
    finally:
        a.channel.close()
        b.channel.close()


def test_a_packet_from_an_unknown_peer_is_dropped():
    a, b = _sessions()
    stranger = Channel(0, ("127.0.0.1", a.channel.port))
    try:
        a.advance(a.input())
        b.advance(b.input())
        _idle(a, b)
        inp = Inputs(SPECS)
        inp.control(2, throttle=1.0)
        stranger.send(Packet(0, 1, 0, 0, [inp.encode()], [], 0.0, 0.0, 0.0).encode())
        _idle(a)
        assert a.channel.dropped.get("from an unknown peer") == 1
        assert a.stats["rollbacks"] == 0
    finally:
        for c in (a.channel, b.channel, stranger):
            c.close()


def test_inputs_encode_compactly_and_refuse_what_is_malformed():
    inp = Inputs(SPECS)
    inp.control(3, throttle=0.5, turn=-1.0)
    inp.launch(3, TORPEDO, target=4, heading=(1.0, 0.0))
    data = inp.encode()
    assert len(data) == 2 + 26 + 35        # header + throttle and turn; + target, heading
    back = Inputs.decode(data, SPECS)
    assert back == inp and back.encode() == data
    assert back.held().calls == inp.calls[:1]          # a guess holds controls, not launches
    for bad, why in ((data[:-1], "malformed"), (data + b"x", "past its calls"),
                     (b"\xff\xff", "calls, more than")):
        with pytest.raises(ValueError, match=why):
            Inputs.decode(bad, SPECS)
    with pytest.raises(ValueError, match="spec 0, the session has 0"):
        Inputs.decode(data, ())
    with pytest.raises(ValueError, match="not one of the session"):
        Inputs(SPECS).launch(3, sp.MissileSpec(mass=2.0))
    with pytest.raises(ValueError, match="throttle|turn"):
        Inputs(SPECS).control(3, turn=np.nan)
    with pytest.raises(ValueError, match="body id"):
        Inputs(SPECS).control(-1, throttle=1.0)


def test_bad_settings_are_refused():
    w, _ = _duel()
    c = Channel(0)
    try:
        with pytest.raises(ValueError, match="player = 2"):
            Session(w, 2, c)
        with pytest.raises(ValueError, match="window = 0"):
            Session(w, 0, c, window=0)
        with pytest.raises(ValueError, match="loss = 1.5"):
            Conditions(loss=1.5)
        with pytest.raises(ValueError, match="jitter = 0.2 exceeds"):
            Conditions(latency=0.1, jitter=0.2)
        with pytest.raises(ValueError, match="port = "):
            Channel(c.port)                    # taken
    finally:
        c.close()


def test_the_benchmark_times_a_rollback_and_frames_at_100_ms():
    from spacephys.study.netplaybench import format_netplay, netplay_bench
    r = netplay_bench(quick=True)
    assert [c["mode"] for c in r["rollback"]] == ["duel", "arena"]
    for c in r["rollback"]:
        assert 0.0 < c["frames_s"] < 1.0 and 0.0 < c["rollback_s"] < 1.0
    lat = r["latency"]
    assert lat["same_digest"] and lat["rollbacks"] > 0 and lat["latency_ms"] == 100.0
    assert 0.0 < lat["median_ms"] <= lat["p95_ms"] <= lat["max_ms"]
    assert "a rollback" in format_netplay(r)


# ----------------------------------------------------------------------------- the game

def _free_port():
    import socket
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_play_duel_host_and_join_end_on_one_digest():
    # the game's duel over loopback, the computer flying each side, headless: both print the
    # same final digest and the same score
    port = _free_port()
    cmd = [sys.executable, "-m", "spacephys", "play", "duel", "--headless", "--frames", "400",
           "--players", "0"]
    host = subprocess.Popen(cmd + ["--host", str(port)], stdout=subprocess.PIPE, text=True)
    join = subprocess.run(cmd + ["--join", f"127.0.0.1:{port}"], capture_output=True,
                          text=True, timeout=300)
    out = host.communicate(timeout=300)[0]
    assert host.returncode == 0 and join.returncode == 0, join.stderr
    finals = [next(line for line in text.splitlines() if line.startswith("final digest"))
              for text in (out, join.stdout)]
    assert finals[0].split()[2] == finals[1].split()[2]
    assert "after 400 frames" in finals[0]
    scores = [text.splitlines()[0] for text in (out, join.stdout)]
    assert scores[0] == scores[1] and scores[0].startswith("Spacewar!")
    assert "the other player" in out and "ping" in join.stdout


@pytest.mark.parametrize("args, said", [
    (["--join", "127.0.0.1"], "give HOST:PORT"),
    (["--host", "0", "--join", "127.0.0.1:1"], "give one"),
    (["orbit", "--host", "0"], "only the duel"),
    (["--host", "0", "--record", "x.h5"], "not recorded"),
    (["--join", "no.such.host.invalid:4000"], "not a reachable"),
])
def test_play_over_the_network_refuses_what_it_cannot_do(args, said, tmp_path):
    mode = [] if args[0] == "orbit" else ["duel"]
    res = subprocess.run([sys.executable, "-m", "spacephys", "play", *mode, "--headless",
                          "--frames", "1", *args], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert res.returncode != 0 and said in res.stderr, res.stderr
    assert not (tmp_path / "x.h5").exists()
