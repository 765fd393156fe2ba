"""`spacephys bench compile`: a scenario's cold start in a fresh process, and what it compiled."""
from spacephys.study import compilebench


def test_a_cold_scenario_reports_its_start_and_the_kernels_it_compiled():
    """two_body (leapfrog, direct gravity, nothing else) from an empty cache: its start's
    seconds in order, the step kernel among the kernels it compiled, and no code of what the
    scene lacks (the tree, collisions, ships, user forces, another family's integration)."""
    r = compilebench.cold_scenario("two_body")
    assert 0.0 < r["import_s"] < r["first_step_s"]
    names = [k["kernel"] for k in r["kernels"]]
    assert "kernels.step.run" in names
    assert r["compile_s"] > 0.0 and all(k["seconds"] >= 0.0 for k in r["kernels"])
    assert [k["seconds"] for k in r["kernels"]] == sorted((k["seconds"] for k in r["kernels"]),
                                                          reverse=True)
    absent = ("kernels.tree.", "kernels.collide.", "kernels.broadphase.", "kernels.responses.",
              "kernels.control.", "kernels.gauss_radau.",
              "kernels.wisdom_holman.")
    assert not [n for n in names if n.startswith(absent) or n.endswith(absent)], names


def test_the_warm_start_compiles_nothing():
    r = compilebench.warm_start(repeats=1)
    for w in (r, r["installed"]):
        assert w["kernels_compiled"] == 0
        assert 0.0 < w["import_s"] < w["first_step_s"]
        assert w["floor_s"] > 0.0


# numba's first call, then spacephys imported and a kernel called: the scipy modules loaded
_SCIPY_LOADED = """
import json, sys
import numba, numpy as np
import spacephys as sp
sp.solve_kepler(0.5, 0.1)
@numba.njit
def total(a):
    return a.sum()
total(np.ones(3))
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] == "scipy")))
"""


def test_the_installed_warm_start_runs_without_scipy(tmp_path):
    """The "installed" probe hides scipy (which numba imports on its first call when it is
    there: the test extra brings it), and spacephys runs without it."""
    assert compilebench._probe(_SCIPY_LOADED, tmp_path)          # the test extra's scipy
    assert compilebench._probe(_SCIPY_LOADED, tmp_path, scipy=False) == []


def test_every_shipped_scenario_is_benchmarked_and_the_table_names_them():
    names = compilebench.scenarios()
    assert "star_system" in names and len(names) >= 10
    row = {"scenario": "x", "import_s": 0.3, "build_s": 0.1, "first_step_s": 4.0,
           "compile_s": 3.5, "kernels": [{"kernel": "k", "compilations": 1, "seconds": 3.5}]}
    text = compilebench.format_compile({
        "machine": "m", "versions": {}, "scenarios": [row],
        "warm": {"import_s": 0.3, "first_step_s": 0.5, "kernels_compiled": 0, "floor_s": 0.4,
                 "installed": {"import_s": 0.2, "first_step_s": 0.35, "kernels_compiled": 0,
                               "floor_s": 0.25}},
        "every_kernel": {"gravity_s": 10.0, "all_s": 30.0, "kernels": row["kernels"]}})
    assert "| x | 0.30 s | 4.0 s | 3.5 s | 1 | k 3.5 |" in text
    assert "every kernel, cold" in text
    assert "(no scipy): import 0.20 s, import + first step 0.35 s" in text
