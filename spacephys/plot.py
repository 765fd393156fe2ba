"""Pictures of a run log: trajectories and the energy error (plot), a quick animation
(animate). matplotlib with its Agg backend: no display needed."""
import math

import numpy as np

from .runs import Run
from .forces import MUTUAL

_TRACKED = 60            # bodies drawn as trajectories; the rest appear as dots


def _matplotlib():
    from .extras import require
    require("drawing a run", "matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _sample(run, most):
    """Indices of at most `most` frames, evenly spread, first and last included."""
    n = len(run)
    return np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int))


def _energy(run, fr):
    """Energy of the bodies with mass in a frame [mass length^2/time^2], under the log's
    gravity model (NaN when there are too many bodies to sum pairs quickly)."""
    m = run.meta
    keep = fr.mass > 0
    x, v, mass = fr.pos[keep], fr.vel[keep], fr.mass[keep]
    kinetic = 0.5 * np.sum(mass * np.sum(v * v, axis=1))
    G, eps2 = float(m["G"]), float(m["softening"]) ** 2
    if m["gravity"] in MUTUAL:
        if mass.size > 3000:
            return math.nan
        d = x[:, None, :] - x[None, :, :]
        r = np.sqrt(np.sum(d * d, axis=2) + eps2)
        iu = np.triu_indices(mass.size, 1)
        return kinetic - G * np.sum(mass[iu[0]] * mass[iu[1]] / r[iu])
    return kinetic          # other models: their fields are not in the log's attributes


def _tracks(data):
    """id -> (times, positions) over the frames `data` for up to _TRACKED bodies (those
    that move before those that do not, then the heaviest, then the longest-lived: ships
    and missiles before debris), and the last frame."""
    heaviest, seen, start, moved = {}, {}, {}, set()
    for fr in data:
        for i, m, p in zip(fr.ids.tolist(), fr.mass.tolist(), fr.pos):
            heaviest[i] = max(heaviest.get(i, 0.0), m)
            seen[i] = seen.get(i, 0) + 1
            if i not in start:
                start[i] = p
            elif i not in moved and np.any(p != start[i]):
                moved.add(i)
    chosen = sorted(heaviest, key=lambda i: (i not in moved, -(heaviest[i] > 0), -seen[i],
                                             -heaviest[i], i))
    chosen = chosen[:_TRACKED]
    tracks = {i: ([], []) for i in chosen}
    last = data[-1]
    for fr in data:
        where = {int(b): k for k, b in enumerate(fr.ids)}
        for i in chosen:
            if i in where:
                tracks[i][0].append(fr.t)
                tracks[i][1].append(fr.pos[where[i]])
    return {i: (np.array(t), np.array(p)) for i, (t, p) in tracks.items() if t}, last


def _title(run, path):
    """The scenario's title and description, or the file name."""
    import tomllib
    try:
        text = tomllib.loads(run.meta.get("scenario", "") or "")
    except tomllib.TOMLDecodeError:
        text = {}
    return text.get("title") or str(path), text.get("description", "")


def predicted_paths(run, most_points=2000):
    """[(ship id, t_planned, positions (P, dim))]: for each plan set in the run (a "plan"
    input; the run log checkpoints the World as it is set), the ship's path predicted then
    to the end of the run, made again from that checkpoint."""
    out = []
    checkpoints = run.checkpoints
    end = float(run.times[-1])
    for entry in run.inputs():
        if entry["call"] != "plan" or "raised" in entry:
            continue
        at = [k for k, (step, _) in enumerate(checkpoints) if step == entry["step"]]
        ship = int(entry["args"][0] if entry["args"] else entry["kwargs"]["ship"])
        if not at:
            continue                  # a log written before plans were checkpointed
        w = run.world(at[-1])
        if ship not in w or end <= w.t:
            continue
        steps = (end - w.t) / w.dt
        pred = w.predict(ship, end - w.t, points=int(min(most_points, steps + 1)))
        out.append((ship, w.t, pred.pos[0]))
    return out


def plot_run(path, out, *, most_frames=1500):
    """Write a PNG: the trajectories (2D; x-y and x-z projections in 3D) of up to 60 of the
    heaviest bodies, the others' last positions as dots, a ship's path predicted when its
    plan was set (dashed) beside the path it flew, and the relative energy error of the
    bodies with mass over time."""
    plt = _matplotlib()
    with Run(path) as run:
        dim = int(run.meta["dim"])
        frames = _sample(run, most_frames)
        data = [run.frame(int(f)) for f in frames]        # read once, used twice
        tracks, last = _tracks(data)
        times = run.times[frames]
        energies = np.array([_energy(run, fr) for fr in data])
        predicted = predicted_paths(run)
        views = [(0, 1)] if dim == 2 else [(0, 1), (0, 2)]
        fig, axes = plt.subplots(1, len(views) + 1, figsize=(6 * (len(views) + 1), 5.5))
        names = "xyz"
        title, about = _title(run, path)
        for ax, (a, b) in zip(axes, views):
            for i, (t, p) in tracks.items():
                ax.plot(p[:, a], p[:, b], lw=0.8)
                ax.plot(p[-1, a], p[-1, b], "o", ms=3, color=ax.lines[-1].get_color())
            for ship, t_plan, p in predicted:
                ax.plot(p[:, a], p[:, b], "--", lw=1.2, color="k", alpha=0.6,
                        label=f"body {ship}: predicted at t = {t_plan:g} (plan)")
            others = ~np.isin(last.ids, list(tracks))
            # the view: the tracked paths and most of the others (a few bodies flung far
            # away would shrink everything else to a dot)
            seen = [p[:, [a, b]] for _, p in tracks.values()]
            if others.any():
                pts = last.pos[others][:, [a, b]]
                seen.append(np.percentile(pts, [1, 99], axis=0))
            box = np.concatenate(seen)
            lo, hi = box.min(axis=0), box.max(axis=0)
            pad = 0.05 * max(hi - lo) + 1e-12
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(lo[1] - pad, hi[1] + pad)
            if others.any():
                ax.plot(last.pos[others, a], last.pos[others, b], ".", ms=1.5, color="0.5",
                        label=f"{int(others.sum())} more bodies (last frame)")
            if others.any() or predicted:
                ax.legend(loc="upper right", fontsize=8)
            ax.set_xlabel(names[a])
            ax.set_ylabel(names[b])
            ax.set_aspect("equal", adjustable="box")
            ax.set_title(f"trajectories ({names[a]}-{names[b]}), t = {times[0]:g} to "
                         f"{times[-1]:g}")
        ax = axes[-1]
        E0 = energies[0]
        if np.isfinite(energies).all() and E0 != 0:
            err = np.abs(energies - E0) / abs(E0)
            ax.semilogy(times[1:], np.maximum(err[1:], 1e-17))
            ax.set_ylabel("|E - E0| / |E0|")
            ax.set_title(f"energy change of the bodies with mass ({run.meta['integrator']}, "
                         f"dt = {run.meta['dt']:g})\nthe integration error, unless thrust, "
                         f"collisions or removals change it", fontsize=10)
        else:
            ax.text(0.5, 0.5, "no energy to show\n(no massive bodies, too many of them,\n"
                    "or a field not kept in the log)", ha="center", va="center")
        ax.set_xlabel("t")
        import textwrap
        fig.suptitle(textwrap.fill(f"{title}: {about}" if about else title, 160), fontsize=10)
        fig.tight_layout()
        fig.savefig(out, dpi=110)
        plt.close(fig)


def animate_run(path, out, *, most_frames=150, fps=20):
    """Write a GIF of the run: every body as a dot (x-y), frame by frame."""
    plt = _matplotlib()
    from matplotlib.animation import FuncAnimation, PillowWriter
    with Run(path) as run:
        frames = _sample(run, most_frames)
        data = [run.frame(int(f)) for f in frames]
        kinds = run.kinds
        allpos = np.concatenate([fr.pos[:, :2] for fr in data if fr.ids.size])
        lo, hi = np.percentile(allpos, 0.5, axis=0), np.percentile(allpos, 99.5, axis=0)
        pad = 0.05 * max(hi - lo) + 1e-12
        fig, ax = plt.subplots(figsize=(6, 6))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        dots = ax.scatter([], [], s=6)
        label = ax.set_title("")
        cmap = plt.get_cmap("tab10")

        def draw(k):
            fr = data[k]
            dots.set_offsets(fr.pos[:, :2] if fr.ids.size else np.zeros((0, 2)))
            dots.set_color([cmap(int(c) % 10) for c in fr.kind])
            # a dot of 6 points, smaller for thousands of bodies (a galaxy is a cloud of
            # its stars, not one blot), larger for the bodies with the larger radii
            dot = 6 * min(1.0, 1000 / max(fr.ids.size, 1)) ** 0.75
            sizes = dot + 60 * fr.radius / (fr.radius.max() or 1.0)
            dots.set_sizes(sizes)
            label.set_text(f"t = {fr.t:.4g}, {fr.ids.size} bodies "
                           f"({', '.join(sorted({kinds[int(c)] for c in fr.kind}))})")
            return dots, label

        anim = FuncAnimation(fig, draw, frames=len(data), blit=False)
        anim.save(out, writer=PillowWriter(fps=fps))
        plt.close(fig)
