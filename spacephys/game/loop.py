"""The frame loop: inputs, the mode's controls and the computer's pilots, fixed physics steps
through World.advance(frame time), drawing at the interpolated positions; a recording of the
match (a run log) and its replay, bit for bit. Headless (SDL's dummy video driver) for tests
and benchmarks, with key presses scripted frame by frame."""
import dataclasses
import os
import time

import numpy as np

from .modes import KEYS, Watch, make_mode, mode_of

RECORD_EVERY = 1.0                 # [time] between the frames of a recording


def _pygame(headless):
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")    # (its banner on stdout)
    if headless:
        os.environ["SDL_VIDEODRIVER"] = "dummy"      # no window: frames drawn off screen
    from ..extras import require
    require("spacephys play", "pygame")
    import pygame
    pygame.display.init()
    pygame.font.init()
    return pygame


def _window(headless, size, caption):
    """(pygame, the window's surface, a View of it, a Clock)."""
    pygame = _pygame(headless)
    from .view import View
    screen = pygame.display.set_mode(size)
    pygame.display.set_caption(caption)
    return pygame, screen, View(screen), pygame.time.Clock()


@dataclasses.dataclass
class Played:
    """What a run of the loop did: frames drawn, and per frame the milliseconds of physics
    and the computer's pilots (controls + advance + events), of drawing, and of the whole
    frame (without the wait for the display's rate)."""
    frames: int
    physics_ms: np.ndarray
    draw_ms: np.ndarray
    frame_ms: np.ndarray
    quit: bool = False
    alpha: float = 0.0            # the last frame's (World.advance's), as it was drawn
    digest: int = None            # a network game's final World.digest()


def _watched(mode):
    """The key names a mode reads (the players' and its own)."""
    names = {n for keys in KEYS for n in keys.values()}
    for k, _ in mode.keys:
        names.update(part.strip().lower() for part in k.replace("/", " ").split())
    return names


def play(mode, *, frames=None, script=None, headless=False, record=None, record_every=None,
         screenshot=None, size=(960, 720), realtime=None, session=None):
    """Run `mode` (a game Mode) for `frames` frames (None: until the window closes or escape).

    script : {frame: key names held from that frame on} in place of the keyboard (a name
    counts as pressed on the frame it first appears). realtime (default: not headless): each
    frame advances the World by the time the last one took and waits for 60 frames a second;
    otherwise by the mode's frame_time. record : a run log path (World.record) of the whole
    match, a frame of positions every `record_every` steps (default: about 10 a second).
    screenshot : a PNG of the last frame. session : a netplay.Session of mode.world, whose
    frame is mode.net_frame: a game over the network, this side flying session.player's ship
    with the first player's keys (or its pilot), each frame one frame of the session (frames
    counts those stepped), the session finished at the end (Played.digest). Returns
    Played."""
    pygame, screen, view, clock = _window(headless, size, f"spacephys play {mode.name}")
    realtime = (not headless) if realtime is None else realtime
    w = mode.world
    log = None
    if record is not None:
        # the replay re-runs the recorded calls: frames only check it, one a second is
        # plenty; and a match's many short-lived debris make layouts that compress well
        every = record_every or max(1, round(RECORD_EVERY / w.dt))
        log = w.record(record, every=every, compression="lzf", scenario=mode.command)
    watched = _watched(mode)
    codes = {}
    for name in watched:
        try:
            codes[name] = pygame.key.key_code(name)
        except ValueError:
            pass
    held, times, frame, quit, alpha = set(), [], 0, False, 0.0
    try:
        while frames is None or frame < frames:
            start = time.perf_counter()
            pressed = set()
            for event in pygame.event.get():
                if event.type == pygame.QUIT:
                    quit = True
                elif event.type == pygame.KEYDOWN:
                    name = pygame.key.name(event.key)
                    quit |= name == "escape"
                    pressed.add(name)
            if quit:
                break
            if script is not None:
                if frame in script:
                    now = set(script[frame])
                    pressed |= now - held
                    held = now
            else:
                state = pygame.key.get_pressed()
                held = {name for name, code in codes.items() if state[code]}
            if session is not None:
                alpha = 1.0
                if not _net_frame(mode, session, held):     # waiting for the other player
                    view.draw(mode, alpha)
                    pygame.display.flip()
                    clock.tick(60) if realtime else time.sleep(0.001)
                    continue
            else:
                step = min(clock.get_time() / 1000.0, 0.1) if realtime and frame else 0.0
                mode.controls(held, pressed)
                frame_time = float(step or mode.frame_time)
                alpha = w.advance(frame_time) if mode.warp == 1 else \
                    w.advance(frame_time, warp=float(mode.warp))
                mode.after(w.events)
            mode.frame += 1
            mid = time.perf_counter()
            view.draw(mode, alpha)
            pygame.display.flip()
            end = time.perf_counter()
            times.append((mid - start, end - mid, end - start))
            frame += 1
            if realtime:
                clock.tick(60)
        digest = session.finish(timeout=30.0) if session is not None and not quit else None
    finally:
        if log is not None:
            log.close()
        if screenshot is not None:
            pygame.image.save(screen, str(screenshot))
        pygame.display.quit()
    t = 1e3 * np.array(times).reshape(-1, 3)
    return Played(frame, t[:, 0], t[:, 1], t[:, 2], quit, alpha, digest)


def _net_frame(mode, session, held):
    """One frame over the network: this side's input (its pilot's calls, or the keys held),
    given to the session; False when the session waits for the other player."""
    k = session.player
    mode.outbox = session.input()
    try:
        if mode.ships[k] in mode.world:
            mode.fly(k, held, keys=KEYS[0])
        return session.advance(mode.outbox)
    finally:
        mode.outbox = None


class _Stop(Exception):
    pass


def replay(path, *, headless=False, size=(960, 720), realtime=None, screenshot=None,
           frames=None):
    """Re-run a recorded match (sp.replay: its calls from its first checkpoint, compared bit
    for bit with what was recorded) and draw each frame (each advance() or step()) as the
    mode that recorded it draws it (its HUD, flames, overlay; Watch for a World recorded by
    anything else). frames : stop after drawing this many (None: the whole match). Returns
    (sp.ReplayResult, frames drawn); closing the window or `frames` stops it (result None)."""
    import spacephys as sp
    pygame, screen, view, clock = _window(headless, size, f"spacephys play --replay {path}")
    realtime = (not headless) if realtime is None else realtime
    with sp.open_run(path) as run:
        made_by = mode_of(str(run.meta.get("scenario", "")))
    seen = {"frames": 0, "mode": None}

    def each(world, call, result):
        mode = seen["mode"]
        if mode is None:
            if made_by:
                mode = seen["mode"] = make_mode(*made_by, watching=True)
            else:
                mode = seen["mode"] = Watch(world)
                mode.message = f"replay of {os.path.basename(str(path))}"
        if call == "add_ship":
            mode.adopt(result)
        if call not in ("advance", "step"):
            return
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN and
                                             pygame.key.name(event.key) == "escape"):
                raise _Stop
        mode.watch(world, world.events)
        view.draw(mode, result if call == "advance" else 1.0)
        pygame.display.flip()
        seen["frames"] += 1
        if realtime:
            clock.tick(60)
        if frames is not None and seen["frames"] >= frames:
            raise _Stop

    try:
        result = sp.replay(path, each=each)
    except _Stop:
        result = None
    finally:
        if screenshot is not None:
            pygame.image.save(screen, str(screenshot))
        pygame.display.quit()
    return result, seen["frames"]
