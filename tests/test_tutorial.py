"""The tutorial (docs/tutorial/) runs as written: each page's Python blocks in order,
extracted from the Markdown, as a reader would paste them into one script; and each prints
what the page says it does."""
import os
import re
from pathlib import Path

import pytest

from test_docs_pages import printed_by

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial"

# each page's prints, as patterns (in order, one per line printed)
EXPECTED = {
    "index.md": [r"spacephys \d+\.\d+\.\d+: t = 1\.000, planet at \[99\.95 +3\.16\]"],
    "orbit.md": [r"t = 3\.00: 14 bodies, the moon drawn at \(\d+\.\d, \d+\.\d\)"],
    "ship.md": [r"fuel left 0\.9\d\d, heading 3\.07 rad, launch events 1, torpedo 2 from 1",
                r"torpedo alive after its lifetime: False"],
    "collisions.md": [r"score 30, rocks left 6, debris flying \d+"],
    "hud.md": [r"laser: hit True, the rock: True, at 30\.0",
               r"pericentre 1\d\d\.\d, apocentre 3\d\d\.\d, path ahead \(200, 2\)",
               r"replayed bit for bit: True", r"pixels drawn: True"],
    "faster.md": [r"\w+ at dt = [\d.e-]+: error [\d.e+-]+, met True, \d+ trials",
                  r"t = [\d.]+, warp granted 1000, coasting: \[2\]"],
}


def test_every_page_is_listed_and_in_the_navigation():
    pages = sorted(p.name for p in TUTORIAL.glob("*.md"))
    assert pages == sorted(EXPECTED)
    nav = (TUTORIAL.parents[1] / "mkdocs.yml").read_text()
    assert all(f"tutorial/{p}" in nav for p in pages)


@pytest.mark.parametrize("page", list(EXPECTED))
def test_the_page_runs_as_written(page, monkeypatch):
    monkeypatch.setitem(os.environ, "SDL_VIDEODRIVER", "dummy")
    lines = printed_by(TUTORIAL / page).splitlines()
    assert len(lines) == len(EXPECTED[page]), lines
    for got, want in zip(lines, EXPECTED[page]):
        assert re.fullmatch(want, got), (got, want)
