"""Monte Carlo: how likely a salvo of two guided missiles is to kill a passing ship, against
the spread of their launch headings. 7 spreads x 50 seeds = 350 runs on local Dask workers
(`--scheduler tcp://host:8786` for a cluster); the hit probability plotted with its
binomial standard error.

    python examples/salvo_sweep.py [--seeds 50] [--out salvo.png] [--scheduler ADDRESS]
"""
import argparse
import math
from pathlib import Path

import numpy as np

import spacephys as sp

SCENARIO = Path(__file__).with_name("salvo.toml")
SEEKER = sp.load_scenario(SCENARIO).data["missiles"]["seeker"]
SPREADS = [0.0, 15.0, 30.0, 45.0, 60.0, 90.0, 120.0]        # degrees, standard deviation


def launch_salvo(world, names, run):
    """Before the first step: two missiles at blue, headings drawn from this run's rng."""
    rng = run.rng()
    for _ in range(2):
        heading = math.radians(rng.normal(0.0, run.params["param.spread"]))
        world.launch(names["red"], SEEKER, target=names["blue"], heading=heading)


def killed(result, run):
    """The run's own figure: was blue destroyed?"""
    return {"hit": result.names["blue"] not in set(result.world.ids.tolist())}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--out", default="salvo.png")
    parser.add_argument("--scheduler", help="a Dask scheduler's address (default: local)")
    args = parser.parse_args()
    table = sp.sweep(SCENARIO, vary={"param.spread": SPREADS}, seeds=range(args.seeds),
                     setup=launch_salvo, measure=killed, client=args.scheduler)
    assert table.ok.all(), table["error"][~table.ok]
    spread, hit = table["param.spread"], table["hit"].astype(float)
    p = np.array([hit[spread == s].mean() for s in SPREADS])
    err = np.sqrt(p * (1 - p) / args.seeds)
    for s, pk, e in zip(SPREADS, p, err):
        print(f"spread {s:5.1f} deg: hit probability {pk:.2f} +- {e:.2f}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.errorbar(SPREADS, p, yerr=err, marker="o", capsize=3)
    ax.set(xlabel="launch heading spread (standard deviation) [deg]",
           ylabel="P(target destroyed)", ylim=(0, 1.05),
           title=f"Two PN missiles at a crossing target, {args.seeds} seeds per spread")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
