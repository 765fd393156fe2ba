"""The `spacephys` command: run a scene, benchmark and validate against REBOUND."""
import argparse
import dataclasses
import json
import sys

from .extras import MissingExtra, require
from .integrators import INTEGRATORS
from .runner import resolve
from .scenes import SCENES
from .study.benchmarks import BENCHMARKS


def _problem_names():
    from .study.validate import PROBLEMS
    return list(PROBLEMS)


def _scenarios(args):
    from .scenario import shipped, summary_line
    known = shipped()
    width = max(map(len, known))
    for name, path in known.items():
        print(f"{name:{width}s}  {summary_line(path)}")
    return 0


def _run(args):
    from .runner import default_progress, run_scenario, run_scene
    kw = dict(integrator=args.integrator, dt=args.dt, duration=args.duration, out=args.out,
              progress=None if args.quiet else default_progress())
    kind, what = resolve(args.scene)
    result = (run_scene if kind == "scene" else run_scenario)(what, **kw)
    print(result.summary())
    if args.out:
        print(f"log           {args.out}")
    return 0


def _compile(args):
    from .precompile import compile
    done = compile(scene=args.scene, scenario=args.scenario, every=args.all, jobs=args.jobs,
                   progress=sys.stdout)
    from . import cache
    print(f"{len(done)} compiled ({sum(c.seconds for c in done):.1f} s); machine code cache: "
          f"{cache.place()}")
    return 0


def _cache(args):
    from . import cache
    if args.action == "clear":
        files, size = cache.clear()
        print(f"deleted {files} files, {size / 1e6:.1f} MB ({cache.place()})")
    else:
        print(cache.describe())
    return 0


def _recommend(args):
    from .study.recommend import recommend
    kind, what = resolve(args.scene)
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
    require(f"spacephys {args.command}", "matplotlib")
    from .plot import animate_run, plot_run
    (plot_run if args.command == "plot" else animate_run)(args.run, args.output)
    print(f"wrote {args.output}")
    return 0


def _play(args):
    require("spacephys play", "pygame")
    from .game import loop, make_mode
    if args.replay is not None:
        result, frames = loop.replay(args.replay, headless=args.headless,
                                     screenshot=args.screenshot, frames=args.frames)
        if result is None:
            print(f"replay of {args.replay} stopped after {frames} frames")
            return 0
        print(f"replay of {args.replay}: {frames} frames drawn; {result.message}")
        return 0 if result.ok else 1
    session = None
    if args.host is not None or args.join is not None:
        mode, session = _net_game(args)
    else:
        mode = make_mode(args.mode, players=args.players, seed=args.seed)
    try:
        done = loop.play(mode, frames=args.frames, headless=args.headless,
                         record=args.record, screenshot=args.screenshot, session=session)
    finally:
        if session is not None:
            session.channel.close()
    print("\n".join(line for line in mode.hud() if line))
    if done.digest is not None:
        print(f"final digest {done.digest:016x} after {done.frames} frames "
              f"({session.stats['rollbacks']} rollbacks)")
    import numpy as np
    physics, frame = (float(np.median(ms)) if ms.size else 0.0
                      for ms in (done.physics_ms, done.frame_ms))
    print(f"{done.frames} frames; physics and pilots {physics:.2f} ms, "
          f"the whole frame {frame:.2f} ms a frame (median)"
          + (f"; recorded in {args.record}" if args.record else ""))
    return 0


def _net_game(args):
    """(the duel, its netplay Session) for --host PORT or --join HOST:PORT: this side flies
    ship 0 (host) or 1, with the keys (--players 1) or the computer (--players 0)."""
    from .game import make_mode
    from .netplay import Channel, Session
    if args.host is not None and args.join is not None:
        raise SystemExit("spacephys play: --host and --join: give one")
    if args.mode != "duel":
        raise SystemExit(f"spacephys play: {args.mode} over the network: only the duel is "
                         f"played over the network")
    if args.record is not None or args.players not in (0, 1):
        raise SystemExit("spacephys play: over the network one player sits at each machine "
                         "(--players 1, or 0 for the computer), and the match is not "
                         "recorded (--record)")
    if args.host is not None:
        player, channel = 0, Channel(args.host, host="0.0.0.0")
    else:
        where, _, port = args.join.rpartition(":")
        if not where or not port.isdigit():
            raise SystemExit(f"spacephys play: --join {args.join!r}: give HOST:PORT")
        player, channel = 1, Channel(0, (where, int(port)), host="0.0.0.0")
    # a peer compiling is silent to the other: compile (or load) what a duel runs first, by
    # playing one here with the computer on both sides (a fraction of a second once cached)
    from .game.modes import autoplay
    autoplay("duel", 600, seed=args.seed)
    mode = make_mode("duel", players=2, seed=args.seed)
    if args.players == 0:
        mode.pilots[player] = mode.make_pilot(player)
    session = Session(mode.world, player, channel, specs=mode.specs, frame=mode.net_frame,
                      save=mode.save, load=mode.load, session_id=args.seed)
    mode.net = session
    return mode, session


def _bench(args):
    bench = BENCHMARKS[args.what]
    require(f"spacephys bench {bench.name}", *bench.needs)
    run, report = bench.load()
    results = run(quick=args.quick, **({"out_dir": args.out} if bench.writes else {}))
    print(report(results))
    if bench.writes:
        print(f"wrote {args.out}/{bench.writes}")
    if args.json and bench.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
        if not bench.writes:          # one that writes into --out has said what it wrote
            print(f"wrote {args.json}")
    return 0


def _sweep(args):
    import time
    require("spacephys sweep", "distributed")
    from .runner import default_progress
    from .sweeps import parse_vary, summary, sweep
    kind, what = resolve(args.scenario)
    if kind != "scenario":
        raise ValueError(f"{args.scenario!r} is a built-in scene: a sweep varies a scenario "
                         f"file's keys (spacephys scenarios lists the shipped ones)")
    vary = {}
    for text in args.vary or []:
        key, values = parse_vary(text)
        if key in vary:
            raise ValueError(f"--vary {key}: given twice")
        vary[key] = values
    if args.seeds < 1:
        raise ValueError(f"--seeds {args.seeds}: expected at least 1")
    start = time.perf_counter()
    table = sweep(what, vary, seeds=range(args.seeds), client=args.scheduler,
                  workers=args.workers, out=args.out, logs=args.logs,
                  progress=None if args.quiet else default_progress())
    print(summary(table, time.perf_counter() - start,
                  None if args.scheduler else args.workers))
    if args.out:
        print(f"table         {args.out}")
    return 0 if table.ok.all() else 1


def _validate(args):
    if args.real_sky:
        return _real_sky(args)
    require("spacephys validate", "rebound")
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


def _real_sky(args):
    """spacephys validate --real-sky: the Sun, the planets and the Moon against DE421."""
    require("spacephys validate --real-sky", "jplephem", "skyfield_data")
    from .study.realsky import HEADER, format_realsky, realsky
    (newton, lag_newton), (einstein, lag_gr) = realsky(relativity=False), realsky()
    table = format_realsky(newton, einstein) + (
        f"\n\nMercury's perihelion after 10 years, ahead of DE421's: {lag_newton:+.3f}\" "
        f"(Newton), {lag_gr:+.4f}\" (with the correction)")
    print(table)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(HEADER + table + "\n")
        print(f"wrote {args.markdown}")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="spacephys", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene or a scenario file and print a summary")
    run.add_argument("scene", nargs="?", default="star_system",
                     help="a scenario file (.toml), a shipped scenario by name "
                          "(spacephys scenarios), or a built-in scene: " + ", ".join(SCENES))
    run.add_argument("--out", metavar="RUN.h5", help="record the run into an HDF5 log")
    run.add_argument("--integrator", choices=list(INTEGRATORS))
    run.add_argument("--dt", type=float, help="step [time units]")
    run.add_argument("--duration", type=float, help="simulated time [time units]")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)

    sc = sub.add_parser("scenarios", help="list the shipped scenarios, one line each "
                                          "(spacephys run NAME runs one)")
    sc.set_defaults(func=_scenarios)

    co = sub.add_parser("compile", help="compile ahead of time (a game's installer or loading "
                                         "screen): later first steps load from the cache")
    which = co.add_mutually_exclusive_group(required=True)
    which.add_argument("--scene", metavar="NAME",
                       help="a shipped scenario or built-in scene by name")
    which.add_argument("--scenario", metavar="FILE", help="a scenario file (.toml)")
    which.add_argument("--all", action="store_true",
                       help="every shipped scenario and built-in scene")
    co.add_argument("--jobs", type=int, default=1, metavar="N",
                    help="processes compiling side by side (default 1)")
    co.set_defaults(func=_compile)

    ca = sub.add_parser("cache", help="where the compiled machine code is kept and how big "
                                      "it is (info), or delete it (clear)")
    ca.add_argument("action", choices=["info", "clear"])
    ca.set_defaults(func=_cache)

    rec = sub.add_parser("recommend", help="the cheapest integrator and step meeting an "
                                           "error target, measured on the scene")
    rec.add_argument("scene", help="a scenario file (.toml), a shipped scenario by name, "
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

    width = max(map(len, BENCHMARKS))
    bench = sub.add_parser("bench", help="benchmark side by side with REBOUND",
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog="benchmarks:\n" + "\n".join(
                               f"  {b.name:{width}s}  {b.about}" for b in BENCHMARKS.values()))
    bench.add_argument("what", metavar="NAME", choices=list(BENCHMARKS),
                       help="the benchmark to run (below)")
    bench.add_argument("--out", default="tradeoff", metavar="DIR",
                       help=", ".join(b.name for b in BENCHMARKS.values() if b.writes) +
                            ": where the CSV, JSON and plots go (default ./tradeoff)")
    bench.add_argument("--quick", action="store_true", help="fewer repeats, smaller cases")
    bench.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    bench.set_defaults(func=_bench)

    sw = sub.add_parser("sweep", help="run a scenario over values and seeds on Dask "
                                      "(local worker processes, or a cluster)")
    sw.add_argument("scenario", help="a scenario file (.toml) or a shipped scenario by name")
    sw.add_argument("--vary", action="append", metavar="KEY=V1,V2",
                    help="a key path of the scenario and its values (repeatable; every "
                         "combination runs): world.dt=0.01,0.02  ships.red.vel=[1,0],[2,0]")
    sw.add_argument("--seeds", type=int, default=1, metavar="N",
                    help="seeds 0..N-1 for every combination (default 1)")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="a Dask scheduler (tcp://host:8786); default: local worker processes")
    sw.add_argument("--workers", type=int, metavar="N",
                    help="local worker processes (default: one per core)")
    sw.add_argument("--out", metavar="SWEEP.h5",
                    help="the table (HDF5); an interrupted sweep given the same path resumes")
    sw.add_argument("--logs", metavar="DIR", help="a run log per run, in DIR")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.set_defaults(func=_sweep)

    pl = sub.add_parser("play", help="play: Spacewar! (duel), orbit (predicted paths, time "
                                     "warp) or arena (ten ships); needs pygame-ce")
    pl.add_argument("mode", nargs="?", default="duel", choices=["duel", "orbit", "arena"])
    pl.add_argument("--players", type=int, default=1,
                    help="players at the keyboard; the computer flies the other ships "
                         "(duel: 0-2, orbit and arena: 0-1; default 1)")
    pl.add_argument("--seed", type=int, default=0)
    pl.add_argument("--record", metavar="MATCH.h5", help="record the match (a run log)")
    pl.add_argument("--replay", metavar="MATCH.h5",
                    help="replay a recorded match, bit for bit, and say so")
    pl.add_argument("--frames", type=int, help="stop after this many frames")
    pl.add_argument("--headless", action="store_true",
                    help="no window (SDL's dummy video driver), fixed frame time, no waiting")
    pl.add_argument("--screenshot", metavar="PNG", help="save the last frame")
    pl.add_argument("--host", type=int, metavar="PORT",
                    help="a duel over the network: wait for the other player on PORT "
                         "(UDP); this side flies the needle")
    pl.add_argument("--join", metavar="HOST:PORT",
                    help="a duel over the network: join the game hosted at HOST:PORT; this "
                         "side flies the wedge (both sides give the same --seed)")
    pl.set_defaults(func=_play)

    val = sub.add_parser("validate", help="every integrator on the reference problems, "
                                          "against REBOUND IAS15")
    val.add_argument("problems", nargs="*", metavar="PROBLEM",
                     help="problems to run (default: all): " + ", ".join(_problem_names()))
    val.add_argument("--integrator", action="append", choices=list(INTEGRATORS),
                     help="only this integrator (repeatable)")
    val.add_argument("--markdown", metavar="PATH", help="also write the table (docs page)")
    val.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    val.add_argument("--real-sky", action="store_true",
                     help="instead: the Sun, the planets and the Moon integrated for 10 years "
                          "from JPL's DE421, against DE421 (with and without general "
                          "relativity's correction)")
    val.set_defaults(func=_validate)

    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:     # bad input: a message, not a traceback
        print(f"spacephys {args.command}: error: {err}", file=sys.stderr)
        return 2
    except MissingExtra as err:   # an optional dependency: which extra to install
        print(f"spacephys {args.command}: error: {err}", file=sys.stderr)
        return 2
    except FloatingPointError as err:     # the integration broke down
        print(f"spacephys {args.command}: failed: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
