"""The optional dependencies: which extra of `pip install 'spacephys[EXTRA]'` brings each, and
one check that names it, made before any work starts (the CLI checks a command's needs before
compiling anything)."""
import importlib.util

# import name -> (the package on the index, the extra that installs it)
EXTRAS = {
    "rebound": ("rebound", "bench"),
    "pytreegrav": ("pytreegrav", "bench"),
    "scipy": ("scipy", "bench"),
    "matplotlib": ("matplotlib", "plot"),
    "distributed": ("distributed", "sweep"),
    "pygame": ("pygame-ce", "game"),
    "jplephem": ("jplephem", "ephemeris"),
    "skyfield_data": ("skyfield-data", "test"),
}


class MissingExtra(ImportError):
    """An optional dependency is not installed; the message names the extra that brings it."""


def require(what, *modules):
    """Raise MissingExtra naming every missing module of `modules` (import names of EXTRAS)
    and the extras to install, for `what` (e.g. "spacephys bench tree"); nothing is imported."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        packages = ", ".join(EXTRAS[m][0] for m in missing)
        extras = ",".join(dict.fromkeys(EXTRAS[m][1] for m in missing))
        raise MissingExtra(f"{what} needs {packages}: pip install 'spacephys[{extras}]'")
