"""`spacephys bench overhead`, its per-call part: every case timed on both sides."""
import math

from spacephys.study.overhead import _calls, _snapshots


def test_per_call_cases_run_beside_rebound():
    """The cases of the issue, each with a finite time, and REBOUND's beside the three
    that have one (its duel: the star pulls, the ships do not, nothing collides)."""
    rows = _calls(quick=True)
    assert [r["case"] for r in rows] == ["step(1), 2 bodies",
                                         "advance(1/60), one step of 2 bodies",
                                         "duel step(1)", "duel step(1), compound hulls",
                                         "duel control()"]
    for r in rows:
        assert 0.0 < r["spacephys_s"] < 1e-3 and math.isfinite(r["spacephys_s"])
        if r["case"] != "duel control()":
            assert 0.0 < r["rebound_s"] < 1e-3
            assert math.isclose(r["ratio"], r["spacephys_s"] / r["rebound_s"])
    # the compound duel's target is 1.5 times the round duel's step, measured in the same run
    by = {r["case"]: r for r in rows}
    assert by["duel step(1), compound hulls"]["target_s"] == 1.5 * by["duel step(1)"]["spacephys_s"]


def test_the_compound_duel_has_compound_hulls():
    from spacephys.study.overhead import _duel
    w, ship = _duel(compound=True)
    assert w.shape(ship) is not None and len(w.circles()[0]) == 6


def test_snapshot_cases_run_beside_rebounds_copy():
    """A duel (the game's, with torpedoes and debris) and 10 000 bodies: snapshot + restore,
    restore alone and digest() timed, REBOUND's sim.copy() beside them."""
    rows = _snapshots(quick=True)
    assert [r["world"] for r in rows] == ["duel", "10 000 bodies"]
    assert 5 <= rows[0]["bodies"] <= 50 and rows[1]["bodies"] == 10_000
    for r in rows:
        for key in ("snapshot_restore_s", "restore_s", "digest_s", "rebound_copy_s"):
            assert 0.0 < r[key] < 0.1
        assert math.isclose(r["ratio"], r["snapshot_restore_s"] / r["rebound_copy_s"])


def test_batched_leapfrog_is_timed_beside_rebound_at_two_call_lengths():
    """N = 2..5, a short and a long call each, both codes on the same scene."""
    from spacephys.study.overhead import _batched
    rows = _batched(quick=True)
    assert [(r["bodies"], r["steps"]) for r in rows] == [
        (n, k) for n in (2, 3, 4, 5) for k in (200, 2000)]
    for r in rows:
        assert 0.0 < r["spacephys_s_per_step"] < 1e-4 and 0.0 < r["rebound_s_per_step"] < 1e-4
        assert math.isclose(r["ratio"], r["spacephys_s_per_step"] / r["rebound_s_per_step"])
