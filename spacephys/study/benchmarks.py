"""The benchmarks of `spacephys bench NAME`, one entry each: what it measures in a line, and
the module of spacephys.study that runs and formats it.

Only names are kept here: a benchmark's module (and what it imports: REBOUND, Dask, pygame)
is imported when that benchmark runs, so the CLI's help stays fast.
"""
import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Benchmark:
    """`spacephys bench NAME`: MODULE.RUN(quick=) returns the results (a dict that JSON
    takes), MODULE.FORMAT(results) the text printed."""
    name: str
    about: str              # one line, for `spacephys bench --help`
    module: str             # a module of spacephys.study
    run: str
    format: str
    # what RUN(quick=, out_dir=DIR) writes into DIR (`--out`), printed after "wrote DIR/";
    # "" for a benchmark that takes no out_dir
    writes: str = ""
    json: bool = True       # `--json PATH` writes the results there too
    needs: tuple = ("rebound",)   # the optional packages it imports (spacephys.extras)

    def load(self):
        """(run, format): the two functions, their module imported now."""
        module = importlib.import_module(f"{__package__}.{self.module}")
        return getattr(module, self.run), getattr(module, self.format)


BENCHMARKS = {b.name: b for b in [
    Benchmark("gravity", "direct-summation leapfrog beside REBOUND's, per step and pair",
              "gravitybench", "gravity", "format_gravity"),
    Benchmark("integrators", "Gauss-Radau and Wisdom-Holman beside IAS15 and WHFast",
              "integratorbench", "integrators", "format_integrators"),
    Benchmark("collisions", "circle fields: detection, the dense field; merging beside REBOUND",
              "collisionbench", "collisions", "format_collisions"),
    Benchmark("fleet", "the fleet battle at 60 Hz: each step and its parts",
              "fleetbench", "fleet", "format_fleet"),
    Benchmark("log", "what recording costs, beside REBOUND's Simulationarchive",
              "logbench", "log", "format_log"),
    Benchmark("tradeoff", "every integrator's error against its cost (files into --out)",
              "tradeoff", "study", "markdown",
              writes="tradeoff.json, tradeoff.csv and a plot per scene",
              needs=("rebound", "matplotlib")),
    Benchmark("peers", "REBOUND's cost over ours at equal accuracy (files into --out)",
              "tradeoff", "peers", "peers_markdown", writes="peers.json", json=False),
    Benchmark("memory", "bytes per body; the peak memory of a million bodies stepped",
              "memorybench", "memory", "format_memory", needs=()),
    Benchmark("models", "what each gravity model costs and gets wrong, beside REBOUND",
              "modelbench", "models", "format_models"),
    Benchmark("overhead", "the cost of a call (step, advance, control), beside REBOUND",
              "overhead", "overhead", "format_overhead"),
    Benchmark("predict", "what a predicted path costs and how right it is, beside REBOUND",
              "prediction", "predict_bench", "format_predict"),
    Benchmark("tree", "the tree beside pytreegrav, REBOUND's tree and direct summation",
              "treebench", "tree", "format_tree", needs=("rebound", "pytreegrav")),
    Benchmark("queries", "the spatial queries beside scipy's cKDTree",
              "querybench", "queries", "format_queries", needs=("scipy",)),
    Benchmark("sweep", "a sweep's throughput on 1 and 2 local Dask workers, beside a loop",
              "sweepbench", "sweep_bench", "format_sweep", needs=("distributed",)),
    Benchmark("play", "the game's frame budget, each mode played headless",
              "playbench", "play_bench", "format_play", needs=("pygame",)),
    Benchmark("threads", "the default thread choice beside busy processes, against one "
              "thread and all", "threadbench", "threads", "format_threads", needs=()),
    Benchmark("netplay", "rolling back 8 frames of the duel and the arena; frame times at "
              "100 ms", "netplaybench", "netplay_bench", "format_netplay", needs=()),
    Benchmark("compile", "each scenario's cold start and what it compiles; the warm start",
              "compilebench", "compile_bench", "format_compile", needs=()),
]}
