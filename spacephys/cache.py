"""Where numba keeps spacephys's compiled machine code: chosen once, when spacephys is first
imported and before any kernel is defined, so that an install anywhere either caches or says
why it cannot. The first that can be written:

1. NUMBA_CACHE_DIR, when it is set;
2. beside the package (its __pycache__ folders): a checkout, one's own virtual environment;
3. a per-user folder: $XDG_CACHE_HOME/spacephys or ~/.cache/spacephys (%LOCALAPPDATA%\\spacephys
   on Windows, ~/Library/Caches/spacephys on macOS), for a read-only install;
4. a folder of one's own in the system's temporary folder, with a CacheWarning;
5. none: nothing is cached and every run compiles again, with a CacheWarning.

A folder other than the package's is handed to numba as NUMBA_CACHE_DIR (its config and the
environment, so that worker processes cache in the same place). `spacephys cache info` says
which folder and how much is in it; `spacephys cache clear` deletes this install's machine
code (run it before `pip uninstall`: pip removes only the files it installed).
"""
import contextlib
import getpass
import hashlib
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numba

# as numba names a source file's folder (os.path.abspath, no symlinks resolved)
PACKAGE = Path(os.path.dirname(os.path.abspath(__file__)))
SOURCES = (PACKAGE, PACKAGE / "kernels")      # the folders whose modules define kernels
_STAMP = "kernels.sha256"


class CacheWarning(UserWarning):
    """Compiled machine code is kept somewhere temporary, or not at all."""


def _writable(folder):
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
        return True
    except OSError:
        return False


def _mine(folder):
    """A folder in a shared place that this user made and alone can write (not a trap another
    user set: numba would load the machine code it finds there)."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = folder.stat()
    except OSError:
        return False
    if hasattr(os, "getuid") and (st.st_uid != os.getuid() or st.st_mode & 0o022):
        return False
    return _writable(folder)


def user_folder():
    """The per-user cache folder for this platform (None when there is no home)."""
    try:
        if sys.platform == "win32":
            base = os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local"
        elif sys.platform == "darwin":
            base = Path.home() / "Library" / "Caches"
        else:
            base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    except (RuntimeError, KeyError):
        return None
    return Path(base) / "spacephys"


def _choose():
    """(folder or None, where): where is "NUMBA_CACHE_DIR", "package", "user", "temporary"
    or "off"; folder None for "package" (numba's own place beside the sources) and "off"."""
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        if _writable(Path(given)):
            return Path(given), "NUMBA_CACHE_DIR"
        warnings.warn(f"NUMBA_CACHE_DIR = {given!r} cannot be written: spacephys caches its "
                      f"machine code elsewhere", CacheWarning, stacklevel=3)
    if all(_writable(src / "__pycache__") for src in SOURCES):
        return None, "package"
    user = user_folder()
    if user is not None and _writable(user):
        return user, "user"
    name = f"spacephys-cache-{os.getuid() if hasattr(os, 'getuid') else getpass.getuser()}"
    temporary = Path(tempfile.gettempdir()) / name
    if _mine(temporary):
        warnings.warn(f"neither the package's folder nor a per-user cache folder can be "
                      f"written: spacephys caches its machine code in {temporary}, which the "
                      f"system may empty (set NUMBA_CACHE_DIR to keep it)", CacheWarning,
                      stacklevel=3)
        return temporary, "temporary"
    warnings.warn("no folder can be written (the package's, a per-user cache folder, the "
                  "temporary folder): nothing is cached and every run compiles again; set "
                  "NUMBA_CACHE_DIR to a folder that can be written", CacheWarning, stacklevel=3)
    return None, "off"


FOLDER, WHERE = _choose()
ENABLED = WHERE != "off"
if FOLDER is not None:
    os.environ["NUMBA_CACHE_DIR"] = numba.config.CACHE_DIR = str(FOLDER)


def place():
    """Where the machine code goes, in a few words (the compile message names it)."""
    return {"package": f"beside the package, in {PACKAGE}{os.sep}…{os.sep}__pycache__",
            "off": "off, every run compiles again"}.get(WHERE, str(FOLDER))


def folders():
    """The folders that hold this install's machine code, one per source folder."""
    if WHERE == "off":
        return []
    if FOLDER is None:
        return [src / "__pycache__" for src in SOURCES]
    # numba's name for a source folder's cache: its name and the SHA-1 of its path
    return [FOLDER / f"{src.name}_{hashlib.sha1(str(src).encode()).hexdigest()}"
            for src in SOURCES]


def files():
    """This install's cached machine code: numba's index (.nbi) and code (.nbc) files."""
    return [f for d in folders() if d.is_dir() for f in sorted(d.iterdir())
            if f.suffix in (".nbi", ".nbc")]


def describe():
    """Where the cache is, how it was chosen, and its size: for `spacephys cache info`."""
    how = {"NUMBA_CACHE_DIR": "NUMBA_CACHE_DIR", "package": "beside the package",
           "user": "the per-user cache folder", "temporary": "a temporary folder",
           "off": "off: nothing is cached"}[WHERE]
    found = files()
    size = sum(f.stat().st_size for f in found)
    lines = [f"cache         {how}"]
    lines += [f"folder        {d}" for d in folders()]
    functions = sum(f.suffix == ".nbi" for f in found)
    lines.append(f"holds         {functions} compiled functions, {size / 1e6:.1f} MB in "
                 f"{len(found)} files")
    return "\n".join(lines)


def clear():
    """Delete this install's cached machine code; (files, bytes) deleted."""
    found = files()
    size = sum(f.stat().st_size for f in found)
    for f in found:
        f.unlink(missing_ok=True)
    if folders():
        _stamp().unlink(missing_ok=True)
        _lock().unlink(missing_ok=True)
    if FOLDER is not None:
        for d in folders():
            shutil.rmtree(d, ignore_errors=True)
    return len(found), size


def purge_stale():
    """Delete cached machine code compiled from older kernel sources.

    numba checks only the caller's own file when it loads a cached function, so a kernel that
    calls into an edited module (integrate.py into gravity.py) would silently run the old
    callee. A digest of every kernel source, kept beside the cache, catches that.
    """
    if WHERE == "off":
        return
    sources = [PACKAGE / "_jit.py"] + sorted((PACKAGE / "kernels").glob("*.py"))
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sources)).hexdigest()
    stamp = _stamp()
    try:
        if stamp.exists() and stamp.read_text() == digest:
            return
        stamp.parent.mkdir(parents=True, exist_ok=True)
        # one process at a time: test workers import side by side, and one that purged after
        # another had stamped and begun to cache would delete half of that one's new files
        # (an index without its code, or code under another's index)
        with _locked(_lock()):
            if stamp.exists() and stamp.read_text() == digest:
                return
            for f in files():
                f.unlink(missing_ok=True)
            tmp = stamp.with_suffix(f".{os.getpid()}")
            tmp.write_text(digest)
            tmp.replace(stamp)
    except OSError:
        pass    # another process is at it; sources cannot change under a read-only install


def saving():
    """Within it, no other process saves machine code into this install's cache or purges it.
    numba reads a kernel's index, numbers a new entry's file after the entries it read and
    writes the index back: two processes saving two entries at once (test workers, compile
    helpers) could take one number, and one entry's file would then hold the other's code."""
    if WHERE == "off":
        return contextlib.nullcontext()
    lock = _lock()
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
    except OSError:
        return contextlib.nullcontext()    # numba's save fails on its own, and says so
    return _locked(lock)


def _stamp():
    """The file holding the digest of the kernel sources the cache was compiled from."""
    return folders()[0] / _STAMP


def _lock():
    """The file whose lock the purge and every save take."""
    return _stamp().with_suffix(".lock")


class _locked:
    """An exclusive lock on a file while the block runs (fcntl's; none where it is
    missing: Windows, whose test runs are not side by side here)."""

    def __init__(self, path):
        self.path = path

    def __enter__(self):
        self.fd = os.open(self.path, os.O_CREAT | os.O_RDWR)
        try:
            import fcntl
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        except ImportError:
            pass
        return self

    def __exit__(self, *exc):
        os.close(self.fd)             # closing releases the lock
