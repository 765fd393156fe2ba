#!/usr/bin/env python3
"""Set up and run spacephys with nothing but Python 3.11: `python3.11 dev.py run|test|bench ...`.

The first call makes a virtual environment in .venv and installs spacephys (editable) with its
test extra; later calls reinstall only when pyproject.toml changed.
  run [ARGS]    spacephys run ARGS  (the default scene, then a summary)
  test [ARGS]   the whole suite: a worker per core (pytest-xdist, whole files to a worker), then
                the tests that compare measured times (marker "timed") alone; with ARGS,
                python -m pytest ARGS. "no tests collected" is a failure
  bench [ARGS]  spacephys bench ARGS (default: gravity)
"""
import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PYTHON = BIN / ("python.exe" if os.name == "nt" else "python")
STAMP = VENV / ".spacephys-installed"


def ensure_env():
    if sys.version_info < (3, 11):
        sys.exit(f"dev.py: spacephys needs Python >= 3.11, this is {sys.version.split()[0]}")
    if not PYTHON.exists():
        print(f"dev.py: creating {VENV}", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    want = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    if STAMP.exists() and STAMP.read_text() == want:
        return
    print("dev.py: installing spacephys and its test extra into .venv", flush=True)
    subprocess.run([PYTHON, "-m", "pip", "install", "--quiet", "--upgrade", "pip"], check=True)
    subprocess.run([PYTHON, "-m", "pip", "install", "--quiet", "-e", f"{ROOT}[test]"], check=True)
    STAMP.write_text(want)


def pytest(*args):
    code = subprocess.run([PYTHON, "-m", "pytest", *args], cwd=ROOT).returncode
    if code == 5:         # pytest: no tests collected; a run that tested nothing proves nothing
        print("dev.py: pytest collected no tests: failing", file=sys.stderr)
        return 1
    return code


def test(args):
    """The whole suite: most of a clean run is numba compiling, one core per process, so a
    worker per core takes whole files (a file's tests share their kernels); then the tests
    that compare measured times, alone. With arguments, pytest with those arguments."""
    if args:
        return pytest(*args)
    parallel = pytest("-n", "auto", "--dist", "loadfile", "-m", "not timed")
    timed = pytest("-m", "timed")
    return parallel or timed


def main(argv):
    if not argv or argv[0] not in ("run", "test", "bench"):
        print(__doc__)
        return 2
    command, args = argv[0], argv[1:]
    ensure_env()
    if command == "test":
        return test(args)
    if command == "bench" and not args:
        args = ["gravity"]
    return subprocess.run([BIN / "spacephys", command, *args], cwd=ROOT).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
