"""The scripts in examples/ run as a user runs them, and say what they should."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_salvo_sweep_plots_hit_probability_against_spread(tmp_path):
    png = tmp_path / "salvo.png"
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "salvo_sweep.py"),
                           "--seeds", "4", "--out", str(png)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [s for s in done.stdout.splitlines() if "hit probability" in s]
    assert len(lines) == 7
    # no spread: both missiles fly the same line, and it hits, whatever the seed
    assert lines[0] == "spread   0.0 deg: hit probability 1.00 +- 0.00"
    # the widest spread misses at least once in 4 seeds × 2 missiles
    assert float(lines[-1].split()[5]) < 1.0
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
