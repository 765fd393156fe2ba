"""The heavy scenes' benchmark (spacephys bench collisions / fleet) on small versions: every
figure present and sane, the busy core really busy while it runs."""
import os
import time

import numpy as np

from spacephys.study import heavybench as hb


def test_heavy_measure_reports_percentiles_split_and_a_busy_core():
    out = hb.measure(lambda: hb.game_fleet(20, 200, 2000), 12, 6)
    for name in ("quiet", "one core busy"):
        f = out[name]
        assert 0 < f["median_ms"] <= f["p95_ms"] <= f["worst_ms"]
        s = f["split_ms"]
        assert set(s) == {"broad_ms", "narrow_ms", "responses_ms", "guidance_ms",
                          "gravity_ms", "rest_ms"}
        assert all(v >= 0 for v in s.values()) and s["broad_ms"] > 0 and s["guidance_ms"] > 0
        assert f["bodies"] > 2000
    lines = hb.format_rows("t", [(k, out[k]) for k in out])
    assert len(lines) == 4 and lines[2].startswith("quiet")


def test_busy_core_spins():
    spinner = hb.busy_core()

    def cpu_seconds():
        fields = open(f"/proc/{spinner.pid}/stat").read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    try:
        time.sleep(0.3)
        start, used = time.monotonic(), cpu_seconds()
        time.sleep(1.0)
        assert (cpu_seconds() - used) / (time.monotonic() - start) > 0.5
    finally:
        spinner.kill()
        spinner.wait()


def test_dense_field_covers_a_tenth_of_its_square():
    w = hb.dense_field(5000, boundary="reflect")
    side = w.boundary[2][0]
    assert abs(np.pi * np.sum(w.radius ** 2) / side ** 2 - 0.10) < 1e-12
    assert 0.5 <= w.radius.min() and w.radius.max() <= 2.0
    assert np.allclose(w.mass, w.radius ** 2)


def test_dense_scaling_times_both_orders_and_sorts_only_the_space_ordered(monkeypatch):
    from spacephys import space_order
    from spacephys.driver import Driver
    moved = []
    sort = Driver._sort
    monkeypatch.setattr(Driver, "_sort", lambda self: moved.append(sort(self)) or moved[-1])
    least = space_order.MIN_BODIES
    out = hb.dense_scaling(quick=True)
    assert space_order.MIN_BODIES == least
    assert out["sizes"] == [12_500, 25_000, 50_000]
    assert out["steps"] == {"12500": 40, "25000": 20, "50000": 10}    # more when smaller
    for case in ("space order", "creation order"):
        per = [out[case][str(n)] for n in out["sizes"]]
        assert all(0 < p < 1e5 for p in per)             # ns a body
        assert out[case + " spread"] == max(per) / min(per)
    assert moved.count(True) == len(out["sizes"])       # one sort each, in space order only
