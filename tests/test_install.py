"""spacephys as a game adds it: the wheel built from this repository, installed into a fresh
virtual environment in a temporary folder (Python 3.11, and 3.12 and 3.13 where this machine
has them), used from another folder; the sdist; the version written once."""
import glob
import os
import re
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

import spacephys

ROOT = Path(__file__).resolve().parents[1]


def _run(*args, **kw):
    res = subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=900,
                         **kw)
    assert res.returncode == 0, f"{args}: {res.stdout[-2000:]}\n{res.stderr[-4000:]}"
    return res


def _other_pythons():
    """Python 3.12 and 3.13 interpreters this machine has (PATH, then pyenv's versions)."""
    found = []
    for minor in (12, 13):
        candidates = [shutil.which(f"python3.{minor}")] + sorted(glob.glob(os.path.expanduser(
            f"~/.pyenv/versions/3.{minor}.*/bin/python3.{minor}")))
        for exe in filter(None, candidates):
            if subprocess.run([exe, "-c", "import venv"], capture_output=True).returncode == 0:
                found.append(exe)
                break
    return found


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    """The wheel and the sdist, built as a release would be (python -m build)."""
    out = tmp_path_factory.mktemp("dist")
    _run(sys.executable, "-m", "build", "--outdir", out, ROOT)
    return next(out.glob("*.whl")), next(out.glob("*.tar.gz"))


def _fresh(python, where, wheel):
    """A new virtual environment at `where` with the wheel installed: its bin folder."""
    _run(python, "-m", "venv", where)
    bin_ = where / ("Scripts" if os.name == "nt" else "bin")
    _run(bin_ / "python", "-m", "pip", "install", "--quiet", wheel)
    return bin_


def _env(tmp):
    """The environment of a user's shell: no numba settings, no path into this checkout."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_", "PYTHON", "VIRTUAL_ENV"))}
    return dict(env, HOME=str(tmp / "home"))


def test_the_wheel_installs_runs_and_compiles_from_anywhere(dist, tmp_path):
    wheel, _ = dist
    bin_ = _fresh(Path(sys._base_executable), tmp_path / "venv", wheel)
    game = tmp_path / "my_game"                   # a folder that is not this repository
    game.mkdir()
    env = _env(tmp_path)
    res = _run(bin_ / "spacephys", "compile", "--scene", "two_body", cwd=game, env=env)
    assert res.stdout.startswith("[1/1] two_body: ") and "kernels.step.run" in res.stdout
    assert str(tmp_path / "venv") in res.stdout          # cached beside the installed package
    res = _run(bin_ / "spacephys", "run", "two_body", "--duration", "1", "--quiet", cwd=game,
               env=env)
    assert "scene         two_body (2D, 2 bodies" in res.stdout
    assert "compiling" not in res.stderr                 # loaded what compile left
    assert len(_run(bin_ / "spacephys", "scenarios", cwd=game, env=env).stdout.splitlines()) \
        == len(list((ROOT / "spacephys" / "scenarios").glob("*.toml")))
    quickstart = re.search(r"<!-- quickstart -->\s*```python\n(.*?)```",
                           (ROOT / "README.md").read_text(), re.S).group(1)
    res = _run(bin_ / "python", "-c", quickstart, cwd=game, env=env)
    assert "energy error" in res.stdout
    res = _run(bin_ / "python", "-m", "spacephys", "cache", "info", cwd=game, env=env)
    assert "cache         beside the package" in res.stdout
    package = Path(_run(bin_ / "python", "-c", "import spacephys, os; "
                        "print(os.path.dirname(spacephys.__file__))", cwd=game,
                        env=env).stdout.strip())
    # what the README says to do before uninstalling: then nothing is left behind
    res = _run(bin_ / "spacephys", "cache", "clear", cwd=game, env=env)
    assert res.stdout.startswith("deleted ") and not res.stdout.startswith("deleted 0 ")
    _run(bin_ / "python", "-m", "pip", "uninstall", "--yes", "--quiet", "spacephys", env=env)
    assert not package.exists(), sorted(p.name for p in package.rglob("*"))[:10]


@pytest.mark.parametrize("python", _other_pythons() or [None],
                         ids=lambda p: "none found" if p is None else Path(p).name)
def test_the_wheel_runs_on_the_other_pythons_this_machine_has(dist, tmp_path, python):
    if python is None:      # nothing to try here: say so in the test's name, assert the search
        assert not _other_pythons()
        return
    bin_ = _fresh(python, tmp_path / "venv", dist[0])
    res = _run(bin_ / "spacephys", "run", "two_body", "--duration", "0.5", "--quiet",
               cwd=tmp_path, env=_env(tmp_path))
    assert "scene         two_body (2D, 2 bodies" in res.stdout


def test_the_sdist_is_the_package_and_what_builds_it(dist):
    _, sdist = dist
    with tarfile.open(sdist) as tar:
        names = [n.split("/", 1)[1] for n in tar.getnames() if "/" in n]
        info = tar.extractfile(next(m for m in tar.getmembers()
                                    if m.name.endswith("/PKG-INFO") and m.name.count("/") == 1))
        meta = info.read().decode()
    assert "pyproject.toml" in names and "LICENSE" in names and "README.md" in names
    shipped = {f"spacephys/scenarios/{p.name}" for p in (ROOT / "spacephys/scenarios").iterdir()}
    assert shipped <= set(names)
    # no half of the test suite: its tests need the repository (docs, examples, data)
    assert not [n for n in names if n.startswith("tests")]
    assert f"Version: {spacephys.__version__}" in meta
    for minor in ("3.11", "3.12", "3.13"):
        assert f"Classifier: Programming Language :: Python :: {minor}" in meta


def test_the_version_is_written_once(dist):
    wheel, _ = dist
    with zipfile.ZipFile(wheel) as z:
        meta = z.read(next(n for n in z.namelist() if n.endswith("METADATA"))).decode()
        assert not [n for n in z.namelist() if n.endswith((".nbi", ".nbc"))]
    assert f"Version: {spacephys.__version__}" in meta
    assert re.search(r'^dynamic = \["version"\]', (ROOT / "pyproject.toml").read_text(), re.M)
    written = [p for p in ROOT.joinpath("spacephys").rglob("*.py")
               if re.search(r"__version__ = ", p.read_text())]
    assert written == [ROOT / "spacephys" / "__init__.py"]
