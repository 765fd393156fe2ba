"""One peer of a two-process netplay test (tests/test_netplay.py): the duel of
tests/test_snapshot.py, scripted inputs at 60 frames a second, a report as JSON.

python netplay_peer.py PLAYER OUT.json [--peer HOST:PORT] [--latency S] [--jitter S]
    [--loss P] [--frames N] [--tamper F]; the host (no --peer) prints its port first.
--tamper F: player 1's game adds a grain of debris at frame F without telling the other (a
desync the session must name).
"""
import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import spacephys as sp                         # noqa: E402
from spacephys import netplay                  # noqa: E402
from test_snapshot import TORPEDO, _duel      # noqa: E402

SPECS = (TORPEDO,)


def script(session, frame):
    """Player p flies ship p + 1 (the duel's ids 1 and 2): throttle and turn by frame, a
    torpedo at the other every 9 frames (refused alike on both peers once a ship is gone)."""
    p = session.player
    inp = session.input()
    inp.control(1 + p, throttle=(frame // (5 + p)) % 2 * 0.8,
                turn=((frame // 3 + p) % 3 - 1) * 0.7)
    if frame % 9 == 4 * p:
        inp.launch(1 + p, TORPEDO, target=2 - p)
    return inp


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("player", type=int)
    ap.add_argument("out")
    ap.add_argument("--peer")
    ap.add_argument("--latency", type=float, default=0.0)
    ap.add_argument("--jitter", type=float, default=0.0)
    ap.add_argument("--loss", type=float, default=0.0)
    ap.add_argument("--frames", type=int, default=3600)
    ap.add_argument("--digest-every", type=int, default=10)
    ap.add_argument("--tamper", type=int, default=-1)
    a = ap.parse_args()
    w, _ = _duel()
    peer = None if a.peer is None else (a.peer.split(":")[0], int(a.peer.split(":")[1]))
    channel = netplay.Channel(0, peer, conditions=netplay.Conditions(
        a.latency, a.jitter, a.loss, seed=11 + a.player))
    if peer is None:
        print(channel.port, flush=True)

    def frame(world, number, inputs):
        if number == a.tamper and a.player == 1:
            world.add_body(0.0, (500.0, 500.0), kind="debris")   # not sent: a desync
        for inp in inputs:
            inp.apply(world)
        world.step(2)

    session = netplay.Session(w, a.player, channel, specs=SPECS, frame=frame,
                              digest_every=a.digest_every)
    mine = []
    start = time.perf_counter()
    tick = start
    while session.frame < a.frames:
        inp = script(session, session.frame)
        if session.advance(inp):
            mine.append(inp.encode().hex())
        tick += 1 / 60
        pause = tick - time.perf_counter()
        if pause > 0:
            time.sleep(pause)
    digest = session.finish(timeout=60.0)
    channel.close()
    with open(a.out, "w") as f:
        json.dump({"digest": digest, "frames": session.frame, "desync": session.desync,
                   "mine": mine, "seconds": time.perf_counter() - start,
                   "history": [[f, x.hex(), y.hex()] for f, x, y in session.history()],
                   "stats": session.stats, "version": sp.__version__}, f)


if __name__ == "__main__":
    main()
