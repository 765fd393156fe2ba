"""`spacephys bench threads` on its quick sizes: every scene under every load, each way and
mode, with the ratio the goal is set on."""
from spacephys.study import threadbench


def test_every_scene_load_way_and_mode_is_timed(capsys):
    results = threadbench.threads(quick=True)
    rows = results["rows"]
    assert [(r["scene"], r["busy"]) for r in rows] == [
        (scene, busy) for busy in (0, 1, 2) for scene in threadbench._scenes(True)]
    for r in rows:
        for way in ("frames", "long"):
            assert all(0 < r[f"{way}_{m}_s"] < 1 for m in threadbench.MODES)
            assert r[f"{way}_auto_over_one"] == r[f"{way}_auto_s"] / r[f"{way}_never_s"]
    assert {r["scene"]: r["force_loop"] for r in rows} == {
        "star_system": True, "dense field": False, "N = 1 024 direct": True}
    for loop, key in ((True, "worst_auto_over_one"), (False, "worst_same_code")):
        assert results[key] == max(max(r["frames_auto_over_one"], r["long_auto_over_one"])
                                   for r in rows if r["force_loop"] == loop)
    table = threadbench.format_threads(results)
    assert table.count("| star_system |") == 3 and "(goal <= 1.10)" in table
    assert "the same code's spread" in table
