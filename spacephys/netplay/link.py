"""What travels between two peers, and how: the packet format, and a UDP channel (the
standard library's socket) with a test hook that delays, jitters and drops what it sends.

A packet: MAGIC, the session's id, the sender's player number, `ack` (the next frame of the
receiver's inputs the sender lacks), `first` (the frame of the first input carried), the
sender's inputs from `first` on, digests of frames the sender has confirmed, and three times
for the ping (the sender's clock when sent, the last such time it received, how long it held
it). Anything else — another magic or session, a player that is not the peer, a size that
does not add up, more than MAX_PACKET bytes — is dropped and counted, never an error.
"""
import heapq
import random
import socket
import struct
import time

from .inputs import Inputs

MAGIC = b"SPN1"
MAX_PACKET = 8192                  # bytes; a larger datagram is dropped
_HEAD = struct.Struct("<4sIBIIBB3d")   # magic, session, player, ack, first, inputs, digests, times
_LEN = struct.Struct("<H")
_DIGEST = struct.Struct("<IQ")


class Packet:
    """One packet's fields (see the module)."""

    __slots__ = ("session", "player", "ack", "first", "inputs", "digests", "sent", "echo",
                 "held")

    def __init__(self, session, player, ack, first, inputs, digests, sent, echo, held):
        self.session, self.player, self.ack, self.first = session, player, ack, first
        self.inputs, self.digests = inputs, digests          # [bytes], [(frame, digest)]
        self.sent, self.echo, self.held = sent, echo, held

    def encode(self):
        out = [_HEAD.pack(MAGIC, self.session, self.player, self.ack, self.first,
                          len(self.inputs), len(self.digests), self.sent, self.echo,
                          self.held)]
        for data in self.inputs:
            out += [_LEN.pack(len(data)), data]
        out += [_DIGEST.pack(f, d) for f, d in self.digests]
        data = b"".join(out)
        if len(data) > MAX_PACKET:
            raise ValueError(f"a packet of {len(data)} bytes: more than {MAX_PACKET} (too "
                             f"many inputs waiting, or inputs too long)")
        return data

    @classmethod
    def decode(cls, data, specs):
        """The packet in `data`; ValueError naming what is wrong with it."""
        if len(data) > MAX_PACKET:
            raise ValueError(f"oversized: {len(data)} bytes")
        if len(data) < _HEAD.size:
            raise ValueError(f"short: {len(data)} bytes")
        magic, session, player, ack, first, k, d, sent, echo, held = _HEAD.unpack_from(data)
        if magic != MAGIC:
            raise ValueError(f"not a spacephys packet (magic {magic!r})")
        at, inputs = _HEAD.size, []
        for _ in range(k):
            if at + 2 > len(data):
                raise ValueError("malformed: an input past the end")
            (size,) = _LEN.unpack_from(data, at)
            at += 2
            if at + size > len(data):
                raise ValueError("malformed: an input past the end")
            Inputs.decode(data[at:at + size], specs)          # checked now, kept as bytes
            inputs.append(bytes(data[at:at + size]))
            at += size
        if at + d * _DIGEST.size != len(data):
            raise ValueError("malformed: its length does not match its digests")
        digests = [_DIGEST.unpack_from(data, at + j * _DIGEST.size) for j in range(d)]
        return cls(session, player, ack, first, inputs, digests, sent, echo, held)


class Conditions:
    """The test hook: what the network does to every datagram sent through a Channel —
    `latency` [s] one way, `jitter` [s] (each datagram delayed by latency + uniform(-jitter,
    jitter), so they may arrive out of order), `loss` in [0, 1) (each dropped with that
    chance), drawn from an RNG seeded with `seed`."""

    def __init__(self, latency=0.0, jitter=0.0, loss=0.0, seed=0):
        for name, value, top in (("latency", latency, 60.0), ("jitter", jitter, 60.0),
                                 ("loss", loss, 1.0)):
            if not isinstance(value, (int, float)) or not 0.0 <= value < top:
                raise ValueError(f"{name} = {value!r}: must be in [0, {top:g})")
        if jitter > latency:
            raise ValueError(f"jitter = {jitter} exceeds latency = {latency}")
        self.latency, self.jitter, self.loss = float(latency), float(jitter), float(loss)
        self.rng = random.Random(seed)

    def delay(self):
        """Seconds until a datagram arrives, or None: lost."""
        if self.loss and self.rng.random() < self.loss:
            return None
        return self.latency + (self.rng.uniform(-self.jitter, self.jitter) if self.jitter
                               else 0.0)


class Channel:
    """A UDP socket bound to (host, port) that talks to one peer: `peer` (host, port), or
    None to take the first valid packet's sender as the peer (the host of a game). send()
    and receive() never block; `conditions` (a Conditions) delays what is sent."""

    def __init__(self, port, peer=None, host="127.0.0.1", conditions=None):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, int(port)))
        except OSError as e:
            self.sock.close()
            raise ValueError(f"port = {port!r}: cannot listen there ({e})") from None
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]
        try:
            self.peer = None if peer is None else (socket.gethostbyname(peer[0]),
                                                   int(peer[1]))
        except (OSError, ValueError, TypeError, IndexError) as e:
            self.sock.close()
            raise ValueError(f"peer = {peer!r}: not a reachable (host, port) ({e})") from None
        self.conditions = conditions
        self.waiting = []                    # (due, sequence, bytes): delayed by conditions
        self.sequence = 0
        self.dropped = {}                    # why -> count, for the session's statistics

    def send(self, data):
        if self.peer is None:
            return                           # no peer yet: nothing to send to
        if self.conditions is None:
            self._out(data)
            return
        delay = self.conditions.delay()
        if delay is None:
            self.drop("lost on the way (test conditions)")
            return
        heapq.heappush(self.waiting, (time.perf_counter() + delay, self.sequence, data))
        self.sequence += 1
        self.flush()

    def flush(self):
        """Send what the conditions held back and is now due."""
        now = time.perf_counter()
        while self.waiting and self.waiting[0][0] <= now:
            self._out(heapq.heappop(self.waiting)[2])

    def _out(self, data):
        try:
            self.sock.sendto(data, self.peer)
        except OSError:
            self.drop("could not be sent")

    def receive(self):
        """The datagrams waiting: [(bytes, sender)]."""
        self.flush()
        got = []
        while True:
            try:
                data, sender = self.sock.recvfrom(MAX_PACKET + 1)
            except (BlockingIOError, InterruptedError):
                return got
            except OSError:                  # e.g. the peer's port closed (ICMP)
                continue
            got.append((data, sender))

    def drop(self, why):
        self.dropped[why] = self.dropped.get(why, 0) + 1

    def close(self):
        self.sock.close()
