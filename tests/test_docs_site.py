"""The documentation site builds from docs/ with no warning, and the README's links lead somewhere.

`mkdocs build --strict` turns every warning into a failure: a broken link or a missing anchor
(mkdocs.yml's `validation:`), a page left out of the navigation, a snippet of the README that
is gone, a docstring the API reference cannot read.
"""
import html
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")   # [t](x), ![a](x)
IMG = re.compile(r"<img\b[^>]*\bsrc=\"([^\"]+)\"")


def build(site):
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                           "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(site)],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)


def test_the_site_builds_strict_with_every_page(tmp_path):
    site = tmp_path / "site"
    done = build(site)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "WARNING" not in done.stderr, done.stderr
    for page in ("index.html", "guide/world.html", "performance.html", "api/world.html",
                 "api/functions.html", "examples.html"):
        assert (site / page).is_file(), page
    # the API reference is made from the docstrings
    world = (site / "api" / "world.html").read_text()
    assert "advance" in world and "Bodies under gravity" in world
    # every script of examples/ is on the Examples page, with its source
    page = (site / "examples.html").read_text()
    examples = html.unescape(re.sub(r"<[^>]+>", "", page))        # the text, not its colours
    for script in sorted((ROOT / "examples").glob("*.py")):
        last = [line for line in script.read_text().splitlines() if line.strip()][-1]
        assert f">{script.name}<" in page, script.name
        assert last.strip() in examples, script.name
    # the home page takes the README's sections (snippets), the commands among them
    home = (site / "index.html").read_text()
    assert "python3.11 dev.py test" in home and "--8&lt;--" not in home
    assert "spacephys play arena" in html.unescape(re.sub(r"<[^>]+>", "", home))
    assert all(f'src="images/play-{m}.png"' in home for m in ("duel", "orbit", "arena"))
    # offline: no script, stylesheet, image or font from another host, and the code is
    # coloured when the site is built (Pygments), not by a script from a CDN
    remote = re.compile(r"<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)=\"(?:https?:)?//")
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 30 and not [p.name for p in pages if remote.search(p.read_text())]
    assert not [c.name for c in site.rglob("*.css") if "@import url(http" in c.read_text()]
    loop = (site / "guide" / "game-loop.html").read_text()
    assert '<div class="highlight">' in loop and '<span class="k">' in loop


def readme_targets():
    text = (ROOT / "README.md").read_text()
    text = re.sub(r"```.*?```", "", text, flags=re.S)            # code is not a link
    return LINK.findall(text) + IMG.findall(text)


def test_readme_links_and_images_point_at_files_that_exist():
    targets = readme_targets()
    assert any(t.endswith(".png") for t in targets)               # the picture
    assert any(t.startswith("docs/") for t in targets)            # where to go next
    missing = []
    for target in targets:
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue                                               # a URL, or this page
        path = ROOT / target.split("#")[0]
        if not path.exists():
            missing.append(target)
    assert not missing, f"README.md links to files that do not exist: {missing}"


def test_the_readme_picture_is_small():
    for target in readme_targets():
        if target.endswith(".png"):
            assert (ROOT / target).stat().st_size < 200_000, target


def test_the_changelog_names_this_version_and_is_on_the_site():
    """CHANGELOG.md (Keep a Changelog): an Unreleased section, then the released versions,
    the newest this package's __version__; the site shows it."""
    import spacephys
    text = (ROOT / "CHANGELOG.md").read_text()
    versions = re.findall(r"^## \[([^\]]+)\]", text, re.M)
    assert versions[0] == "Unreleased" and versions[1] == spacephys.__version__
    assert all(re.search(rf"## \[{re.escape(v)}\].*?### (Added|Changed|Fixed)", text, re.S)
               for v in versions)
    assert "changelog.md" in (ROOT / "mkdocs.yml").read_text()


def test_the_lecture_notes_are_cited_by_name_never_as_the_seed():
    """Laird & Jamin's *Basic Game Physics* is cited by its title and authors (the
    References page lists it); "the seed" means a random generator's seed only."""
    seed_as_text = re.compile(r"\bthe seed'?s?\s+(brick|wind|particle|lecture|notes|model|"
                              r"game|text|physics|projectile|thrust)", re.I)
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"),
             *(ROOT / "spacephys").rglob("*.py"), *(ROOT / "examples").glob("*.py")]
    assert not [f"{f.name}: {m.group(0)}" for f in files
                for m in seed_as_text.finditer(f.read_text())]
    references = (ROOT / "docs" / "references.md").read_text()
    assert "Laird and S. Jamin, *Basic Game Physics*" in references
    assert "references.md" in (ROOT / "mkdocs.yml").read_text()


# World's members the API reference leaves out: the World's own parts call them
HIDDEN = {"tables", "driver", "warn_later", "named", "step_control_rows"}
DOCUMENTED = ("World", "Run", "RunResult", "Sweep", "Prediction", "Hits", "RayHits", "Burn",
              "Elements", "ShipSpec", "MissileSpec", "ExplosionSpec", "Circles", "Filter")


def _members(cls):
    """(name, docstring) of a class's public methods and properties (its own and its
    bases' but object's)."""
    import inspect
    out = {}
    for klass in reversed(cls.__mro__[:-1]):
        for name, v in vars(klass).items():
            if name.startswith("_") or not (callable(v) or isinstance(
                    v, (property, staticmethod, classmethod))):
                continue
            fn = v.fget if isinstance(v, property) else getattr(v, "__func__", v)
            out[name] = inspect.getdoc(fn) or ""
    return out


def test_every_public_name_has_a_docstring_and_an_entry_in_the_reference(tmp_path):
    import inspect
    import spacephys as sp
    undocumented = [n for n in sp.__all__ if (inspect.isclass(getattr(sp, n)) or
                                              inspect.isfunction(getattr(sp, n)))
                    and not (inspect.getdoc(getattr(sp, n)) or "").strip()]
    undocumented += [f"{c}.{m}" for c in DOCUMENTED
                     for m, doc in _members(getattr(sp, c)).items()
                     if not doc.strip() and not (c == "World" and m in HIDDEN)]
    assert not undocumented
    site = tmp_path / "site"
    assert build(site).returncode == 0
    api = "".join(p.read_text() for p in (site / "api").glob("*.html"))
    anchors = set(re.findall(r'id="(spacephys\.[A-Za-z0-9_.-]+)"', api))
    ends = {a.rsplit(".", 1)[-1] for a in anchors}
    assert not [n for n in sp.__all__ if n not in ends]
    world = [m for m in _members(sp.World) if m not in HIDDEN and m != "index_of"]
    assert not [m for m in world if f"spacephys.World.{m}" not in anchors]
    assert "spacephys.World.index_of-rows" in anchors
    assert not [f"spacephys.World.{m}" for m in HIDDEN if f"spacephys.World.{m}" in anchors]
    # the events page: every kind and every field
    events = (site / "api" / "constants.html").read_text()
    assert all(f"<code>{name}</code>" in events for name in sp.EVENT_KINDS.values())
    assert all(f"<code>{f}</code>" in events for f in sp.EVENT_DTYPE.names)


def _hooks():
    import importlib.util
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_figures_on_the_pages_are_written_from_the_committed_results():
    hooks = _hooks()
    results = {}
    for path in sorted(p for folder in hooks.RESULTS for p in folder.glob("*.json")):
        r = results[path.stem] = json.loads(path.read_text())
        assert r["benchmark"] == path.stem and r["quick"] is False, path.name
        assert re.fullmatch(r"\d{4}-\d\d-\d\d", r["date"]) and r["cpu"], path.name
    quoted = 0
    for page in sorted((ROOT / "docs").rglob("*.md")):
        text = page.read_text()
        quoted += len(hooks.FIGURE.findall(text))
        hooks.figures(text)                        # a path that names nothing raises
    assert quoted >= 5
    step = results["overhead"]["calls"][0]
    assert step["case"] == "step(1), 2 bodies"
    line = 'a step: {{ overhead.calls["step(1), 2 bodies"].spacephys_s | us }}'
    assert hooks.figures(line) == f"a step: {step['spacephys_s'] * 1e6:.3g} µs"
    assert hooks.figures("{{ overhead.calls | count }}") == str(len(results["overhead"]["calls"]))
    assert hooks.figure({"t": 0.0020014}, "b", ".t", "us") == "2 001 µs"     # not 2e+03
    assert hooks.figure({"t": 0.0020014}, "b", ".t", "ms") == "2 ms"
    assert hooks.figure({"d": 65163201.0}, "b", ".d", "km") == "65 163 km"
    for wrong in ('{{ overhead.calls["step(2)"].spacephys_s | us }}',
                  '{{ overhead.calls["step(1), 2 bodies"].seconds | us }}',
                  '{{ overhead.cpu | us }}', '{{ overhead.calls | us }}',
                  '{{ overhead.calls["duel control()"].rebound_s | us }}', '{{ nobench.x }}',
                  '{{ overhead.cpu | count }}'):
        with pytest.raises(KeyError):
            hooks.figures(wrong)
