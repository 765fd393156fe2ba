"""Where the compiled machine code goes (spacephys/cache.py), tried as other users meet it: a
copy of the package that cannot be written (a system install), a home that cannot be
written (a service account), both, and NUMBA_CACHE_DIR; each in fresh processes run as
another user (as root: `nobody`, for whom a root-owned folder is read-only)."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

import spacephys as sp

ROOT = Path(__file__).resolve().parents[1]
NOBODY = 65534

# the package's own kernel with the least to compile, then what the cache module chose
PROBE = """
import json, warnings
warnings.simplefilter("always")
with warnings.catch_warnings(record=True) as said:
    import spacephys
    from spacephys import cache
from numba.core import event
from spacephys.precompile import Compiles
listener = Compiles()
event.register("numba:compile", listener)
import numpy as np
from spacephys.kernels.diagnostics import add
add(1.0, 0.0, 2.0)
print(json.dumps({"package": spacephys.__file__, "where": cache.WHERE,
                  "folder": None if cache.FOLDER is None else str(cache.FOLDER),
                  "files": [str(f) for f in cache.files()], "compiled": list(listener.kernels),
                  "warnings": [str(w.message) for w in said]}))
"""


def _as_other_user():
    return os.geteuid() == 0 if hasattr(os, "geteuid") else False


def _folder(path, writable):
    """A folder the probe's user can (or cannot) write."""
    path.mkdir(parents=True, exist_ok=True)
    if _as_other_user():
        os.chown(path, NOBODY if writable else 0, NOBODY if writable else 0)
        path.chmod(0o755)
    else:
        path.chmod(0o755 if writable else 0o555)
    return path


@pytest.fixture
def place():
    """run(package_writable, home_writable, tmp_writable, env) -> (its folder, the two
    probes' JSON); in a folder of /tmp that the other user can reach (pytest's are private)"""
    top = Path(tempfile.mkdtemp(prefix="spacephys-cache-test-"))
    top.chmod(0o755)

    def run(package_writable, home_writable, tmp_taken=False, env=()):
        case = top / f"case{len(list(top.iterdir()))}"
        _folder(case, False)
        code = case / "code"
        shutil.copytree(ROOT / "spacephys", code / "spacephys",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for d in [code, *[p for p in (code / "spacephys").rglob("*") if p.is_dir()],
                  code / "spacephys"]:
            _folder(d, package_writable)
        home, tmp = _folder(case / "home", home_writable), _folder(case / "tmp", True)
        if tmp_taken:        # the temporary cache folder's name taken by another user
            uid = NOBODY if _as_other_user() else os.getuid()
            taken = tmp / f"spacephys-cache-{uid}"
            taken.mkdir()
            if not _as_other_user():
                taken.chmod(0o777)             # one's own, but anyone could plant code in it
        environ = {k: v for k, v in os.environ.items()
                   if not k.startswith("NUMBA_") and k not in ("XDG_CACHE_HOME", "PYTHONPATH")}
        environ.update(HOME=str(home), TMPDIR=str(tmp), PYTHONPATH=str(code))
        for key, name in dict(env).items():             # a folder of the case's, writable
            environ[key] = str(_folder(case / name, True))
        user = dict(user=NOBODY, group=NOBODY) if _as_other_user() else {}
        out = []
        for _ in range(2):                      # the second process finds what the first left
            res = subprocess.run([sys.executable, "-c", PROBE], env=environ, cwd=case,
                                 capture_output=True, text=True, timeout=300, **user)
            assert res.returncode == 0, res.stderr
            out.append(json.loads(res.stdout.strip().splitlines()[-1]))
        assert out[0]["package"] == str(code / "spacephys" / "__init__.py")
        return case, out
    yield run
    shutil.rmtree(top)


def test_a_writable_package_keeps_its_machine_code_beside_it(place):
    case, (first, second) = place(package_writable=True, home_writable=False)
    assert first["where"] == "package" and first["folder"] is None and not first["warnings"]
    assert first["compiled"] and first["files"]
    assert all(f.startswith(str(case / "code" / "spacephys")) and "__pycache__" in f
               for f in first["files"])
    assert second["compiled"] == []                          # loaded from the cache


def test_a_read_only_package_caches_in_the_users_cache_folder(place):
    case, (first, second) = place(package_writable=False, home_writable=True)
    assert first["where"] == "user" and not first["warnings"]
    assert first["folder"] == str(case / "home" / ".cache" / "spacephys")
    assert first["files"] and all(f.startswith(first["folder"]) for f in first["files"])
    assert not list((case / "code").rglob("*.nbi"))
    assert second["compiled"] == [] and second["files"] == first["files"]


def test_nothing_writable_but_the_temporary_folder_warns_and_caches_there(place):
    case, (first, second) = place(package_writable=False, home_writable=False)
    assert first["where"] == "temporary"
    assert first["folder"].startswith(str(case / "tmp" / "spacephys-cache-"))
    assert "which the system may empty" in first["warnings"][0]
    assert first["files"] and second["compiled"] == []


def test_no_folder_of_ones_own_turns_caching_off_with_a_warning_and_still_runs(place):
    case, (first, second) = place(package_writable=False, home_writable=False, tmp_taken=True)
    assert first["where"] == "off" and "nothing is cached" in first["warnings"][0]
    assert first["compiled"] and second["compiled"] == first["compiled"]   # compiled again
    assert not list(case.rglob("*.nbi"))


def test_numba_cache_dir_is_honoured(place):
    case, (first, second) = place(package_writable=True, home_writable=True,
                                  env={"NUMBA_CACHE_DIR": "given"})
    given = case / "given"
    assert first["where"] == "NUMBA_CACHE_DIR" and first["folder"] == str(given)
    assert first["files"] and all(f.startswith(str(given)) for f in first["files"])
    assert second["compiled"] == []


def test_the_compile_message_names_the_folder_used_and_compile_then_loads(tmp_path):
    cache = tmp_path / "cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    exe = Path(sys.executable).parent / "spacephys"
    res = subprocess.run([str(exe), "compile", "--scene", "two_body"], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert f"machine code cache: {cache})" in res.stderr          # the announcement
    assert res.stdout.startswith("[1/1] two_body: ") and "kernels.step.run" in res.stdout
    res = subprocess.run([str(exe), "run", "two_body", "--duration", "0.1", "--quiet"],
                         env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0 and "compiling" not in res.stderr, res.stderr
    info = subprocess.run([str(exe), "cache", "info"], env=env, capture_output=True,
                          text=True).stdout
    assert "cache         NUMBA_CACHE_DIR" in info and f"folder        {cache}" in info
    files = int(info.split(" MB in ")[1].split()[0])
    assert files > 20
    res = subprocess.run([str(exe), "cache", "clear"], env=env, capture_output=True, text=True)
    assert res.stdout.startswith(f"deleted {files} files")
    assert not list(cache.rglob("*.nbi"))


def test_compile_runs_targets_side_by_side_and_later_processes_load_them(tmp_path):
    code = """
import json, sys
import spacephys as sp
done = sp.compile(scene=["two_body", "figure_eight"], jobs=2)
print(json.dumps([[c.target, len(c.kernels)] for c in done]))
"""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    runs = [json.loads(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                      capture_output=True, text=True).stdout)
            for _ in range(2)]
    assert [t for t, _ in runs[0]] == ["two_body", "figure_eight"]
    assert all(k > 5 for _, k in runs[0])              # each compiled in its own process
    assert runs[1] == [["two_body", 0], ["figure_eight", 0]]


def test_compile_a_world_a_scenario_file_and_what_all_names(tmp_path):
    """sp.compile(world) steps a copy (the World is not changed) and leaves nothing for the
    World's own first step to compile; `spacephys compile --scenario FILE --jobs 2`; --all
    names every shipped scenario and built-in scene; a bad --jobs is named."""
    from numba.core import event
    from spacephys.precompile import Compiles, targets
    from spacephys.scenario import shipped
    from spacephys.scenes import SCENES
    w, _ = sp.load_scenario("two_body").build()
    before = w.digest()
    done = sp.compile(w)
    assert [c.target for c in done] == ["world"] and w.digest() == before and w.t == 0.0
    listener = Compiles()
    event.register("numba:compile", listener)
    try:
        w.step(1)
    finally:
        event.unregister("numba:compile", listener)
    assert listener.kernels == {} and w.t > 0.0
    mine = tmp_path / "mine.toml"
    mine.write_text((Path(sp.__file__).parent / "scenarios" / "two_body.toml").read_text())
    exe = Path(sys.executable).parent / "spacephys"
    res = subprocess.run([str(exe), "compile", "--scenario", str(mine), "--jobs", "2"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"[1/1] {mine}: ") and "1 compiled" in res.stdout
    every = [label for label, _, _ in targets(every=True)]
    assert sorted(every) == sorted(set(shipped()) | set(SCENES)) and len(every) == len(set(every))
    res = subprocess.run([str(exe), "compile", "--scene", "two_body", "--jobs", "0"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert res.returncode == 2 and "jobs = 0" in res.stderr and "Traceback" not in res.stderr


# a kernel of one's own, cached in NUMBA_CACHE_DIR, called with the types on the command line
KERNEL = """
from spacephys._jit import kernel

@kernel
def plus_one(x):
    return x + 1
"""
CALL = """
import json, sys, time
import plus_mod
print("calling", flush=True)
t0 = time.perf_counter()
got = [plus_mod.plus_one(eval(a)) for a in sys.argv[1:]]
print(json.dumps({"got": got, "took": time.perf_counter() - t0,
                  "hits": sum(plus_mod.plus_one.stats.cache_hits.values()),
                  "types": sorted(str(s[0]) for s in plus_mod.plus_one.overloads)}))
"""


def _own_kernel(tmp_path):
    (tmp_path / "plus_mod.py").write_text(KERNEL)
    (tmp_path / "call.py").write_text(CALL)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))
    return [sys.executable, str(tmp_path / "call.py")], env


def test_an_entry_whose_file_holds_another_entrys_code_is_compiled_again(tmp_path):
    """numba numbers a new entry's file after reading the index: two processes saving at once
    (test workers, compile helpers) could leave one entry's file holding the other's code,
    which numba would load as the code asked for."""
    call, env = _own_kernel(tmp_path)
    def run(*args):
        out = subprocess.run(call + list(args), env=env, check=True, capture_output=True,
                             text=True).stdout
        return json.loads(out.split("\n")[1])
    assert run("1", "1.5")["got"] == [2, 2.5]
    codes = sorted((tmp_path / "cache").rglob("plus_mod.plus_one-*.nbc"))
    assert len(codes) == 2
    first, second = (c.read_bytes() for c in codes)
    codes[0].write_bytes(second)                 # the two entries' files swapped
    codes[1].write_bytes(first)
    healed = run("1", "1.5")
    assert healed["got"] == [2, 2.5] and healed["types"] == ["float64", "int64"]
    assert healed["hits"] == 0                   # both compiled again, and saved over
    assert run("1", "1.5")["hits"] == 2


def test_a_save_waits_for_anothers_to_end(tmp_path):
    """cache.saving: a process that saves machine code waits while another holds the lock."""
    call, env = _own_kernel(tmp_path)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom spacephys import cache\nwith cache.saving():\n"
         "    print('held', flush=True)\n    sys.stdin.read()"],
        env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    saver = None
    try:
        assert holder.stdout.readline() == "held\n"
        saver = subprocess.Popen(call + ["1"], env=env, stdout=subprocess.PIPE, text=True)
        assert saver.stdout.readline() == "calling\n"
        time.sleep(4.0)                       # the tiny kernel compiles in well under a second
        assert not list((tmp_path / "cache").rglob("plus_mod.plus_one-*.nbi"))
        holder.stdin.close()
        done = json.loads(saver.stdout.readline())
        assert done["got"] == [2] and done["took"] > 3.5
        assert saver.wait(60) == 0 and holder.wait(60) == 0
        assert len(list((tmp_path / "cache").rglob("plus_mod.plus_one-*.nbi"))) == 1
    finally:
        for p in (holder, saver):
            if p is not None and p.poll() is None:
                p.kill()
