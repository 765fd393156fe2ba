"""A rollback session between two peers (GGPO's scheme): each applies its own player's input
at once, guesses the other's (the last one known, held), and when the real one arrives and
differs, restores the World to that frame and steps again to the present.

A frame is the game's: `frame(world, number, inputs)` applies both players' Inputs (in
player order) and steps the World (the default: apply, then `steps` steps). The game's own
state (scores, the ship ids it keeps...) rolls back with the World through `save()` and
`load(saved)`, if given. Frames are confirmed once both inputs are known and stepped; every
`digest_every`-th confirmed frame's World.digest() goes to the peer, and a digest that
differs from the peer's is a desync, named by its frame (`desync`).
"""
import time

from .inputs import Inputs
from .link import Packet

MAX_INPUTS = 32                   # inputs one packet carries (the oldest the peer lacks)


class Session:
    """A rollback session of `world` for `player` (0 or 1) over `channel` (link.Channel).

    specs : the MissileSpecs launches may name (the same on both peers); frame : the game's
    frame function (see the module); steps : World steps a frame (default frame only);
    save, load : the game's state, saved with each frame's snapshot; window : most frames
    the session runs ahead of the other player's last input (beyond it, advance() waits,
    and says so: `waiting`); digest_every : frames between digests compared; session_id :
    both peers' (packets of another session are dropped); silence : seconds without a
    packet from the peer, once it has been heard, after which advance() and tick() raise
    ConnectionError (before that, the session waits for the other player to come)."""

    def __init__(self, world, player, channel, *, specs=(), frame=None, steps=2, save=None,
                 load=None, window=8, digest_every=10, session_id=0, silence=30.0):
        if player not in (0, 1):
            raise ValueError(f"player = {player!r}: must be 0 or 1")
        for name, value in (("window", window), ("digest_every", digest_every),
                            ("steps", steps)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} = {value!r}: must be a whole number >= 1")
        self.world, self.player, self.channel = world, player, channel
        self.specs = tuple(specs)
        self.frame_fn = frame or (lambda w, number, inputs: _default_frame(w, inputs, steps))
        self.save, self.load = save, load
        self.window, self.digest_every = window, digest_every
        self.session_id = int(session_id)
        self.frame = 0                    # the next frame to step
        self.inputs = ({}, {})            # player -> {frame: encoded input}, as known
        self.used = {}                    # frame -> the other player's input it was stepped with
        self.saved = {}                   # frame -> (World snapshot, game state) before it
        self.stepped = {}                 # checked frame -> our digest after it, as stepped
        self.digests = {}                 # confirmed frame -> our digest after it
        self.peer_digests = {}            # frame -> the peer's digest after it
        self.remote_next = 0              # the other player's first input not yet here
        self.peer_ack = 0                 # the first of our inputs the peer lacks
        self.desync = None                # the first frame whose digests differ
        self.waiting = False
        self.stats = {"rollbacks": 0, "frames_resimulated": 0, "waits": 0, "packets_in": 0,
                      "packets_out": 0, "ping_ms": None, "dropped": channel.dropped}
        self._echo = (0.0, 0.0)           # (peer's send time, our clock when it came)
        self.silence = float(silence)
        self._heard = None                # when the peer last sent a valid packet
        self._confirmed = 0               # frames [0, this) are confirmed

    @property
    def other(self):
        return 1 - self.player

    def input(self):
        """A new Inputs for this frame's calls (launches may name `specs`)."""
        return Inputs(self.specs)

    # ------------------------------------------------------------------ the frame
    def advance(self, local):
        """Take the local player's Inputs for the next frame and step it (after any
        rollback the peer's inputs ask for); False, nothing stepped, when the session is
        `waiting` (the other player is more than `window` frames behind): call again with
        the same input next tick."""
        self.poll()
        if self.frame - self.remote_next >= self.window:
            self.waiting = True
            self.stats["waits"] += 1
            self._send()
            return False
        self.waiting = False
        self.inputs[self.player][self.frame] = local.encode()
        self._step(self.frame)
        self.frame += 1
        self._confirm()
        self._send()
        return True

    def _guess(self, f):
        """The other player's input for frame f: theirs, or the last known held."""
        known = self.inputs[self.other]
        if f in known:
            return known[f]
        if self.remote_next == 0:
            return Inputs(self.specs).encode()
        return Inputs.decode(known[self.remote_next - 1], self.specs).held().encode()

    def _step(self, f):
        w = self.world
        self.saved[f] = (w.snapshot(), None if self.save is None else self.save())
        theirs = self._guess(f)
        self.used[f] = theirs
        pair = [None, None]
        pair[self.player] = Inputs.decode(self.inputs[self.player][f], self.specs)
        pair[self.other] = Inputs.decode(theirs, self.specs)
        self.frame_fn(w, f, pair)
        if (f + 1) % self.digest_every == 0:
            # the state after f, as stepped now: final once f is confirmed (a later input
            # that differs from the one used steps f again, and this is taken again)
            self.stepped[f] = w.digest()

    def _rollback(self, f):
        """Restore the World (and the game) to before frame f and step again to now."""
        snap, game = self.saved[f]
        self.world.restore(snap)
        if self.load is not None:
            self.load(game)
        self.stats["rollbacks"] += 1
        for g in range(f, self.frame):
            self._step(g)
            self.stats["frames_resimulated"] += 1

    def _confirm(self):
        """Frames both inputs of which are known and were stepped with: their digests (taken
        when they were last stepped) become final and go to the peer; old snapshots go."""
        top = min(self.frame, self.remote_next)
        while self._confirmed < top:
            f = self._confirmed
            if f in self.stepped:
                self.digests[f] = self.stepped.pop(f)
                self._compare(f)
            self._confirmed += 1
        for g in [g for g in self.saved if g < self._confirmed - 1]:
            del self.saved[g]
            self.used.pop(g, None)

    def _compare(self, f):
        theirs = self.peer_digests.get(f)
        ours = self.digests.get(f)
        if theirs is not None and ours is not None and theirs != ours and \
                (self.desync is None or f < self.desync):
            self.desync = f

    # ------------------------------------------------------------------ the network
    def poll(self):
        """Read what arrived: the other player's inputs (a rollback if one differs from the
        guess a frame was stepped with), their acks, digests and ping."""
        earliest = None
        for data, sender in self.channel.receive():
            if self.channel.peer is None:
                try:
                    Packet.decode(data, self.specs)
                except ValueError:
                    self.channel.drop("malformed")
                    continue
                self.channel.peer = sender          # the host takes its first caller
            if sender != self.channel.peer:
                self.channel.drop("from an unknown peer")
                continue
            try:
                p = Packet.decode(data, self.specs)
            except ValueError as e:
                self.channel.drop(str(e).split(":")[0])
                continue
            if p.session != self.session_id or p.player != self.other:
                self.channel.drop("another session or player")
                continue
            self.stats["packets_in"] += 1
            self._heard = time.perf_counter()
            self.peer_ack = max(self.peer_ack, p.ack)
            now = time.perf_counter()
            self._echo = (p.sent, now)
            if p.echo:
                self.stats["ping_ms"] = 1e3 * max(now - p.echo - p.held, 0.0)
            known = self.inputs[self.other]
            for k, data in enumerate(p.inputs):
                f = p.first + k
                if f in known:
                    continue
                known[f] = data
                if f < self.frame and data != self.used.get(f) and \
                        (earliest is None or f < earliest):
                    earliest = f
            while self.remote_next in known:
                self.remote_next += 1
            for f, d in p.digests:
                self.peer_digests[f] = d
                self._compare(f)
        if earliest is not None and earliest >= self._confirmed:
            self._rollback(earliest)
        self._confirm()
        quiet = 0.0 if self._heard is None else time.perf_counter() - self._heard
        if quiet > self.silence:
            raise ConnectionError(f"netplay: nothing heard from the other player for "
                                  f"{quiet:.1f} s (frame {self.frame}; they may have left)")

    def _send(self):
        mine = self.inputs[self.player]
        first = self.peer_ack
        inputs = [mine[f] for f in range(first, min(self.frame, first + MAX_INPUTS))]
        checked = sorted(self.digests)[-4:]
        sent, got = self._echo
        now = time.perf_counter()
        p = Packet(self.session_id, self.player, self.remote_next, first, inputs,
                   [(f, self.digests[f]) for f in checked], now, sent,
                   now - got if sent else 0.0)
        self.channel.send(p.encode())
        self.stats["packets_out"] += 1

    # ------------------------------------------------------------------ the end
    def done(self):
        """Whether every frame stepped is confirmed and the peer has all our inputs."""
        return self._confirmed == self.frame and self.peer_ack >= self.frame

    def tick(self):
        """Read and send without stepping: keeps the peer informed while this side does not
        advance (paused, or finished)."""
        self.poll()
        self._send()

    def finish(self, timeout=10.0, linger=0.3):
        """Keep talking until done() (or `timeout` [s]: TimeoutError), then `linger` [s]
        more so the peer hears that we are; returns the World's digest."""
        until = time.perf_counter() + timeout
        while not self.done():
            if time.perf_counter() > until:
                raise TimeoutError(f"netplay: frames confirmed {self._confirmed} of "
                                   f"{self.frame}, the peer has {self.peer_ack} of our "
                                   f"{self.frame} inputs after {timeout} s")
            self.tick()
            time.sleep(0.002)
        end = time.perf_counter() + linger
        while time.perf_counter() < end:
            self.tick()
            time.sleep(0.01)
        return self.world.digest()

    def history(self):
        """[(frame, player 0's input, player 1's input)] (encoded) of the confirmed frames
        still known: what a single process would replay."""
        return [(f, self.inputs[0][f], self.inputs[1][f]) for f in range(self._confirmed)]


def _default_frame(world, inputs, steps):
    for inp in inputs:
        inp.apply(world)
    world.step(steps)
