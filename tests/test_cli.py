"""The command line end to end, as a user runs it: exit codes, summaries, errors."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def spacephys(*args):
    exe = Path(sys.executable).parent / "spacephys"        # the installed console script
    return subprocess.run([str(exe), *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=600)


def test_run_prints_a_summary():
    res = spacephys("run", "figure_eight", "--duration", "6.32591398", "--quiet")
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "scene         figure_eight (2D, 3 bodies: 3 pulling" in out
    assert "integrator    yoshida6 (order 6, symplectic), dt = 0.001" in out
    assert re.search(r"steps         6326 in [\d.]+ s", out)
    error = float(re.search(r"energy .* relative error (\S+)", out).group(1))
    assert error < 1e-12          # yoshida6 at dt = 1e-3 over one period of the figure-eight


def test_run_overrides_integrator_and_dt():
    res = spacephys("run", "kepler", "--integrator", "euler", "--dt", "0.01", "--duration", "6.3",
                    "--quiet")
    assert res.returncode == 0, res.stderr
    assert "integrator    euler (order 1, not symplectic), dt = 0.01" in res.stdout
    assert "steps         630 in" in res.stdout
    error = float(re.search(r"energy .* relative error (\S+)", res.stdout).group(1))
    assert error > 1e-2           # the textbook Euler visibly loses energy


@pytest.mark.parametrize("args,message", [
    (["run", "kepler", "--dt", "-1"], "spacephys run: error: dt = -1.0: must be > 0"),
    (["run", "kepler", "--duration", "0"], "spacephys run: error: duration = 0.0: must be > 0"),
    (["run", "kepler", "--duration", "nan"], "spacephys run: error: duration = nan: must be > 0"),
    (["run", "jupiter"], "spacephys run: error: 'jupiter' is neither a scenario file"),
    (["run", "--integrator", "ias15"], "invalid choice: 'ias15'"),
    (["bench", "everything"], "invalid choice: 'everything'"),
    (["run", "kepler", "--duration", "1e-9"],
     "spacephys run: error: duration = 1e-09 is shorter than one step (dt = 0.001)"),
    (["run", "kepler", "--dt", "1e-320"], "spacephys run: error: duration / dt = "),
    (["validate", "mars"], "spacephys validate: error: problem 'mars' is not known"),
    (["validate", "--integrator", "ias15"], "invalid choice: 'ias15'"),
])
def test_bad_arguments_exit_2_without_traceback(args, message):
    res = spacephys(*args)
    assert res.returncode == 2
    assert message in res.stderr
    assert "Traceback" not in res.stderr


def _doc_example(page, tag):
    """Run the python block marked <!-- tag --> of the repository's file `page` (README.md or
    a page of docs/) as pasted; its output lines."""
    text = (ROOT / page).read_text()
    block = re.search(rf"<!-- {tag} -->\s*```python\n(.*?)```", text, re.S).group(1)
    res = subprocess.run([sys.executable, "-c", block], capture_output=True, text=True,
                         cwd=ROOT, timeout=600)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


def test_readme_quickstart_runs_as_pasted():
    assert any("energy error" in line for line in _doc_example("README.md", "quickstart"))


def test_guide_collision_example_runs_as_pasted():
    assert _doc_example("docs/guide/collisions.md", "collisions")[0].startswith("bounce 0 1 ")   # the ball hits the brick


def test_guide_ships_example_runs_as_pasted():
    lines = _doc_example("docs/guide/ships.md", "ships")
    assert lines[1].startswith("launch ") and lines[2].startswith("detonation ")
    assert lines[-1].startswith("debris: 50 ")       # the prey's explosion


def test_guide_spacewar_loop_runs_as_pasted():
    lines = _doc_example("docs/guide/game-loop.md", "spacewar")
    assert re.match(r"1200 frames: [\d.]+ ms per frame, \d+ bodies now; score ", lines[-1])


def test_the_benchmarked_spacewar_loop_is_the_guides_word_for_word():
    # spacephys bench overhead times the package's copy (an installed package has no docs/)
    page = (ROOT / "docs" / "guide" / "game-loop.md").read_text()
    block = re.search(r"<!-- spacewar -->\s*```python\n(.*?)```", page, re.S).group(1)
    assert (ROOT / "spacephys" / "study" / "spacewar_loop.py").read_text() == block


def test_guide_queries_example_prints_what_the_page_says():
    text = (ROOT / "docs" / "guide" / "queries.md").read_text()
    printed = re.search(r"It prints:\s*```\n(.*?)```", text, re.S).group(1).splitlines()
    assert _doc_example("docs/guide/queries.md", "queries") == printed


def test_netplay_page_examples_run_as_pasted():
    assert _doc_example("docs/netplay.md", "snapshot") == [
        "the same bits as never having burned: True"]
    assert _doc_example("docs/netplay.md", "rollback") == [
        "rolled back and stepped again: True"]
    assert _doc_example("docs/netplay.md", "netplay") == [
        "the same World on both sides: True", "rolled back: True desync: None"]


def test_runlog_page_example_runs_as_pasted():
    lines = _doc_example("docs/runlog.md", "runlog")
    # 300 steps / 5 + 100 / 5 + the first = 81 frames; 1 fuel at 1/3 per time: empty at 3
    assert lines[0] == "81 frames; last at t = 3.5"
    assert lines[1] == "fuel burned out at t = [3.]"
    assert lines[2] == "['control', 'step', 'setattr', 'step']"
    assert lines[3] == "81 recorded frames, the events and the final state equal, bit for bit"


def test_readme_commands_are_what_ci_runs():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    assert "python3.11 dev.py test" in ci and "python3.11 dev.py test" in readme
    assert "python3.11 dev.py run" in readme


def test_validate_prints_the_table_and_writes_it(tmp_path):
    table = tmp_path / "validate.md"
    res = spacephys("validate", "kepler_e0", "hyperbolic", "--integrator", "leapfrog",
                    "--integrator", "gauss_radau", "--markdown", str(table))
    assert res.returncode == 0, res.stderr
    rows = [line for line in res.stdout.splitlines() if line.startswith("| |")]
    assert [r.split("|")[2].strip() for r in rows] == ["leapfrog", "gauss_radau"] * 2
    assert "| **kepler_e0**" in res.stdout and "REBOUND IAS15" in res.stdout
    with open(table) as f:
        assert f.read().startswith("# Validation against REBOUND")


@pytest.mark.parametrize("args, missing, extra", [
    (["validate"], "rebound", "bench"),
    (["bench", "tree"], "pytreegrav", "bench"),
    (["bench", "queries"], "scipy", "bench"),
    (["sweep", "dogfight"], "distributed", "sweep"),
    (["play", "duel", "--headless", "--frames", "1"], "pygame", "game"),
    (["plot", "run.h5", "-o", "run.png"], "matplotlib", "plot"),
])
def test_a_missing_optional_dependency_is_one_line_naming_its_extra_before_compiling(
        tmp_path, args, missing, extra):
    # the package hidden from this process only, as if it were not installed
    code = (f"import sys; sys.modules[{missing!r}] = None\n"
            f"from spacephys.cli import main; sys.exit(main({args!r}))")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, cwd=tmp_path, timeout=300)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and f"pip install 'spacephys[{extra}]'" in res.stderr
    assert missing.replace("pygame", "pygame-ce") in res.stderr
    assert not list(tmp_path.rglob("*.nbi"))                 # nothing was compiled first


def test_python_dash_m_spacephys_is_the_command():
    res = subprocess.run([sys.executable, "-m", "spacephys", "scenarios"], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[0].startswith("arena ")
    res = subprocess.run([sys.executable, "-m", "spacephys", "--help"], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0 and "compile" in res.stdout and "cache" in res.stdout
