"""`spacephys bench play` (a quick run): each mode played headless by the computer, its
frames timed; the figures themselves are the benchmark's (docs/game.md)."""
import os

os.environ["SDL_VIDEODRIVER"] = "dummy"

from spacephys.study import playbench      # noqa: E402


def test_every_mode_is_played_and_timed():
    results = playbench.play_bench(quick=True)
    assert results["frames"] == 600
    assert set(results["modes"]) == {"duel", "orbit", "arena"}
    for name, m in results["modes"].items():
        for part in ("physics", "draw", "frame"):
            s = m[part]
            assert 0 < s["median_ms"] <= s["p95_ms"] <= s["worst_ms"], (name, part)
        assert m["frame"]["median_ms"] > m["physics"]["median_ms"]   # the drawing is in it
        assert m["budget_ms"] == playbench.BUDGETS[name]
    assert results["modes"]["arena"]["bodies_at_end"] > 500           # missiles, debris
    table = playbench.format_play(results)
    for name in ("duel", "orbit", "arena"):
        assert table.count(name) >= 2
