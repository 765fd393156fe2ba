"""The `spacephys` command: run a scene, benchmark and validate against REBOUND."""
import argparse
import dataclasses
import json
import sys
from pathlib import Path

from .integrators import INTEGRATORS
from .scenes import SCENES


def _problem_names():
    from .study.validate import PROBLEMS
    return list(PROBLEMS)


SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def _resolve(scene):
    """("scenario", path) for a scenario file or a name in scenarios/, ("scene", name) for a
    built-in scene; ValueError listing the known ones otherwise."""
    path = Path(scene)
    if not path.suffix and (SCENARIOS / (scene + ".toml")).exists():
        path = SCENARIOS / (scene + ".toml")          # scenarios/NAME.toml first
    if path.suffix != ".toml" and scene in SCENES:
        return "scene", scene
    if path.suffix != ".toml" or not path.exists():
        known = sorted(SCENES) + sorted(p.stem for p in SCENARIOS.glob("*.toml"))
        raise ValueError(f"{scene!r} is neither a scenario file (.toml) nor a known scene "
                         f"or scenario: {', '.join(known)}")
    return "scenario", path


def _run(args):
    from .runner import default_progress, run_scenario, run_scene
    kw = dict(integrator=args.integrator, dt=args.dt, duration=args.duration, out=args.out,
              progress=None if args.quiet else default_progress())
    kind, what = _resolve(args.scene)
    result = (run_scene if kind == "scene" else run_scenario)(what, **kw)
    print(result.summary())
    if args.out:
        print(f"log           {args.out}")
    return 0


def _recommend(args):
    from .study.recommend import recommend
    kind, what = _resolve(args.scene)
    duration = args.duration
    if kind == "scene":
        build, default_duration, integrator, dt = SCENES[what]
        what = build(integrator=integrator, dt=dt)
        duration = default_duration if duration is None else duration
    rec = recommend(what, args.error, budget=args.budget, duration=duration)
    print(rec)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dataclasses.asdict(rec), f, indent=1)
        print(f"wrote {args.json}")
    return 0 if rec.met else 1


def _plot(args):
    from .plot import animate_run, plot_run
    (plot_run if args.command == "plot" else animate_run)(args.run, args.output)
    print(f"wrote {args.output}")
    return 0


def _bench(args):
    from .study import bench
    if args.what == "peers":
        from .study import tradeoff
        results = tradeoff.peers(quick=args.quick, out_dir=args.out)
        print(tradeoff.peers_markdown(results))
        print(f"wrote {args.out}/peers.json")
        return 0
    if args.what == "tradeoff":
        from .study import tradeoff
        results = tradeoff.study(quick=args.quick, out_dir=args.out)
        print(tradeoff.markdown(results))
        print(f"wrote {args.out}/tradeoff.json, tradeoff.csv and a plot per scene")
        if args.json:
            with open(args.json, "w") as f:
                json.dump(results, f, indent=2)
        return 0
    results = bench.BENCHMARKS[args.what](quick=args.quick)
    print(bench.format_table(results))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
        print(f"wrote {args.json}")
    return 0


def _validate(args):
    from .study import validate
    results = validate.validate(args.problems, args.integrator)
    table = validate.format_markdown(results)
    print(table)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(validate.MARKDOWN_HEADER + table + "\n")
        print(f"wrote {args.markdown}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
        print(f"wrote {args.json}")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="spacephys", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene or a scenario file and print a summary")
    run.add_argument("scene", nargs="?", default="star_system",
                     help="a scenario file (.toml), a scenario of scenarios/ by name, or a "
                          "built-in scene: " + ", ".join(SCENES))
    run.add_argument("--out", metavar="RUN.h5", help="record the run into an HDF5 log")
    run.add_argument("--integrator", choices=list(INTEGRATORS))
    run.add_argument("--dt", type=float, help="step [time units]")
    run.add_argument("--duration", type=float, help="simulated time [time units]")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)

    rec = sub.add_parser("recommend", help="the cheapest integrator and step meeting an "
                                           "error target, measured on the scene")
    rec.add_argument("scene", help="a scenario file (.toml), a scenario of scenarios/ by name, "
                                   "or a built-in scene: " + ", ".join(SCENES))
    rec.add_argument("--error", type=float, default=1e-6,
                     help="the error target (relative; default 1e-6)")
    rec.add_argument("--budget", type=float,
                     help="the most wall seconds per unit of simulated time")
    rec.add_argument("--duration", type=float, help="simulated time the error must hold over")
    rec.add_argument("--json", metavar="PATH", help="also write the choice and every trial")
    rec.set_defaults(func=_recommend)

    for name, what, ext in (("plot", "trajectories and energy error", "png"),
                            ("animate", "an animation of the bodies", "gif")):
        p = sub.add_parser(name, help=f"draw a run log: {what}")
        p.add_argument("run", metavar="RUN.h5", help="a log from spacephys run --out")
        p.add_argument("-o", "--output", required=True, metavar=f"OUT.{ext}")
        p.set_defaults(func=_plot)

    bench = sub.add_parser("bench", help="benchmark side by side with REBOUND")
    bench.add_argument("what", choices=["gravity", "integrators", "collisions", "fleet", "log",
                                        "tradeoff", "peers", "memory", "models", "overhead",
                                        "predict", "tree", "queries"])
    bench.add_argument("--out", default="tradeoff", metavar="DIR",
                       help="tradeoff, peers: where the CSV, JSON and plots go (default ./tradeoff)")
    bench.add_argument("--quick", action="store_true", help="fewer repeats, smaller cases")
    bench.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    bench.set_defaults(func=_bench)

    val = sub.add_parser("validate", help="every integrator on the reference problems, "
                                          "against REBOUND IAS15")
    val.add_argument("problems", nargs="*", metavar="PROBLEM",
                     help="problems to run (default: all): " + ", ".join(_problem_names()))
    val.add_argument("--integrator", action="append", choices=list(INTEGRATORS),
                     help="only this integrator (repeatable)")
    val.add_argument("--markdown", metavar="PATH", help="also write the table (docs page)")
    val.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    val.set_defaults(func=_validate)

    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:     # bad input: a message, not a traceback
        print(f"spacephys {args.command}: error: {err}", file=sys.stderr)
        return 2
    except FloatingPointError as err:     # the integration broke down
        print(f"spacephys {args.command}: failed: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
