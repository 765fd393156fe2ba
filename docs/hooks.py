"""The docs build's own code: an mkdocs hook and a griffe extension (both named in mkdocs.yml).

- The hook makes the Examples page at build time from every file of examples/: each
  examples/*.py with its whole source (and the files they read, such as salvo.toml, after
  them), so a script added to examples/ is on the site without editing the docs.
- Figures from data: a page quotes a benchmark's figure as `{{ overhead.calls["step(1), 2
  bodies"].spacephys_s | us }}`, and the build writes it from the benchmark's latest results
  committed in docs/data/<benchmark>.json (`spacephys bench NAME --json`, with the date and
  the CPU in it; the work-precision study's in docs/tradeoff/, beside its plots), so a
  re-run updates every page that quotes it and no two pages can disagree. A path that names
  nothing fails the build.
- PlainDocstrings, for the API reference: the docstrings are plain prose, with arguments on
  lines of their own ("tof : float > 0, the time of flight [time]", continued on indented
  lines); Markdown would run those lines into one paragraph, so each becomes an item of a
  list. A docstring with a numpy section (World's "Parameters") is left to the numpy parser.

mkdocs.yml keeps this file out of the site (`exclude_docs`).
"""
import ast
import json
import re
from pathlib import Path

import griffe
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PAGE = "examples.md"
LANGUAGES = {".py": "python", ".toml": "toml", ".json": "json", ".yml": "yaml",
             ".yaml": "yaml", ".txt": "text", ".csv": "text"}


def _fenced(text, language):
    """text in a fenced block whose fence is longer than any run of backticks inside it."""
    longest = max((len(run) for run in re.findall(r"`+", text)), default=0)
    fence = "`" * max(3, longest + 1)
    return f"{fence}{language}\n{text.rstrip()}\n{fence}\n"


def _anchor(path):
    return re.sub(r"[^a-z0-9]+", "-", path.name.lower()).strip("-")


def _summary(path):
    """': ' and the first sentence of a script's docstring ('' for other files, or none)."""
    if path.suffix != ".py":
        return ""
    try:
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    except SyntaxError:
        return ""
    first = " ".join(doc.split("\n\n")[0].split())
    first = re.split(r"(?<=\.)\s", first)[0]
    return f": {first}" if first else ""


def examples_page():
    scripts = sorted(EXAMPLES.glob("*.py"))
    others = sorted(p for p in EXAMPLES.iterdir()
                    if p.is_file() and p.suffix != ".py" and p.suffix in LANGUAGES)
    lines = ["# Examples", "",
             "Scripts to copy, from the repository's `examples/` folder. Each runs from the "
             "repository root as `python examples/NAME.py` (its docstring says how), and "
             "`tests/test_examples.py` runs them. This page is made from the folder when the "
             "site is built (`docs/hooks.py`): every script is here, with its whole source.", ""]
    lines += [f"- [`{p.name}`](#{_anchor(p)})" + _summary(p) for p in scripts + others]
    lines.append("")
    for p in scripts:
        lines += [f"## {p.name} {{#{_anchor(p)}}}", "", _fenced(p.read_text(), "python")]
    if others:
        lines += ["## Files the scripts read", ""]
        for p in others:
            lines += [f"### {p.name} {{#{_anchor(p)}}}", "",
                      _fenced(p.read_text(), LANGUAGES[p.suffix])]
    return "\n".join(lines)


def on_files(files, config):
    files.append(File.generated(config, PAGE, content=examples_page()))
    return files


DATA = ROOT / "docs" / "data"
# the work-precision study writes its plots beside its results: the page shows both
RESULTS = (DATA, ROOT / "docs" / "tradeoff")
# {{ bench.key["row"].key | unit }}: ["key"] of a dict, or the row of a list with a value
# equal to "row", or with "field=value" (or "a=1, b=2": every field so)
FIGURE = re.compile(r"\{\{\s*([a-z_]+)((?:\.\w+|\[\"[^\"]*\"\])+)\s*(?:\|\s*(\w+)\s*)?\}\}")
FIELDS = re.compile(r"^\w+=[^,]*(?:, \w+=[^,]*)*$")
STEP = re.compile(r"\.(\w+)|\[\"([^\"]*)\"\]")


def _number(v):
    """Three significant digits, or a whole number in full from 1 000 (3 170, not 3.17e+03)."""
    if isinstance(v, int) or abs(v) >= 1000:
        return f"{v:,.0f}".replace(",", " ")
    return f"{v:.3g}"


UNITS = {"s": lambda v: f"{_number(v)} s", "ms": lambda v: f"{_number(v * 1e3)} ms",
         "us": lambda v: f"{_number(v * 1e6)} µs", "ns": lambda v: f"{_number(v * 1e9)} ns",
         "x": lambda v: f"{_number(v)}×", "e": lambda v: f"{v:.1e}",
         "MB": lambda v: f"{_number(v / 1e6)} MB", "kB": lambda v: f"{_number(v / 1e3)} kB",
         "km": lambda v: f"{_number(v / 1e3)} km",
         "pct": lambda v: f"{_number(v * 100)} %"}


def figure(results, name, path, unit=None):
    """The value at `path` (".key", '["row"]' and '["field=value, ..."]' steps) of the results of
    benchmark `name`, written with three significant digits, or a whole number in full from
    1 000 (100 000), in `unit` (s, ms, us, ns, x, MB and kB from bytes, km from metres, pct
    from a fraction; e: two digits, in powers of ten; none: as it is; count: how many items a
    list holds)."""
    value = results
    for key, row in STEP.findall(path):
        if key:
            if not isinstance(value, dict) or key not in value:
                raise KeyError(f"{name}{path}: no {key!r}")
            value = value[key]
        elif isinstance(value, dict) and row in value:
            value = value[row]
        else:
            wanted = [pair.split("=", 1) for pair in row.split(", ")] \
                if FIELDS.match(row) else None
            rows = [r for r in value if (all(str(r.get(k)) == v for k, v in wanted) if wanted
                                         else row in r.values())] \
                if isinstance(value, list) else []
            if len(rows) != 1:
                raise KeyError(f"{name}{path}: {len(rows)} rows named {row!r}")
            value = rows[0]
    if unit == "count" and isinstance(value, list):
        return str(len(value))
    if value is None or isinstance(value, (dict, list)) or \
            unit is not None and (isinstance(value, str) or unit not in UNITS):
        raise KeyError(f"{name}{path}: cannot write {value!r} in {unit!r}")
    if unit is not None:
        return UNITS[unit](value)
    if isinstance(value, (bool, str)):
        return str(value)
    return _number(value)


def figures(markdown, folders=RESULTS):
    """markdown with every {{ ... }} figure written from <benchmark>.json in `folders`."""
    loaded = {}

    def one(m):
        name = m.group(1)
        if name not in loaded:
            path = next((p for p in (f / f"{name}.json" for f in folders) if p.is_file()),
                        None)
            if path is None:
                raise KeyError(f"{{{{ {name}...}}}}: no {name}.json in {folders}")
            loaded[name] = json.loads(path.read_text())
        return figure(loaded[name], name, m.group(2), m.group(3))
    return FIGURE.sub(one, markdown)


def on_page_markdown(markdown, page, config, files):
    return figures(markdown)


# "name : what" or "a, b : what" at the start of a docstring's line
ENTRY = re.compile(r"^([A-Za-z_][\w.]*(?:, [A-Za-z_][\w.]*)*) : ")
NUMPY_SECTION = re.compile(r"^\s*-{3,}\s*$", re.M)


def entries_as_list(text):
    """A docstring's "name : what" lines (and their indented continuations) as a list."""
    if NUMPY_SECTION.search(text):
        return text
    out, in_list = [], False
    for line in text.split("\n"):
        found = ENTRY.match(line)
        if found:
            if not in_list and out and out[-1].strip():
                out.append("")
            out.append(f"- `{found.group(1)}` : {line[found.end():]}")
            in_list = True
        elif in_list and line.startswith(" ") and line.strip():
            out.append("    " + line.strip())
        else:
            if in_list and line.strip():
                out.append("")
            in_list = False
            out.append(line)
    return "\n".join(out)


class PlainDocstrings(griffe.Extension):
    """Griffe extension: the argument lines of plain-prose docstrings as Markdown lists."""

    def on_instance(self, *, node, obj, agent, **kwargs):
        if obj.docstring is not None:
            obj.docstring.value = entries_as_list(obj.docstring.value)
