"""`spacephys bench play`: the game's frame budget, headless (SDL's dummy video driver), the
computer flying every ship: per frame, the physics and the pilots (controls, launches,
w.advance, events, predictions started) and the whole frame with the drawing, against the
budgets of a 60 Hz game: physics + pilots <= 2 ms (duel, orbit) and <= 6 ms (arena), the
whole frame <= 16 ms. No peer plays these games; the figures are ours alone.
"""
import numpy as np

from . import header

BUDGETS = {"duel": 2.0, "orbit": 2.0, "arena": 6.0}     # [ms] physics + pilots a frame
FRAME = 16.0                                            # [ms] the whole frame


def _stats(ms):
    return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95)),
            "worst_ms": float(ms.max())}


def play_bench(quick=False):
    frames = 600 if quick else 1800
    out = {**header("play", quick), "frames": frames, "modes": {}}
    for name in BUDGETS:
        # the same game played once untimed first (seeded: the same frames): every kernel the
        # timed one runs is compiled or loaded by then, explosions' and late events' too
        _played(name, frames)
        mode, done = _played(name, frames)
        w = mode.world
        out["modes"][name] = {"physics": _stats(done.physics_ms), "draw": _stats(done.draw_ms),
                              "frame": _stats(done.frame_ms), "bodies_at_end": w.n,
                              "budget_ms": BUDGETS[name], "hud": [h for h in mode.hud() if h]}
    return out


def _played(name, frames):
    """(mode, play's result) of `frames` frames of a new game of mode `name`, headless."""
    from ..game import make_mode
    from ..game.loop import play
    mode = make_mode(name, players=0, seed=0)
    if name == "orbit":                            # sp.recommend's choice for x1, the
        mode.wait_for_choice(1)                    # warp the computer flies at
    done = play(mode, frames=frames, headless=True)
    if name == "orbit":
        mode.close()
    return mode, done


def format_play(results):
    lines = [f"play benchmark on {results['machine']} ({results['versions']}), headless, "
             f"{results['frames']} frames a mode, the computer flying every ship",
             f"{'mode':7s} {'physics + pilots: median':>25s} {'p95':>7s} {'worst':>7s} "
             f"{'budget':>7s}   {'whole frame: median':>20s} {'p95':>7s} {'worst':>7s} "
             f"(budget {FRAME:.0f} ms)   bodies"]
    for name, m in results["modes"].items():
        p, f = m["physics"], m["frame"]
        lines.append(f"{name:7s} {p['median_ms']:22.2f} ms {p['p95_ms']:7.2f} "
                     f"{p['worst_ms']:7.2f} {m['budget_ms']:7.1f}   {f['median_ms']:17.2f} ms "
                     f"{f['p95_ms']:7.2f} {f['worst_ms']:7.2f}   {m['bodies_at_end']:10d}")
    for name, m in results["modes"].items():
        lines.append(f"{name}: " + " | ".join(m["hud"]))
    return "\n".join(lines)
