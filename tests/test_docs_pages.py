"""The Concepts and FAQ pages run as written (their Python blocks in order, extracted from
the Markdown) and print what they say they print; so does every Python block of the guide,
here or in the test of what it shows."""
import contextlib
import io
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"

def printed_by(page):
    """What a Markdown page's Python blocks print, run in order as one script (extracted
    from the page, as a reader would paste them)."""
    code = "\n".join(re.findall(r"```python\n(.*?)```", page.read_text(), re.S))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, page.name, "exec"), {"__name__": "__main__"})
    return out.getvalue()


# what each page's prints give, line by line (a str: the whole line; a tuple: its start)
EXPECTED = {
    "concepts.md": ["0 1 [1. 0.]", "False True False",
                    ("refused: id = 1 names no live body",), "body", "True False",
                    "merge 0 1 0.5", "1.0", "True"],
    "faq.md": ["world", "0.0", "True True 8.0", "False", "['destroy', 'destroy']", "4",
               ("0.0099999999999",), "never"],
}


@pytest.mark.parametrize("page", sorted(EXPECTED))
def test_the_page_runs_as_written_and_prints_what_it_says(page):
    lines = printed_by(DOCS / page).splitlines()
    assert len(lines) == len(EXPECTED[page]), lines
    for got, want in zip(lines, EXPECTED[page]):
        assert got.startswith(want[0]) if isinstance(want, tuple) else got == want, (got, want)


GUIDE = DOCS / "guide"
# guide pages whose blocks a test of their subject runs (and checks what they print)
RUN_ELSEWHERE = {"collisions.md": ("test_cli.py", "test_compound.py"),
                 "ships.md": ("test_cli.py",), "game-loop.md": ("test_cli.py",),
                 "queries.md": ("test_cli.py", "test_compound_queries.py"),
                 "drawing.md": ("test_draw.py",)}
# the guide pages run here, and what each prints that says it did what the page says
RUN_HERE = {"world.md": [], "gravity.md": ["[(14, 0, 1, 0.39"],
            "orbits.md": ["(3, 16, 3, 14)", "granted="],
            "prediction.md": ["apocentre", "pericentre"]}


def test_every_guide_page_with_code_is_run():
    pages = {p.name for p in GUIDE.glob("*.md") if "```python" in p.read_text()}
    assert pages == set(RUN_ELSEWHERE) | set(RUN_HERE)
    tests = Path(__file__).parent
    for page, files in RUN_ELSEWHERE.items():
        assert all(page in (tests / f).read_text() for f in files), page


@pytest.mark.parametrize("page", list(RUN_HERE))
def test_the_guide_page_runs_as_written(page):
    out = printed_by(GUIDE / page)
    assert all(marker in out for marker in RUN_HERE[page]), out[-2000:]
