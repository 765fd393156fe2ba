"""The compile notice (_jit.announced): a line on stderr while numba compiles, and only then."""
import time

from spacephys import _jit


def test_a_long_compilation_is_announced_with_where_it_is_cached(capsys):
    with _jit.announced("the test kernel", after=0.05):
        time.sleep(0.3)
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("spacephys: compiling the test kernel with numba; this happens "
                             "once per machine and version (the machine code is cached in ")
    assert err[1].startswith("spacephys: compiled in 0.")


def test_a_quick_load_from_the_cache_says_nothing(capsys):
    with _jit.announced("the test kernel", after=0.5):
        time.sleep(0.01)
    assert capsys.readouterr().err == ""
