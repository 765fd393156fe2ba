"""The Concepts and FAQ pages run as written (their Python blocks in order, extracted from
the Markdown) and print what they say they print."""
import contextlib
import io
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"

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
    code = "\n".join(re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), re.S))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, page, "exec"), {})
    lines = out.getvalue().splitlines()
    assert len(lines) == len(EXPECTED[page]), lines
    for got, want in zip(lines, EXPECTED[page]):
        assert got.startswith(want[0]) if isinstance(want, tuple) else got == want, (got, want)
