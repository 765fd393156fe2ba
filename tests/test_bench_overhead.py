"""`spacephys bench overhead`, its per-call part: every case timed on both sides."""
import math

from spacephys.study.overhead import _calls


def test_per_call_cases_run_beside_rebound():
    """The four cases of the issue, each with a finite time, and REBOUND's beside the three
    that have one (its duel: the star pulls, the ships do not, nothing collides)."""
    rows = _calls(quick=True)
    assert [r["case"] for r in rows] == ["step(1), 2 bodies",
                                         "advance(1/60), one step of 2 bodies",
                                         "duel step(1)", "duel control()"]
    for r in rows:
        assert 0.0 < r["spacephys_s"] < 1e-3 and math.isfinite(r["spacephys_s"])
        if r["case"] != "duel control()":
            assert 0.0 < r["rebound_s"] < 1e-3
            assert math.isclose(r["ratio"], r["spacephys_s"] / r["rebound_s"])
